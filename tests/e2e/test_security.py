"""The hardened station in real Chromium: the operator's token goes nowhere it should
not, and a page at another origin gets nothing.

A full ``python -m backend serve`` (stand-in vehicle, simulated camera, the 3D view,
uvicorn's access log on) is used from the dashboard as an operator would: type the
token, watch, command, open the 3D view. Then a page served from another origin (the
kind of page the operator might visit meanwhile) tries to read the station: fetch,
WebSocket, pictures, frames, the 3D view and its own port.
"""

from __future__ import annotations

import contextlib
import http.server
import os
import signal
import subprocess
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.e2e.support import DIST, NO_CHROMIUM, ROOT, expect
from tests.serve import free_port, serve_command

TOKEN = "e2e-sec-token-5b1f9c7e"

pytestmark = [pytest.mark.e2e, pytest.mark.slow, NO_CHROMIUM]


@dataclass
class Served:
    url: str
    port: int
    viser_port: int
    proc: subprocess.Popen
    log: Path
    requests: list[str] = field(default_factory=list)

    def output(self) -> str:
        return self.log.read_text(errors="replace")


@pytest.fixture(scope="module")
def station(tmp_path_factory) -> Iterator[Served]:
    if not DIST.exists():
        pytest.fail("the dashboard is not built: run `make frontend` first", pytrace=False)
    tmp = tmp_path_factory.mktemp("secure")
    port, viser_port = free_port(), free_port()
    log = tmp / "server.log"
    env = {
        **os.environ,
        "VISLAND_TOKEN": TOKEN,
        "VISLAND_SIM_READY_AFTER": "0.1",
        "PYTHONUNBUFFERED": "1",
    }
    with log.open("wb") as out:
        proc = subprocess.Popen(
            serve_command(port, viser_port, tmp / "data", "--log-level", "info"),
            cwd=ROOT,
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    served = Served(f"http://127.0.0.1:{port}", port, viser_port, proc, log)
    try:
        deadline = time.monotonic() + 60
        while "Application startup complete" not in served.output():
            assert proc.poll() is None, served.output()
            assert time.monotonic() < deadline, served.output()
            time.sleep(0.1)
        yield served
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


def test_the_token_is_in_no_url_response_or_log_line(browser, station: Served) -> None:
    context = browser.new_context(viewport={"width": 1600, "height": 1000})
    page = context.new_page()
    page.set_default_timeout(20_000)
    urls: list[str] = []
    bodies: list[str] = []
    sockets: list = []
    page.on("request", lambda r: urls.append(r.url))

    def keep_body(response) -> None:
        kind = response.headers.get("content-type", "")
        if "json" in kind or "html" in kind or "javascript" in kind or "text" in kind:
            # a response the page dropped (a navigation) has nothing to read
            with contextlib.suppress(Exception):
                bodies.append(response.text())

    page.on("response", keep_body)
    page.on("websocket", lambda s: sockets.append(s))
    try:
        page.goto(station.url + "/")
        # the operator types the token in, as the banner and README say
        page.get_by_test_id("token-input").fill(TOKEN)
        page.get_by_test_id("token-save").click()
        expect(page.get_by_test_id("token-state")).to_have_text("token set")
        expect(page.get_by_test_id("server-state")).to_have_text("server connected")
        expect(page.get_by_test_id("link-state")).to_have_text("LINK UP", timeout=30_000)
        # a command goes out with the token (accepted or refused: either is an answer)
        page.get_by_test_id("arm").click()
        page.get_by_test_id("confirm-yes").click()
        expect(page.get_by_test_id("command-outcome")).not_to_contain_text("sending")
        # the 3D view loads through the station and gets its scene
        page.get_by_test_id("viser-embed").click()  # embedded on demand
        frame = page.get_by_test_id("viser-frame")
        frame.scroll_into_view_if_needed()
        deadline = time.monotonic() + 30
        view = None
        while view is None and time.monotonic() < deadline:
            view = next((s for s in sockets if s.url.endswith("/view3d")), None)
            page.wait_for_timeout(100)
        assert view is not None, [s.url for s in sockets]
        got: list = []
        view.on("framereceived", lambda f: got.append(f))
        deadline = time.monotonic() + 30
        while not got and time.monotonic() < deadline:
            page.wait_for_timeout(100)
        assert got, "the 3D view got no scene through the station"
        # viewing with the token required: reload; the page signs its socket in itself
        page.evaluate(
            """t => fetch('/api/settings', {method: 'PUT', headers: {'Authorization':
            'Bearer ' + t, 'Content-Type': 'application/json'},
            body: JSON.stringify({view_requires_token: true})})""",
            TOKEN,
        )
        page.reload()
        expect(page.get_by_test_id("server-state")).to_have_text("server connected")
        expect(page.get_by_test_id("camera-placeholder")).to_be_hidden(timeout=30_000)
    finally:
        page.evaluate(
            """t => fetch('/api/settings', {method: 'PUT', headers: {'Authorization':
            'Bearer ' + t, 'Content-Type': 'application/json'},
            body: JSON.stringify({view_requires_token: false})})""",
            TOKEN,
        )
        context.close()
    assert urls and not [u for u in urls + [s.url for s in sockets] if TOKEN in u]
    assert bodies and not [b for b in bodies if TOKEN in b]
    log = station.output()
    assert '"GET / HTTP/1.1" 200' in log  # the access log is on ...
    assert TOKEN not in log  # ... and holds no token (nor does any other line)


EVIL_PAGE = """<!doctype html><title>evil</title><body>
<iframe id="dash" src="{station}/"></iframe>
<iframe id="view" src="{station}/view3d/"></iframe>
<script>
window.results = {{}};
const done = (k, v) => {{ window.results[k] = v; }};
fetch("{station}/api/status").then(r => r.text()).then(t => done("fetch", "read " + t.length),
  e => done("fetch", "failed"));
fetch("{station}/api/status", {{mode: "no-cors"}}).then(r => done("nocors", r.type),
  e => done("nocors", "failed"));
for (const [key, url, protocols] of [
    ["ws", "{ws}/ws", []], ["view3d", "{ws}/view3d", ["{viser}"]],
    ["viserport", "ws://127.0.0.1:{viser_port}/", ["{viser}"]]]) {{
  let n = 0;
  const s = new WebSocket(url, protocols);
  s.onmessage = () => {{ n += 1; }};
  s.onclose = (e) => done(key, "closed " + e.code + " after " + n + " messages");
}}
// The picture's handlers are set before its source: a refusal that comes back before
// a script after an <img> tag runs would leave its event unheard.
const img = new Image();
img.onerror = () => done("img", "error");
img.onload = () => done("img", "loaded");
img.src = "{station}/api/references";
document.body.appendChild(img);
</script></body>"""


def test_a_page_at_another_origin_gets_nothing(browser, station: Served) -> None:
    import viser

    html = EVIL_PAGE.format(
        station=station.url,
        ws=station.url.replace("http:", "ws:"),
        viser=f"viser-v{viser.__version__}",
        viser_port=station.viser_port,
    ).encode()

    class Evil(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(html)))
            self.end_headers()
            self.wfile.write(html)

        def log_message(self, *args: object) -> None:
            pass

    evil = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Evil)
    thread = threading.Thread(target=evil.serve_forever, daemon=True)
    thread.start()
    context = browser.new_context()
    page = context.new_page()
    try:
        # "localhost" is another origin than 127.0.0.1 (and another port): another site
        page.goto(f"http://localhost:{evil.server_address[1]}/")
        # every attempt ends (refused or closed); a loaded machine may take its time
        try:
            page.wait_for_function(
                "['fetch','nocors','ws','view3d','viserport','img']"
                ".every(k => k in window.results)",
                timeout=90_000,
            )
        finally:
            results = page.evaluate("window.results")
            print("cross-origin attempts:", results)
        frames = {f.name or f.url: f for f in page.frames}
        dash = next(f for f in page.frames if f.parent_frame and "/view3d" not in f.url)
        view = next(f for f in page.frames if f.parent_frame and f is not dash)
    finally:
        context.close()
        evil.shutdown()
    assert results["fetch"] == "failed", results
    assert results["nocors"] in ("opaque", "failed"), results  # nothing readable either way
    for key in ("ws", "view3d", "viserport"):
        assert results[key].endswith("after 0 messages"), results
    assert results["img"] == "error", results
    # framing the dashboard or the 3D view is refused: the frames hold Chrome's error page
    for framed in (dash, view):
        assert framed.url.startswith("chrome-error://"), (framed.url, list(frames))
