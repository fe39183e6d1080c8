"""Run the fuzzers by kind; the JSON the program prints."""

from __future__ import annotations

import platform
import time
from collections.abc import Callable, Iterable
from typing import Any

KINDS = ("mavlink", "cmucam4", "uploads", "bodies", "websocket")


def _runner(kind: str) -> Callable[[int, int], dict[str, Any]]:
    # Imported when asked: each fuzzer brings its own heavy parts (a server, a pty).
    if kind == "mavlink":
        from bench.fuzz import mavlink

        return mavlink.run
    if kind == "cmucam4":
        from bench.fuzz import cmucam4

        return cmucam4.run
    if kind == "uploads":
        from bench.fuzz import http

        return http.run_uploads
    if kind == "bodies":
        from bench.fuzz import http

        return http.run_bodies
    if kind == "websocket":
        from bench.fuzz import websocket

        return websocket.run
    raise ValueError(f"unknown kind {kind!r}; kinds: {', '.join(KINDS)}")


def fuzz(n: int, *, kinds: Iterable[str] = KINDS, seed: int = 0) -> dict[str, Any]:
    """``n`` inputs of each kind; one dict per kind and the verdict."""
    kinds = list(kinds)
    runners = {kind: _runner(kind) for kind in kinds}
    out: dict[str, Any] = {
        "n_per_kind": n,
        "seed": seed,
        "machine": f"{platform.machine()} {platform.system()}",
    }
    t0 = time.perf_counter()
    for kind, run in runners.items():
        out[kind] = run(n, seed)
    out["unhandled_exceptions"] = sum(out[k]["unhandled_exceptions"] for k in kinds)
    out["status_5xx"] = sum(out[k].get("status_5xx", 0) for k in kinds)
    out["no_answer"] = sum(out[k].get("no_answer", 0) for k in kinds)
    out["bars_met"] = not (out["unhandled_exceptions"] or out["status_5xx"] or out["no_answer"])
    out["wall_s"] = round(time.perf_counter() - t0, 1)
    return out
