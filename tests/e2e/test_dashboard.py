"""The operator's dashboard end to end: real Chromium, a real uvicorn server, the
stand-in ArduCopter in its own process over real MAVLink TCP, the simulated camera.

What the operator does is what the tests do: load the page, watch telemetry move,
upload a reference, switch to GUIDED, arm and take off through the confirmation
steps, and see the link-lost alarm when the vehicle goes silent. Screenshots are
kept under test-artifacts/ for a person to look at.

Needs /usr/bin/chromium (Debian's package; `apt-get install -y chromium`) and the
built dashboard (`cd frontend && npm ci && npm run build`).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import socket
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

pytestmark = [
    pytest.mark.e2e,
    pytest.mark.slow,
    pytest.mark.skipif(
        not CHROMIUM.exists(),
        reason="Debian's Chromium is not installed at /usr/bin/chromium "
        "(apt-get install -y chromium); no browser is downloaded",
    ),
]

sync_api = pytest.importorskip("playwright.sync_api")
expect = sync_api.expect


# --------------------------------------------------------------------------- processes


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


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
        [
            sys.executable,
            "-m",
            "backend",
            "serve",
            "--port",
            str(port),
            "--viser-port",
            str(viser_port),
            "--data-dir",
            str(data_dir),
            "--token",
            TOKEN,
            "--mavlink",
            f"tcp:127.0.0.1:{mav_port}",
            "--log-level",
            "warning",
        ],
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


@pytest.fixture
def page(browser) -> Iterator[object]:
    """A fresh browser context per test: no token or state carried over."""
    context = browser.new_context(viewport={"width": 1680, "height": 1050})
    pg = context.new_page()
    pg.set_default_timeout(15_000)
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.errors = errors  # type: ignore[attr-defined]
    try:
        yield pg
    finally:
        context.close()


def open_dashboard(page, station: Station, *, token: str | None = TOKEN) -> None:
    """The dashboard, with the token the operator entered before (kept by the page in
    localStorage: it never travels in a URL)."""
    if token:
        page.add_init_script(f"localStorage.setItem('visland.token', {json.dumps(token)})")
    page.goto(station.url + "/")
    expect(page.get_by_test_id("server-state")).to_have_text("server connected", timeout=15_000)


def screenshot(page, name: str) -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(path), full_page=True)
    return path


def number_in(text: str) -> float | None:
    m = re.search(r"-?\d+(?:\.\d+)?", text)
    return float(m.group()) if m else None


def send_command(page, testid: str, *, confirm: bool) -> str:
    """Click a control (twice when it asks for confirmation); the outcome's text."""
    outcome = page.get_by_test_id("command-outcome")
    button = page.get_by_test_id(testid)
    button.click()
    if confirm:
        expect(button).to_have_attribute("data-confirming", "true")
        button.click()
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


# --------------------------------------------------------------------------- tests


def test_page_loads_with_every_panel(page, station: Station) -> None:
    open_dashboard(page, station)
    assert "Visland" in page.title()
    for testid in (
        "camera",
        "corner-map",
        "invariants",
        "flight",
        "controls",
        "reference",
        "viser",
        "events",
        "abort",
    ):
        expect(page.get_by_test_id(testid)).to_be_visible()
    # the token is kept by the page, and never shows in the address bar
    expect(page.get_by_test_id("token-state")).to_have_text("token set")
    assert "token=" not in page.url
    # the 3D view is embedded from the URL the server gives
    status = station.get("/api/status")[1]
    expect(page.get_by_test_id("viser-frame")).to_have_attribute("src", status["viser_url"])
    expect(page.get_by_test_id("viser-link")).to_have_attribute("href", status["viser_url"])
    # camera frames arrive and are drawn
    expect(page.get_by_test_id("camera-placeholder")).to_be_hidden(timeout=20_000)
    expect(page.get_by_test_id("pipeline-fps")).not_to_have_text("—", timeout=10_000)
    assert not page.errors, page.errors


def test_telemetry_moves(page, station: Station) -> None:
    open_dashboard(page, station)
    expect(page.get_by_test_id("link-state")).to_have_text("LINK UP", timeout=20_000)
    expect(page.get_by_test_id("mode")).not_to_have_text("—")
    attitude = page.get_by_test_id("attitude-text")
    expect(attitude).to_contain_text("R ")
    expect(attitude).not_to_contain_text("R —", timeout=10_000)
    # the reported attitude carries sensor noise, and the heartbeat age keeps updating
    first_att = attitude.inner_text()
    first_age = page.get_by_test_id("heartbeat-age").inner_text()
    deadline = time.monotonic() + 10
    changed = set()
    while time.monotonic() < deadline and len(changed) < 2:
        time.sleep(0.3)
        if attitude.inner_text() != first_att:
            changed.add("attitude")
        if page.get_by_test_id("heartbeat-age").inner_text() != first_age:
            changed.add("heartbeat")
    assert changed == {"attitude", "heartbeat"}, f"did not move: {changed}"
    expect(page.get_by_test_id("field-battery")).to_contain_text("V")
    assert not page.errors, page.errors


def test_server_connection_loss_shows_and_reconnect_restores_state(page, station: Station):
    open_dashboard(page, station)
    expect(page.get_by_test_id("link-state")).to_have_text("LINK UP", timeout=20_000)
    page.evaluate("window.visland.ws.stop()")
    expect(page.get_by_test_id("server-state")).to_have_text("server stopped")
    banner = page.get_by_test_id("link-banner")
    expect(banner).to_contain_text("SERVER CONNECTION LOST")
    expect(page.get_by_test_id("link-state")).to_have_text("NO SERVER")
    # a reconnecting page gets the whole current state at once (the server's hello)
    page.evaluate("window.visland.ws.start()")
    expect(page.get_by_test_id("server-state")).to_have_text("server connected")
    expect(page.get_by_test_id("link-state")).to_have_text("LINK UP")
    expect(banner).to_be_hidden()
    assert not page.errors, page.errors


def test_reference_upload_shows_corners(page, station: Station, tmp_path: Path) -> None:
    import cv2

    from pipeline.render import make_pad_image

    picture = tmp_path / "my-pad.png"
    assert cv2.imwrite(str(picture), make_pad_image())
    open_dashboard(page, station)
    page.get_by_test_id("reference-file").set_input_files(str(picture))
    page.get_by_test_id("reference-size").fill("0.6")
    page.get_by_test_id("reference-upload").click()
    state = page.get_by_test_id("reference-upload-state")
    expect(state).to_contain_text("uploaded", timeout=15_000)
    expect(page.get_by_test_id("reference-name")).to_contain_text("my-pad")
    expect(page.get_by_test_id("reference-meta")).to_contain_text("0.60 m")
    corners = page.get_by_test_id("reference-corners").locator("tr")
    expect(corners).to_have_count(12)
    # the corner table holds the pad's corners in metres (half the pad at most)
    xs = [number_in(corners.nth(i).locator("td").nth(1).inner_text()) for i in range(12)]
    assert all(x is not None and abs(x) <= 0.3 + 1e-9 for x in xs), xs
    expect(page.get_by_test_id("reference-invariants")).to_contain_text("Hu 1")
    # the extracted H's pictures load from the server
    for img in ("reference-threshold", "reference-corners-img"):
        page.wait_for_function(
            "id => { const i = document.querySelector(`[data-testid=${id}]`);"
            " return i && i.complete && i.naturalWidth > 0; }",
            arg=img,
        )
    # the new reference is listed and active; the server agrees
    expect(page.get_by_test_id("reference-list")).to_contain_text("my-pad")
    active = station.get("/api/reference")[1]
    assert active["name"].startswith("my-pad") and active["pad_size_m"] == pytest.approx(0.6)
    # the corner map draws it
    expect(page.get_by_test_id("corner-caption")).not_to_contain_text("No reference")
    assert not page.errors, page.errors


def test_bad_upload_is_refused_and_the_reference_stays(page, station: Station, tmp_path: Path):
    before = station.get("/api/reference")[1]
    junk = tmp_path / "notes.png"
    junk.write_bytes(b"this is not a picture at all")
    open_dashboard(page, station)
    page.get_by_test_id("reference-file").set_input_files(str(junk))
    page.get_by_test_id("reference-upload").click()
    state = page.get_by_test_id("reference-upload-state")
    expect(state).to_contain_text("refused (415)")
    expect(state).to_contain_text("previous reference stays active")
    # an out-of-range size is refused in the page, before anything is sent
    page.get_by_test_id("reference-size").fill("25")
    page.get_by_test_id("reference-upload").click()
    expect(state).to_contain_text("pad size must be")
    assert station.get("/api/reference")[1]["id"] == before["id"]


def test_commands_without_token_are_refused(page, station: Station) -> None:
    open_dashboard(page, station, token=None)
    expect(page.get_by_test_id("token-state")).to_have_text("no token: view only")
    text = send_command(page, "arm", confirm=True)
    assert "Not authorised" in text, text
    expect(page.get_by_test_id("token-input")).to_have_class(re.compile("attention"))
    time.sleep(0.5)
    telemetry = station.get("/api/telemetry")[1]
    assert telemetry["armed"] is False


def test_take_off_is_confirmed_and_happens(page, station: Station) -> None:
    open_dashboard(page, station)
    expect(page.get_by_test_id("link-state")).to_have_text("LINK UP", timeout=20_000)
    # a single click on Arm only asks; Cancel leaves the vehicle alone
    page.get_by_test_id("arm").click()
    expect(page.get_by_test_id("arm")).to_have_text("Confirm arm?")
    page.get_by_test_id("arm-cancel").click()
    expect(page.get_by_test_id("arm")).to_have_text("Arm")
    expect(page.get_by_test_id("armed")).to_have_text("DISARMED")

    page.get_by_test_id("mode-select").select_option("GUIDED")
    retry_command(page, "set-mode", confirm=False, until="accepted", timeout=30)
    expect(page.get_by_test_id("mode")).to_have_text("GUIDED", timeout=5_000)
    retry_command(page, "arm", confirm=True, until="accepted", timeout=30)
    expect(page.get_by_test_id("armed")).to_have_text("ARMED", timeout=5_000)
    page.get_by_test_id("takeoff-altitude").fill("2.5")
    text = send_command(page, "takeoff", confirm=True)
    assert "accepted" in text, text

    altitude = page.get_by_test_id("altitude")
    deadline = time.monotonic() + 25
    alt = None
    while time.monotonic() < deadline:
        alt = number_in(altitude.inner_text())
        if alt is not None and alt > 1.5:
            break
        time.sleep(0.25)
    assert alt is not None and alt > 1.5, f"altitude stayed at {alt}"
    expect(page.get_by_test_id("event-log")).to_contain_text("Take off: accepted")
    # from up there the camera sees the pad: the overlays and the corner map follow
    expect(page.get_by_test_id("detection-badge")).to_contain_text("H LOCKED", timeout=15_000)
    expect(page.get_by_test_id("corner-caption")).to_contain_text("corners matched")
    expect(page.get_by_test_id("hu1")).not_to_have_text("—")
    # the 3D view loads when scrolled to (a lazy iframe): show it in the picture too
    page.get_by_test_id("viser-frame").scroll_into_view_if_needed()
    page.wait_for_timeout(3000)
    page.evaluate("window.scrollTo(0, 0)")
    screenshot(page, "dashboard-take-off")

    # the threshold mask is asked for only when shown
    assert page.evaluate("window.visland.store.thresholdImage") is None
    page.get_by_test_id("toggle-threshold").check()
    page.wait_for_function("window.visland.store.thresholdImage !== null", timeout=10_000)
    assert not page.errors, page.errors


def test_missions_button_says_when_missions_are_missing(page, station: Station) -> None:
    open_dashboard(page, station)
    text = send_command(page, "hover", confirm=True)
    if station.status_code("/api/missions/current") in (404, 405):
        assert "missions not available yet" in text, text
    else:
        assert "Hover over pad" in text
    # ABORT is on screen wherever the page is scrolled
    page.mouse.wheel(0, 3000)
    expect(page.get_by_test_id("abort")).to_be_in_viewport()


def test_hover_then_land_by_vision_in_the_mission_panel(page, station: Station) -> None:
    """After the take-off (and the hover the missions button started): the precision-
    landing panel follows the mission live; abort it, land by GCS guidance, see the
    touchdown error in the history."""
    open_dashboard(page, station)
    panel = page.get_by_test_id("mission")
    expect(panel).to_be_visible()
    state = page.get_by_test_id("mission-panel-state")
    expect(state).to_contain_text("hover", timeout=20_000)
    # over the pad the camera sees it: the estimate fills in
    expect(page.get_by_test_id("field-estimate")).not_to_have_text("—", timeout=30_000)
    page.get_by_test_id("abort").click()
    expect(page.get_by_test_id("command-outcome")).to_contain_text("Abort")
    expect(state).to_contain_text(re.compile("aborted|completed"), timeout=10_000)
    page.get_by_test_id("mission-strategy").select_option("guided")
    land = page.get_by_test_id("mission-land")
    land.click()
    expect(land).to_have_attribute("data-confirming", "true")
    expect(page.get_by_test_id("mission-outcome")).not_to_have_text("Landing started (guided)")
    land.click()
    expect(page.get_by_test_id("mission-outcome")).to_have_text("Landing started (guided)")
    expect(state).to_contain_text("land (guided)", timeout=10_000)
    # velocity targets go out at the camera's pace: the last one is fresh
    expect(page.get_by_test_id("field-targetAge")).to_contain_text("limits", timeout=20_000)
    screenshot(page, "dashboard-mission-landing")
    expect(state).to_contain_text("landed", timeout=120_000)
    first = page.get_by_test_id("mission-history").locator("tbody tr").first
    expect(first).to_contain_text("landed", timeout=10_000)
    expect(first).to_contain_text("cm")
    text = first.inner_text()
    cm = number_in(text.split("landed", 1)[1])
    assert cm is not None and cm < 25.0, text
    screenshot(page, "dashboard-mission-landed")
    assert not page.errors, page.errors


def test_refusal_reasons_and_link_lost(page, tmp_path: Path) -> None:
    """A stand-in that is far from ready refuses to arm with its PreArm reasons,
    verbatim in the page; then it dies and the page shows the link as lost."""
    if not DIST.exists():
        pytest.fail("the dashboard is not built", pytrace=False)
    station = start_station(tmp_path, ready_after=5.0)  # pre-arm passes only after ~2 min
    try:
        open_dashboard(page, station)
        expect(page.get_by_test_id("link-state")).to_have_text("LINK UP", timeout=20_000)
        expect(page.get_by_test_id("link-banner")).to_be_hidden()
        text = send_command(page, "arm", confirm=True)
        assert "Refused by the vehicle" in text, text
        reasons = page.get_by_test_id("command-reasons").locator("li")
        expect(reasons.first).to_be_visible()
        shown = reasons.all_inner_texts()
        assert shown and all(r.startswith(("PreArm:", "Arm:")) for r in shown), shown
        # verbatim: the same sentences the vehicle sent as STATUSTEXT
        sent = {s["text"] for s in station.get("/api/telemetry")[1]["statustexts"]}
        assert set(shown) <= sent, (shown, sent)

        station.stand_in.stop()
        expect(page.get_by_test_id("link-state")).to_have_text("LINK LOST", timeout=15_000)
        banner = page.get_by_test_id("link-banner")
        expect(banner).to_be_visible()
        expect(banner).to_contain_text("VEHICLE LINK LOST")
        expect(page.get_by_test_id("flight")).to_have_class(re.compile("alarm"))
        screenshot(page, "dashboard-link-lost")
        # a command now fails at once with the link-down sentence
        text = send_command(page, "rtl", confirm=False)
        assert "Link down" in text or "link" in text.lower(), text
        assert not page.errors, page.errors
    finally:
        stop_station(station)
