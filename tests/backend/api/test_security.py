"""The station's edge, on a real uvicorn server: who may ask, and where the token goes.

Attacked as an outsider would: another Host (DNS rebinding), another Origin (a page the
operator visits), another site's subresources, the token in a URL, garbage and
non-ASCII tokens on the WebSocket, the 3D view's own port. Every refusal is a 4xx or a
WebSocket close code, counted in the status, with no traceback in any log.
"""

from __future__ import annotations

import json
import logging
import socket
from collections.abc import Iterator

import httpx
import pytest
import viser
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

from backend.api import ws as ws_module
from backend.loopback import LoopbackServer
from tests.backend.api.support import AUTH, TOKEN, make_settings, wait_for
from tests.serve import free_port

pytestmark = pytest.mark.slow

EVIL = "http://evil.example"
VISER_PROTOCOL = f"viser-v{viser.__version__}"


@pytest.fixture(scope="module")
def live(tmp_path_factory) -> Iterator[LoopbackServer]:
    settings = make_settings(tmp_path_factory.mktemp("data"), viser_port=free_port())
    with LoopbackServer(settings) as server:
        yield server


@pytest.fixture
def error_records() -> Iterator[list[logging.LogRecord]]:
    """Every log record at ERROR or with a traceback, from any logger (uvicorn's too)."""
    records: list[logging.LogRecord] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if record.levelno >= logging.ERROR or record.exc_info:
                records.append(record)

    handler = Keep(logging.DEBUG)
    loggers = [logging.getLogger(), logging.getLogger("uvicorn"), logging.getLogger("websockets")]
    for logger in loggers:
        logger.addHandler(handler)
    yield records
    for logger in loggers:
        logger.removeHandler(handler)


@pytest.fixture
def viewing_needs_the_token(live) -> Iterator[None]:
    r = httpx.put(f"{live.url}/api/settings", json={"view_requires_token": True}, headers=AUTH)
    assert r.status_code == 200
    yield
    httpx.put(f"{live.url}/api/settings", json={"view_requires_token": False}, headers=AUTH)


def upgrade_status(port: int, path: str, headers: dict[str, str]) -> int:
    """The HTTP status a WebSocket upgrade to ``path`` gets (101: it opened)."""
    head = {
        "Host": f"127.0.0.1:{port}",
        "Upgrade": "websocket",
        "Connection": "Upgrade",
        "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version": "13",
        **headers,
    }
    request = f"GET {path} HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in head.items())
    with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
        sock.sendall((request + "\r\n").encode("latin-1"))
        line = sock.makefile("rb").readline().decode("latin-1")
    return int(line.split()[1])


def rejected(live) -> dict:
    """The refusal counts as the station counts them now (the status is 1 s behind)."""
    return live.station.rejections.to_dict()


# --- Host -------------------------------------------------------------------------------------
@pytest.mark.parametrize("host", ["evil.example", "127.0.0.1.evil.example", "localhost.", ""])
def test_a_wrong_host_gets_400_on_every_route_and_socket(live, host):
    if host == "localhost.":  # the trailing-dot spelling of an own name is still ours
        assert httpx.get(f"{live.url}/api/health", headers={"Host": host}).status_code == 200
        return
    for path in ("/", "/api/status", "/api/health", "/view3d/", "/docs", "/openapi.json"):
        r = httpx.get(f"{live.url}{path}", headers={"Host": host})
        assert r.status_code == 400, (path, r.text)
        assert "name" in r.json()["detail"] or "Host" in r.json()["detail"]
    r = httpx.post(f"{live.url}/api/vehicle/arm", headers={**AUTH, "Host": host})
    assert r.status_code == 400
    for path in ("/ws", "/view3d"):  # a socket is refused before it opens
        assert upgrade_status(live.port, path, {"Host": host}) == 403


# --- Origin and site --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "origin", [EVIL, "http://127.0.0.1:1", "null", "http://localhost:3000", "https://127.0.0.1"]
)
def test_another_origin_gets_nothing(live, origin):
    before = rejected(live)
    for path in ("/api/status", "/api/telemetry", "/", "/view3d/", "/api/references"):
        r = httpx.get(f"{live.url}{path}", headers={"Origin": origin})
        assert r.status_code == 403, (path, r.text)
        assert "refused" in r.json()["detail"]
    assert upgrade_status(live.port, "/ws", {"Origin": origin}) == 403
    assert upgrade_status(live.port, "/view3d", {"Origin": origin}) == 403
    after = rejected(live)
    assert after["requests"] >= before["requests"] + 5
    assert after["sockets"] >= before["sockets"] + 2
    # and the status shows them (it is rebuilt once a second)
    wait_for(
        lambda: (
            httpx.get(f"{live.url}/api/status").json()["rejected"]["sockets"] >= after["sockets"]
        ),
        timeout=10,
    )


def test_the_stations_own_pages_are_served(live):
    own = f"http://127.0.0.1:{live.port}"
    assert httpx.get(f"{live.url}/api/status", headers={"Origin": own}).status_code == 200
    assert upgrade_status(live.port, "/ws", {"Origin": own}) == 101
    local = {"Origin": f"http://localhost:{live.port}", "Host": f"localhost:{live.port}"}
    assert httpx.get(f"{live.url}/api/status", headers=local).status_code == 200


@pytest.mark.parametrize(
    ("site", "mode", "dest", "path", "status"),
    [
        ("cross-site", "no-cors", "image", "/api/references", 403),
        ("cross-site", "no-cors", "script", "/api/status", 403),
        ("same-site", "no-cors", "image", "/api/status", 403),  # another port, same host
        ("cross-site", "navigate", "iframe", "/", 403),  # framing the dashboard
        ("cross-site", "navigate", "document", "/api/status", 403),
        ("cross-site", "navigate", "document", "/", 200),  # a link to the dashboard
        ("same-origin", "cors", "empty", "/api/status", 200),
        ("none", "navigate", "document", "/", 200),  # typed by the operator
    ],
)
def test_fetch_metadata_keeps_other_sites_out(live, site, mode, dest, path, status):
    headers = {"Sec-Fetch-Site": site, "Sec-Fetch-Mode": mode, "Sec-Fetch-Dest": dest}
    assert httpx.get(f"{live.url}{path}", headers=headers).status_code == status


def test_answers_forbid_framing_and_cross_origin_reads(live):
    r = httpx.get(f"{live.url}/")
    assert r.headers["x-frame-options"] == "SAMEORIGIN"
    assert "frame-ancestors 'self'" in r.headers["content-security-policy"]
    assert r.headers["cross-origin-resource-policy"] == "same-origin"
    assert r.headers["x-content-type-options"] == "nosniff"


# --- the token --------------------------------------------------------------------------------
@pytest.mark.parametrize("query", ["token=abc", "x=1&Token=abc", "token", "TOKEN=" + TOKEN])
def test_a_token_in_a_url_is_refused(live, query):
    for path in ("/", "/api/status", "/view3d/"):
        r = httpx.get(f"{live.url}{path}?{query}")
        assert r.status_code == 400 and "never goes in a URL" in r.json()["detail"]
    assert upgrade_status(live.port, f"/ws?{query}", {}) == 403


def test_the_token_is_in_no_log_line(live):
    """uvicorn's access log included: a token in a URL is blanked before any handler."""
    seen: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            seen.append(self.format(record))

    access = logging.getLogger("uvicorn.access")
    old_level, handler = access.level, Keep(logging.DEBUG)
    access.setLevel(logging.INFO)
    access.addHandler(handler)
    logging.getLogger().addHandler(handler)
    try:
        httpx.get(f"{live.url}/?token={TOKEN}")
        httpx.get(f"{live.url}/api/status?token=other-secret-value")
        httpx.post(f"{live.url}/api/vehicle/mode", json={"mode": TOKEN}, headers=AUTH)
        logging.getLogger("backend.test").warning("a line that names %s", TOKEN)
    finally:
        access.removeHandler(handler)
        logging.getLogger().removeHandler(handler)
        access.setLevel(old_level)
    text = "\n".join(seen)
    assert "GET /?token=[redacted]" in text  # the access log line is there, blanked
    assert TOKEN not in text and "other-secret-value" not in text


# --- the WebSocket's auth ---------------------------------------------------------------------
def close_of(live, *messages: str | bytes) -> tuple[int, list]:
    """Send ``messages`` on /ws; the close code and what came before it."""
    got: list = []
    with connect(live.ws_url, open_timeout=5) as sock:
        for message in messages:
            sock.send(message)
        try:
            while True:
                got.append(sock.recv(timeout=10))
        except ConnectionClosed as exc:
            assert exc.rcvd is not None
            return exc.rcvd.code, got
    raise AssertionError("the socket stayed open")


GARBAGE = [
    '{"type": "auth", "token": "t\\u00f6k\\u00e9n-\\ud800-\\u4e2d"}',  # non-ASCII, a lone surrogate
    json.dumps({"type": "auth", "token": "\u00e9" * 40}),
    '{"type": "auth", "token": 12345}',
    '{"type": "auth"}',
    '{"type": "ping"}',
    "not json at all",
    "[" * 3000,
    "{" + '"a":' * 2000,
    "x" * 100_000,
    b"\x00\xff\xfe binary",
    '{"type": 7}',
]


@pytest.mark.parametrize("first", GARBAGE)
def test_garbage_first_messages_are_closed_4401_without_a_traceback(
    live, viewing_needs_the_token, error_records, first
):
    before = rejected(live)["sockets"]
    code, got = close_of(live, first)
    assert code == ws_module.CLOSE_UNAUTHORIZED and got == []  # nothing was shown
    assert rejected(live)["sockets"] == before + 1
    assert error_records == []


def test_no_auth_message_in_time_is_closed_4408(live, viewing_needs_the_token, monkeypatch):
    monkeypatch.setattr(ws_module, "AUTH_TIMEOUT_S", 0.3)
    code, got = close_of(live)
    assert code == ws_module.CLOSE_AUTH_TIMEOUT and got == []


def test_the_right_token_first_opens_the_stream(live, viewing_needs_the_token):
    with connect(live.ws_url, open_timeout=5) as sock:
        sock.send(json.dumps({"type": "auth", "token": TOKEN}))
        assert json.loads(sock.recv(timeout=10))["type"] == "hello"


def test_a_wrong_token_is_refused_even_when_viewing_is_open(live, error_records):
    code, got = close_of(live, '{"type": "auth", "token": "\\u00fcber-wrong"}')
    assert code == ws_module.CLOSE_UNAUTHORIZED
    assert [json.loads(m)["type"] for m in got[:1]] == ["hello"]  # viewing is open
    assert error_records == []


# --- the 3D view ------------------------------------------------------------------------------
def viser_messages(url: str, **kwargs) -> list:
    with connect(url, subprotocols=[VISER_PROTOCOL], open_timeout=5, max_size=None, **kwargs) as s:
        return [s.recv(timeout=10)]


def test_the_3d_view_is_served_through_the_station(live):
    status = httpx.get(f"{live.url}/api/status").json()
    assert status["viser_url"] == "/view3d/"
    page = httpx.get(f"{live.url}/view3d/")
    assert page.status_code == 200 and "<html" in page.text.lower()
    assert httpx.get(f"{live.url}/view3d").status_code == 307
    got = viser_messages(f"ws://127.0.0.1:{live.port}/view3d")
    assert got and isinstance(got[0], bytes)  # viser's scene, msgpack


def test_the_3d_views_own_port_closes_strangers_before_sending_anything(live):
    port = live.station.viewer.bound_port
    assert port is not None and port != live.port
    with pytest.raises(ConnectionClosed) as info:
        viser_messages(f"ws://127.0.0.1:{port}/", origin=EVIL)
    assert info.value.rcvd is not None and info.value.rcvd.code == 1008


def test_viewing_with_the_token_required_needs_the_view_cookie(live, viewing_needs_the_token):
    assert httpx.get(f"{live.url}/view3d/").status_code == 401
    assert httpx.get(f"{live.url}/api/status").status_code == 401
    with pytest.raises(InvalidStatus) as refused:
        viser_messages(f"ws://127.0.0.1:{live.port}/view3d")
    assert refused.value.response.status_code == 403
    with httpx.Client(base_url=live.url) as browser:
        assert browser.post("/api/session").status_code == 401
        opened = browser.post("/api/session", headers=AUTH)
        assert opened.status_code == 200 and opened.json()["view_cookie"] is True
        cookie = opened.headers["set-cookie"]
        assert "HttpOnly" in cookie and "SameSite=strict" in cookie and TOKEN not in cookie
        assert browser.get("/view3d/").status_code == 200
        assert browser.get("/api/status").status_code == 200
        # the cookie lets its holder view, never command
        assert browser.post("/api/vehicle/arm").status_code == 401
        value = browser.cookies["visland_view"]
    got = viser_messages(
        f"ws://127.0.0.1:{live.port}/view3d",
        additional_headers={"Cookie": f"visland_view={value}"},
    )
    assert got and isinstance(got[0], bytes)


def test_the_3d_view_refuses_other_origins(live):
    with pytest.raises(InvalidStatus) as info:
        viser_messages(f"ws://127.0.0.1:{live.port}/view3d", origin=EVIL)
    assert info.value.response.status_code == 403
