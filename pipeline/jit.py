"""How the pipeline compiles its inner loops (numba): once per machine, cached beside
the module or in ``NUMBA_CACHE_DIR``, and without the GIL, so that the station's other
threads run while a frame is measured.

Loops over a few hundred numbers written as numpy expressions spend their time in
the calls' overhead, not in the arithmetic; compiled, they cost what the arithmetic
costs. ``solve`` is the small linear solve their Gauss-Newton steps share,
``column_medians`` the medians the pattern comparison takes and ``popcount`` the
bit count the shape match's overlaps take; ``plain`` and ``pixels`` give the loops
their inputs in the one layout each is compiled for.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

compiled = numba.njit(cache=True, nogil=True)
# ... and where a division by zero must give inf or nan, as numpy's does, not raise
compiled_ieee = numba.njit(cache=True, nogil=True, error_model="numpy")


def plain(a, dtype=np.float64) -> np.ndarray:
    """``a`` as a contiguous, writable array of ``dtype`` (a copy only when it is not
    one): what the compiled loops take, so that each has one signature, the one the
    warm-up compiles (a read-only or strided input would compile another at run time)."""
    out = np.ascontiguousarray(a, dtype)
    return out if out.flags.writeable else out.copy()


def pixels(image) -> np.ndarray:
    """An image the compiled edge loops sample: a uint8 one as it is (the smoothed
    channel; float32 would take four times the memory, and a frame's float copy was
    a full pass over memory that is no longer in cache when the next frame comes),
    any other as float32; contiguous and writable (see `plain`)."""
    return plain(image, np.uint8 if image.dtype == np.uint8 else np.float32)


@intrinsic
def popcount(typingctx, word):
    """The number of bits set in a uint64 (one CPU instruction), for compiled loops."""
    if word != types.uint64:
        return None

    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return types.int64(types.uint64), codegen


@compiled
def solve(A, b):
    """x with A x = b for the compiled loops' small systems (Gaussian elimination,
    partial pivoting), and whether A was not singular."""
    n = A.shape[0]
    M = A.copy()
    x = b.copy()
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(M[r, c]) > abs(M[p, c]):
                p = r
        if abs(M[p, c]) < 1e-300:
            return x, False
        if p != c:
            for k in range(n):
                M[c, k], M[p, k] = M[p, k], M[c, k]
            x[c], x[p] = x[p], x[c]
        for r in range(c + 1, n):
            f = M[r, c] / M[c, c]
            for k in range(c, n):
                M[r, k] -= f * M[c, k]
            x[r] -= f * x[c]
    for c in range(n - 1, -1, -1):
        acc = x[c]
        for k in range(c + 1, n):
            acc -= M[c, k] * x[k]
        x[c] = acc / M[c, c]
    return x, True


@compiled
def column_medians(rows):
    """The median of each column of ``rows`` (N x K, N >= 1), as ``np.median(rows,
    axis=0)`` (float64)."""
    n, k = rows.shape
    out = np.empty(k)
    column = np.empty(n, rows.dtype)
    for c in range(k):
        for i in range(n):
            column[i] = rows[i, c]
        out[c] = np.median(column)
    return out
