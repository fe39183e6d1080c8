"""How the pipeline compiles its inner loops (numba): once per machine, cached beside
the module or in ``NUMBA_CACHE_DIR``, and without the GIL, so that the station's other
threads run while a frame is measured.

Loops over a few hundred numbers written as numpy expressions spend their time in
the calls' overhead, not in the arithmetic; compiled, they cost what the arithmetic
costs.
"""

from __future__ import annotations

import numba

compiled = numba.njit(cache=True, nogil=True)
