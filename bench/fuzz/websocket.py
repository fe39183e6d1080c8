"""Fuzzing ``/ws`` on a real uvicorn server: random first and later messages.

Each input is one socket: one to three messages (random JSON, the protocol's own
messages with wrong fields, garbage text, non-ASCII and lone surrogates, binary, an
oversized message), then whatever the server sends until it closes or goes quiet.
Viewing is switched between open and token-required every 500 inputs. The server
answers garbage with a close code; the bar counts tracebacks, not closes.
"""

from __future__ import annotations

import json
import random
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidStatus, WebSocketException
from websockets.sync.client import connect

from bench.fuzz.http import random_json
from bench.fuzz.server import TOKEN, Server
from bench.fuzz.watch import Watch

_TYPES = ("auth", "ping", "subscribe", "hello", "", "AUTH", "unknown", 5, None)


def message(rng: random.Random) -> str | bytes:
    """One fuzzed client message."""
    roll = rng.random()
    if roll < 0.35:
        data: Any = {"type": rng.choice(_TYPES)}
        if rng.random() < 0.7:
            data["token"] = rng.choice(
                (TOKEN, "wrong", "t\u00f6k\u00e9n", "\ud800", 12, None, "", TOKEN + "x", [TOKEN])
            )
        if rng.random() < 0.4:
            data["threshold"] = random_json(rng)
        try:
            return json.dumps(data)
        except (ValueError, TypeError):
            return json.dumps(data, ensure_ascii=True)
    if roll < 0.6:
        return json.dumps(random_json(rng))
    if roll < 0.75:
        return rng.choice(
            ("", "{", "[" * 4000, "null", '"\\ud800"', "\u0000", "x" * 5000, '{"type"}')
        )
    if roll < 0.9:
        return rng.randbytes(rng.randint(0, 500))
    return "y" * (1 << 20) + "z"  # over the server's message limit


def run(n: int, seed: int) -> dict[str, Any]:
    rng = random.Random(seed)
    closes: Counter[str] = Counter()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, Server(Path(tmp)) as server, Watch() as watch:
        url = server.url.replace("http:", "ws:") + "/ws"
        runtime = server.station.runtime
        for i in range(n):
            if i % 500 == 0:
                runtime.update({"view_requires_token": (i // 500) % 2 == 1})
            try:
                with connect(url, open_timeout=10, max_size=None, close_timeout=2) as sock:
                    for _ in range(rng.randint(1, 3)):
                        sock.send(message(rng))
                    for _ in range(4):
                        sock.recv(timeout=0.05)
                closes["still open (closed by us)"] += 1
            except ConnectionClosed as exc:
                code = exc.rcvd.code if exc.rcvd is not None else None
                closes[f"closed {code}"] += 1
            except TimeoutError:
                closes["quiet (closed by us)"] += 1
            except (InvalidStatus, WebSocketException, OSError) as exc:
                closes[f"refused: {type(exc).__name__}"] += 1
            except Exception as exc:  # the fuzzing client's own trouble, not the station's
                closes[f"client error: {type(exc).__name__}"] += 1
        runtime.update({"view_requires_token": False})
        with connect(url, open_timeout=10) as sock:
            alive = json.loads(sock.recv(timeout=10))["type"] == "hello"
        rejected = server.station.rejections.to_dict()
    return {
        "inputs": n,
        "outcomes": dict(sorted(closes.items())),
        "sockets_refused_by_the_station": rejected["sockets"],
        "unhandled_exceptions": watch.count,
        "samples": watch.samples,
        "server_alive": alive,
        "wall_s": round(time.perf_counter() - t0, 1),
    }
