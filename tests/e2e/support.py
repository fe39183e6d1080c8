"""Shared by the browser tests: real Chromium (Debian's), a real server in its own
process, the stand-in ArduCopter in its own process over real MAVLink TCP."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.serve import free_port, serve_command

CHROMIUM = Path("/usr/bin/chromium")
ROOT = Path(__file__).resolve().parents[2]
DIST = ROOT / "frontend" / "dist" / "index.html"
ARTIFACTS = ROOT / "test-artifacts"
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
TOKEN = "e2e-operator-token-0123"
START_TIMEOUT_S = 60.0

NO_CHROMIUM = pytest.mark.skipif(
    not CHROMIUM.exists(),
    reason="Debian's Chromium is not installed at /usr/bin/chromium "
    "(apt-get install -y chromium); no browser is downloaded",
)

sync_api = pytest.importorskip("playwright.sync_api")
expect = sync_api.expect


# --------------------------------------------------------------------------- processes


class Proc:
    """A child process whose output goes to a log file and is searched for lines."""

    def __init__(self, name: str, argv: list[str], log_dir: Path, env: dict | None = None) -> None:
        self.name = name
        self.log_path = log_dir / f"{name}.log"
        self._log = self.log_path.open("wb")
        self._lines: list[str] = []
        self._lock = threading.Lock()
        self.popen = subprocess.Popen(
            argv,
            cwd=ROOT,
            env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own group: a clean kill of it and its children
        )
        self._reader = threading.Thread(target=self._read, name=f"{name}-log", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for raw in iter(self.popen.stdout.readline, b""):
            self._log.write(raw)
            self._log.flush()
            with self._lock:
                self._lines.append(raw.decode(errors="replace"))

    def output(self) -> str:
        with self._lock:
            return "".join(self._lines)

    def wait_for_line(self, pattern: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if re.search(pattern, self.output()):
                return
            if self.popen.poll() is not None:
                raise RuntimeError(
                    f"{self.name} exited with {self.popen.returncode} before printing "
                    f"{pattern!r}:\n{self.output()[-3000:]}"
                )
            time.sleep(0.05)
        raise TimeoutError(f"{self.name} did not print {pattern!r} in {timeout} s")

    def stop(self, timeout: float = 10.0) -> None:
        if self.popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.popen.pid, signal.SIGTERM)
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.popen.pid, signal.SIGKILL)
                self.popen.wait(timeout)
        self._reader.join(timeout)
        self._log.close()


def start_stand_in(log_dir: Path, ready_after: float) -> tuple[Proc, int]:
    port = free_port()
    proc = Proc(
        f"stand-in-{port}",
        [
            sys.executable,
            "-m",
            "sim.vehicle",
            "--mavlink",
            f"tcp:127.0.0.1:{port}",
            "--ready-after",
            str(ready_after),
        ],
        log_dir,
    )
    try:
        proc.wait_for_line(r"stand-in ArduCopter listening on", START_TIMEOUT_S)
    except Exception:
        proc.stop()
        raise
    return proc, port


@dataclass
class Station:
    url: str
    token: str
    server: Proc
    stand_in: Proc
    data_dir: Path

    def get(self, path: str, timeout: float = 5.0):
        with urllib.request.urlopen(self.url + path, timeout=timeout) as r:
            return r.status, json.loads(r.read() or b"null")

    def status_code(self, path: str) -> int:
        try:
            with urllib.request.urlopen(self.url + path, timeout=5) as r:
                return r.status
        except urllib.error.HTTPError as e:
            return e.code


def start_station(tmp: Path, ready_after: float) -> Station:
    logs = tmp / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    stand_in, mav_port = start_stand_in(logs, ready_after)
    port, viser_port = free_port(), free_port()
    data_dir = tmp / "data"
    server = Proc(
        f"server-{port}",
        serve_command(
            port,
            viser_port,
            data_dir,
            "--token",
            TOKEN,
            "--mavlink",
            f"tcp:127.0.0.1:{mav_port}",
            "--log-level",
            "warning",
        ),
        logs,
    )
    url = f"http://127.0.0.1:{port}"
    station = Station(url, TOKEN, server, stand_in, data_dir)
    deadline = time.monotonic() + START_TIMEOUT_S
    while True:
        try:
            if station.get("/api/health", timeout=1)[1].get("ok"):
                break
        except (OSError, ValueError):
            pass
        if server.popen.poll() is not None or time.monotonic() > deadline:
            server.stop()
            stand_in.stop()
            raise RuntimeError(f"the server did not come up:\n{server.output()[-3000:]}")
        time.sleep(0.2)
    return station


def stop_station(station: Station) -> None:
    station.server.stop()
    station.stand_in.stop()


# --------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def station(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Station]:
    """A ground station flying a quick stand-in (ready in a few seconds)."""
    if not DIST.exists():
        pytest.fail(
            "the dashboard is not built: run `cd frontend && npm ci && npm run build` first",
            pytrace=False,
        )
    s = start_station(tmp_path_factory.mktemp("station"), ready_after=0.2)
    try:
        yield s
    finally:
        stop_station(s)


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, timeout=30_000)
        try:
            yield b
        finally:
            b.close()


VIEWPORTS = {"desktop": (1600, 1000), "laptop": (1280, 720), "phone": (390, 844)}


@pytest.fixture
def page(browser) -> Iterator[object]:
    """A fresh browser context per test: no token or state carried over."""
    context = browser.new_context(viewport={"width": 1600, "height": 1000})
    pg = context.new_page()
    pg.set_default_timeout(15_000)
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.errors = errors  # type: ignore[attr-defined]
    try:
        yield pg
    finally:
        context.close()


def open_dashboard(page, station: Station, *, token: str | None = TOKEN, tab: str = "") -> None:
    """The dashboard, with the token the operator entered before (kept by the page in
    localStorage: it never travels in a URL)."""
    if token:
        page.add_init_script(f"localStorage.setItem('visland.token', {json.dumps(token)})")
    page.goto(station.url + "/")
    expect(page.get_by_test_id("server-state")).to_have_text("server connected", timeout=15_000)
    if tab:
        page.get_by_test_id(f"tab-{tab}").click()


def screenshot(page, name: str) -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(path), full_page=True)
    return path


def number_in(text: str) -> float | None:
    m = re.search(r"-?\d+(?:\.\d+)?", text)
    return float(m.group()) if m else None


def confirm(page, *, expect_text: str | None = None) -> None:
    """Say yes in the confirmation dialog (after checking what it says will happen)."""
    dialog = page.get_by_test_id("confirm-dialog")
    expect(dialog).to_be_visible()
    if expect_text is not None:
        expect(dialog).to_contain_text(expect_text)
    page.get_by_test_id("confirm-yes").click()
    expect(dialog).to_have_count(0)


def send_command(page, testid: str, *, confirm: bool) -> str:
    """Click a control (and confirm it in the dialog when it asks); the outcome's text."""
    outcome = page.get_by_test_id("command-outcome")
    page.get_by_test_id(testid).click()
    if confirm:
        globals()["confirm"](page)
    expect(outcome).not_to_contain_text("sending", timeout=10_000)
    return outcome.inner_text()


def retry_command(page, testid: str, *, confirm: bool, until: str, timeout: float) -> str:
    """Repeat a command while the stand-in is still getting ready (as an operator would)."""
    deadline = time.monotonic() + timeout
    text = ""
    while time.monotonic() < deadline:
        text = send_command(page, testid, confirm=confirm)
        if until in text:
            return text
        time.sleep(0.5)
    raise AssertionError(f"{testid} never gave {until!r}; last outcome: {text!r}")
