"""Fuzz and abuse the station: garbage to every input it has, counting what breaks.

``python -m bench.fuzz [--n 10000] [--kinds ...] [--seed 0]`` prints one JSON object:
for each kind of input, how many were sent, what came back, and how many unhandled
exceptions the station raised (any exception that escaped to a thread, the event loop,
uvicorn or a log line with a traceback) and how many 5xx answers it gave. Bars
(issue 15): 0 unhandled exceptions over 10,000 inputs of each kind; 0 5xx.

- ``mavlink``: random bytes, random well-formed frames of every message of the dialect
  (random payloads: NaNs, huge values), the station's own message types with extreme
  values, mutated frames, to a real :class:`~backend.link.VehicleLink` over TCP;
- ``cmucam4``: garbage and mutated replies on a pseudo-terminal to the CMUcam4 driver;
- ``uploads``: random and malformed pictures and decompression bombs to
  ``POST /api/reference`` (bombs also timed and their memory measured);
- ``bodies``: random JSON (and garbage) to every route of the API, with and without
  the token;
- ``websocket``: random messages to ``/ws``, first and later, viewing open or not.

The suite runs a short version (``tests/bench/test_fuzz.py``).
"""

from __future__ import annotations

from bench.fuzz.run import KINDS, fuzz

__all__ = ["KINDS", "fuzz"]
