"""Fuzzing the HTTP API on a real uvicorn server: uploads (and bombs), request bodies."""

from __future__ import annotations

import faulthandler
import json
import random
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx

from bench.fuzz.images import FORMATS, bomb, random_upload
from bench.fuzz.server import AUTH, Server
from bench.fuzz.watch import Watch

_PAD_SIZES = ("0.55", "0.55", "0.55", "1", "20", "nan", "-1", "abc", "", "1e999", "0")


# --- memory -----------------------------------------------------------------------------------
def _rss_kb(field: str) -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    return 0


class PeakRss:
    """This process's peak resident memory during a block, in MB above where it began.

    Resets the kernel's high-water mark (``/proc/self/clear_refs``) where allowed, and
    samples the resident size every millisecond besides (a process may not reset it).
    """

    def __enter__(self) -> PeakRss:
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")
            self._hwm = True
        except OSError:
            self._hwm = False
        self.start = _rss_kb("VmRSS")
        self.peak = self.start
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, name="fuzz-rss", daemon=True)
        self._thread.start()
        return self

    def _sample(self) -> None:
        while not self._stop.wait(0.001):
            self.peak = max(self.peak, _rss_kb("VmRSS"))

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(1.0)
        if self._hwm:
            self.peak = max(self.peak, _rss_kb("VmHWM"))

    @property
    def growth_mb(self) -> float:
        return round((self.peak - self.start) / 1024, 1)


# --- uploads ----------------------------------------------------------------------------------
def _upload(client: httpx.Client, data: bytes, pad_size: str = "0.55") -> httpx.Response:
    return client.post(
        "/api/reference",
        files={"file": ("upload.bin", data, "application/octet-stream")},
        data={"pad_size_m": pad_size},
        headers=AUTH,
    )


def measure_bombs(client: httpx.Client) -> dict[str, Any]:
    """Each format's bomb at 30k, 40k and 100k pixels a side (and real PNG bombs that
    would truly decode): status, seconds to the answer, peak memory growth."""
    cases = [(f, side, False) for f in FORMATS for side in (30_000, 40_000, 100_000)]
    cases += [("png", 20_000, True), ("png", 40_000, True)]
    out: dict[str, Any] = {}
    for fmt, side, real in cases:
        data = bomb(fmt, side, side, real=real)
        with PeakRss() as rss:
            t0 = time.perf_counter()
            r = _upload(client, data)
            seconds = time.perf_counter() - t0
        name = f"{fmt}_{side}" + ("_real" if real else "")
        out[name] = {
            "bytes": len(data),
            "status": r.status_code,
            "seconds": round(seconds, 3),
            "peak_rss_growth_mb": rss.growth_mb,
        }
    cases_out = list(out.values())
    return {
        "cases": out,
        "all_4xx": all(400 <= v["status"] < 500 for v in cases_out),
        "max_seconds": max(v["seconds"] for v in cases_out),
        "max_peak_rss_growth_mb": max(v["peak_rss_growth_mb"] for v in cases_out),
    }


def run_uploads(n: int, seed: int) -> dict[str, Any]:
    rng = random.Random(seed)
    codes: Counter[int] = Counter()
    t0 = time.perf_counter()
    with (
        tempfile.TemporaryDirectory() as tmp,
        Server(Path(tmp)) as server,
        Watch() as watch,
        httpx.Client(base_url=server.url, timeout=120) as client,
    ):
        bombs = measure_bombs(client)
        for _ in range(n):
            try:
                r = _upload(client, random_upload(rng), rng.choice(_PAD_SIZES))
            except httpx.TimeoutException:
                codes[0] += 1  # no answer in a minute: a hang, shown with every thread's stack
                faulthandler.dump_traceback(all_threads=True)
                continue
            codes[r.status_code] += 1
        alive = client.get("/api/health").status_code == 200
    return {
        "inputs": n,
        "status_counts": {str(k): v for k, v in sorted(codes.items())},
        "status_5xx": sum(v for k, v in codes.items() if k >= 500),
        "no_answer": codes.get(0, 0),
        "unhandled_exceptions": watch.count,
        "samples": watch.samples,
        "server_alive": alive,
        "bombs": bombs,
        "wall_s": round(time.perf_counter() - t0, 1),
    }


# --- request bodies ---------------------------------------------------------------------------
_PATH_VALUES = (
    "1", "2", "0", "-1", "999999999999999999999", "abc", "%00", "..", "1.5", "🙂",
    "original", "threshold", "corners", "000001.jpg", "1.jpg", "x.jpg", "%2e%2e", "",
)  # fmt: skip
_FIELDS = (
    "altitude_m", "hold_s", "abort_mode", "strategy", "approach_alt_m", "lost_timeout_s",
    "search_s", "mode", "view_requires_token", "record_frames", "jpeg_quality", "type",
)  # fmt: skip
_ODD_TEXT = ("NaN", "Infinity", "-Infinity", "1e400", "-0", "[" * 5000, "{" * 100, "\x00", "")


def random_json(rng: random.Random, depth: int = 0) -> Any:
    roll = rng.random()
    if depth < 3 and roll < 0.25:
        keys = [rng.choice(_FIELDS) if rng.random() < 0.7 else rng.randbytes(4).hex()]
        keys += [rng.choice(_FIELDS) for _ in range(rng.randint(0, 3))]
        return {k: random_json(rng, depth + 1) for k in keys}
    if depth < 3 and roll < 0.35:
        return [random_json(rng, depth + 1) for _ in range(rng.randint(0, 4))]
    return rng.choice(
        [
            None,
            True,
            False,
            0,
            -1,
            1,
            3,
            1e-300,
            1e300,
            2**64,
            -(2**70),
            rng.uniform(-200, 200),
            rng.randint(-10, 150),
            "",
            "GUIDED",
            "LOITER",
            "RTL",
            "plnd",
            "guided",
            "LAND",
            "4",
            "true",
            "\u00e9\u4e2d\U0001f642",
            "x" * rng.choice((1, 100, 10_000)),
        ]
    )


def _body(rng: random.Random) -> tuple[bytes | None, str | None]:
    roll = rng.random()
    if roll < 0.6:
        return json.dumps(random_json(rng)).encode(), "application/json"
    if roll < 0.75:
        text = rng.choice(_ODD_TEXT)
        field = rng.choice(_FIELDS)
        return (f'{{"{field}": {text}}}' if rng.random() < 0.5 else text).encode(), (
            "application/json"
        )
    if roll < 0.85:
        return rng.randbytes(rng.randint(0, 300)), rng.choice(
            ("application/json", "text/plain", "multipart/form-data; boundary=x", None)
        )
    return None, None


def _headers(rng: random.Random, content_type: str | None) -> dict[str, str]:
    roll = rng.random()
    if roll < 0.7:
        headers = dict(AUTH)
    elif roll < 0.8:
        headers = {}
    elif roll < 0.9:
        headers = {"Authorization": "Bearer not-the-token"}
    else:
        headers = {"Authorization": rng.choice(("Basic x", "Bearer", "Bearer \u00e9t\u00e9", "x"))}
    if content_type is not None:
        headers["Content-Type"] = content_type
    return headers


def _routes(app: Any) -> list[tuple[str, str]]:
    """Every (method, path) of the API (its OpenAPI document), and the pages."""
    out = [("GET", "/"), ("GET", "/view3d/"), ("GET", "/view3d"), ("GET", "/docs")]
    for path, operations in app.openapi()["paths"].items():
        out += [(method.upper(), path) for method in sorted(operations)]
    return out


def _link_down(r: httpx.Response) -> bool:
    """A 503 that says the link to the vehicle is down (a state, not a server fault)."""
    try:
        body = r.json()
    except ValueError:
        return False
    if not isinstance(body, dict):
        return False
    said = f"{body.get('result_name', '')} {body.get('detail', '')}".lower()
    return "link_down" in said or ("link" in said and ("down" in said or "lost" in said))


def run_bodies(n: int, seed: int) -> dict[str, Any]:
    rng = random.Random(seed)
    codes: Counter[int] = Counter()
    worst: dict[str, int] = {}
    link_down = 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, Server(Path(tmp)) as server, Watch() as watch:
        routes = _routes(server.app)
        with httpx.Client(base_url=server.url, timeout=120) as client:
            for _ in range(n):
                method, path = rng.choice(routes)
                if rng.random() < 0.05:
                    method = rng.choice(("GET", "POST", "PUT", "DELETE", "PATCH"))
                for name in ("ref_id", "flight_id", "run_id", "kind", "name"):
                    path = path.replace("{" + name + "}", rng.choice(_PATH_VALUES))
                body, ctype = _body(rng)
                headers = {k: v.encode("utf-8") for k, v in _headers(rng, ctype).items()}
                r = client.request(method, path, content=body, headers=headers)  # type: ignore[arg-type]
                if r.status_code == 503 and _link_down(r):
                    link_down += 1  # a fuzzed reboot took the vehicle away: an honest answer
                    continue
                codes[r.status_code] += 1
                if r.status_code >= 500:
                    worst.setdefault(f"{method} {path}: {r.text[:120]}", r.status_code)
            alive = client.get("/api/health").status_code == 200
    return {
        "inputs": n,
        "routes": len(routes),
        "status_counts": {str(k): v for k, v in sorted(codes.items())},
        "status_5xx": sum(v for k, v in codes.items() if k >= 500),
        "samples_5xx": list(worst)[:5],
        # 503 with the link-down sentence, while the vehicle rebooted (fuzzed reboots and
        # precision-landing set-ups are real commands): counted apart from server faults
        "link_down_503": link_down,
        "unhandled_exceptions": watch.count,
        "samples": watch.samples,
        "server_alive": alive,
        "wall_s": round(time.perf_counter() - t0, 1),
    }
