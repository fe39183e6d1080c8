"""Fuzzing the CMUcam4 driver: garbage on a real pseudo-terminal, whatever it asks.

Each input is one operation of the driver (a command, the version, a snapshot, a packet
of a tracking or statistics stream, a resync, now and then a whole connect), answered
with a fuzzed reply written to the pty before the driver reads: pieces of the real
protocol (ACK, NCK, the prompt, ERR:, MSG:, the banner, DAT: columns, T and S packets,
line-mode bitmaps), mutated, cut short, mixed with random and non-ASCII bytes. The
driver may refuse any of it with a ``CMUcam4Error`` (or end a stream); anything else
escaping it is an unhandled exception.
"""

from __future__ import annotations

import contextlib
import errno
import os
import random
import threading
import time
from collections.abc import Callable
from typing import Any

from backend.camera.cmucam4 import CMUcam4, CMUcam4Error
from bench.fuzz.watch import Watch

_NUMBERS = ("0", "1", "-1", "255", "65536", "99999999999999999999", "x", "", "1.5", "\xff")


def _packet(rng: random.Random, tag: str, n: int) -> bytes:
    count = n if rng.random() < 0.7 else rng.randint(0, n + 3)
    fields = [
        str(rng.randint(0, 255)) if rng.random() < 0.7 else rng.choice(_NUMBERS)
        for _ in range(count)
    ]
    return (tag + " " + " ".join(fields) + "\r").encode("latin-1")


def _piece(rng: random.Random) -> bytes:
    pieces: list[Callable[[], bytes]] = [
        lambda: b"ACK\r",
        lambda: b"NCK\r:",
        lambda: b":",
        lambda: b"ERR: Camera Timeout Error\r:",
        lambda: b"MSG: " + rng.randbytes(rng.randint(0, 20)) + b"\r",
        lambda: b"\rCMUcam4 v1.02\r:",
        lambda: b"CMUcam4 v" + rng.randbytes(rng.randint(0, 8)) + b"\r",
        lambda: b"DAT: " + rng.randbytes(rng.choice((120, 119, 121, 7))) + b"\r",
        lambda: _packet(rng, "T", 8),
        lambda: _packet(rng, "S", 12),
        lambda: b"F " + rng.randbytes(rng.choice((600, 599, 10))) + b"\r",
        lambda: rng.randbytes(rng.randint(1, 200)),
        lambda: bytes(rng.randrange(128, 256) for _ in range(rng.randint(1, 40))),
        lambda: b"\r" * rng.randint(1, 5),
    ]
    return rng.choice(pieces)()


def reply(rng: random.Random) -> bytes:
    """One fuzzed answer: protocol pieces and garbage, sometimes cut short."""
    # Half start as the camera would (ACK): the parsing behind it gets the garbage.
    head = b"ACK\r" if rng.random() < 0.5 else b""
    data = head + b"".join(_piece(rng) for _ in range(rng.randint(1, 6)))
    if rng.random() < 0.2:
        data = data[: rng.randrange(len(data) + 1)]
    return data[:2000]


def _stream(cam: CMUcam4, start: Callable[[], Any], rng: random.Random) -> None:
    with start() as stream:
        for _ in range(rng.randint(1, 3)):
            next(stream)


def _ops(rng: random.Random) -> list[tuple[str, float, Callable[[CMUcam4], Any]]]:
    return [
        (
            "command",
            0.25,
            lambda c: c.command(rng.choice(("GV", "GT", "GW", "DM 0", "L0", "PM 0"))),
        ),
        ("version", 0.1, lambda c: c.get_version()),
        ("snapshot", 0.15, lambda c: c.snapshot(80, 60)),
        ("statistics", 0.15, lambda c: _stream(c, c.statistics, rng)),
        ("track", 0.15, lambda c: _stream(c, c.track, rng)),
        ("resync", 0.15, lambda c: c.resync()),
        ("connect", 0.05, lambda c: c.connect()),
    ]


def run(n: int, seed: int) -> dict[str, Any]:
    """Put ``n`` fuzzed exchanges to the driver over a pty; what came of them."""
    rng = random.Random(seed)
    ops = _ops(rng)
    master, slave = os.openpty()
    os.set_blocking(master, False)
    stop = threading.Event()
    sent_by_driver = [0]

    def drain() -> None:  # what the driver writes is read and dropped (keeps it unblocked)
        while not stop.is_set():
            try:
                data = os.read(master, 65536)
                sent_by_driver[0] += len(data)
            except BlockingIOError:
                time.sleep(0.002)
            except OSError:
                return

    drainer = threading.Thread(target=drain, name="fuzz-pty-drain", daemon=True)
    drainer.start()
    cam = CMUcam4(os.ttyname(slave), timeout=0.02, reset_timeout=0.02, tries=1)
    refused: dict[str, int] = {}
    completed: dict[str, int] = {}
    escaped: list[str] = []
    dropped = 0
    t0 = time.perf_counter()
    with Watch() as watch:
        cam.open()
        try:
            for _ in range(n):
                name, _, op = rng.choices(ops, weights=[w for _, w, _ in ops])[0]
                cam.line_mode = rng.random() < 0.3
                try:
                    os.write(master, reply(rng))
                except OSError as exc:  # the pty's buffer is full: the driver is behind
                    if exc.errno != errno.EAGAIN:
                        raise
                    dropped += 1
                try:
                    op(cam)
                    completed[name] = completed.get(name, 0) + 1
                except (CMUcam4Error, StopIteration) as exc:
                    key = f"{name}: {type(exc).__name__}"
                    refused[key] = refused.get(key, 0) + 1
                except Exception as exc:  # what the bar counts: escaped the driver
                    if len(escaped) < 5:
                        escaped.append(f"{name}: {type(exc).__name__}: {exc}"[:300])
                    watch.count += 1
        finally:
            stop.set()
            drainer.join(2.0)
            cam.close()
            for fd in (master, slave):
                with contextlib.suppress(OSError):
                    os.close(fd)
    return {
        "inputs": n,
        "completed": dict(sorted(completed.items())),
        "refused_by_the_driver": dict(sorted(refused.items())),
        "unhandled_exceptions": watch.count,
        "samples": escaped + watch.samples,
        "garbage_bytes_skipped": cam.garbage_bytes,
        "replies_not_written": dropped,
        "wall_s": round(time.perf_counter() - t0, 2),
    }
