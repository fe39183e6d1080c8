"""The station's edge: who may talk to it, and how the operator token travels.

Every HTTP request and WebSocket on the main port passes :class:`StationGuard` first:

- **Host**: the name the client used must be one of the station's own (loopback names,
  the bound address, ``allowed_hosts``): a DNS-rebinding page, whose name points at
  127.0.0.1, gets 400.
- **Origin**: a browser says which page made the request; only the station's own
  origin (the scheme and Host of the request itself) and ``allowed_origins`` pass,
  anything else (another site, another port on localhost, ``null``) gets 403.
- A WebSocket refused for any of these is refused before it opens (HTTP 403).
- **Site** (fetch metadata): a request a browser made for another site's page (an
  ``<img>``, a ``<script>``, a frame) gets 403 even without an Origin header; only a
  top-level navigation to a page (not ``/api``) may come from elsewhere.
- **Token in a URL**: refused (400). URLs end up in logs and the browser's history;
  the token goes in the ``Authorization`` header or the WebSocket's first message.
- **Operator first**: a request that changes something (POST, PUT, PATCH, DELETE on
  ``/api``) is checked for the operator token before its body is read, so a
  malformed body without a token gets 401, and an upload is not read at all.

Answers also carry headers that keep other sites from framing the dashboard or
reading its resources. :func:`install_log_redaction` keeps the token (and any
``token=`` query) out of every log line, uvicorn's access log included.
"""

from __future__ import annotations

import json
import logging
import re
import socket
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qsl

from starlette.datastructures import Headers
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from backend.tokens import tokens_equal

LOOPBACK_NAMES = frozenset({"127.0.0.1", "localhost", "::1"})
_WILDCARDS = ("0.0.0.0", "::", "")
_MUTATING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
BEARER_HINT = (
    "send it as 'Authorization: Bearer <token>' (printed at start, kept in DATA_DIR/token)"
)
TOKEN_IN_URL = (
    "The operator token never goes in a URL (URLs are kept in logs and the browser's "
    "history): send it in the Authorization header, or as the WebSocket's first message."
)
_SECURITY_HEADERS = [
    # No other site may frame the dashboard (clickjacking the ARM button) ...
    (b"x-frame-options", b"SAMEORIGIN"),
    (b"content-security-policy", b"frame-ancestors 'self'"),
    # ... or load its pictures, telemetry or scripts into its own page.
    (b"cross-origin-resource-policy", b"same-origin"),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),
]


# --- the operator token ---------------------------------------------------------------------
def token_problem(expected: str, authorization: str | None) -> str | None:
    """Why ``authorization`` is not ``Bearer <expected>``, in a sentence; None when it is."""
    if not authorization:
        return f"This needs the operator token: {BEARER_HINT}."
    scheme, _, token = authorization.partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        return f"The Authorization header must be 'Bearer <token>': {BEARER_HINT}."
    if not tokens_equal(token.strip(), expected):
        return "The operator token is wrong; nothing was done."
    return None


def url_has_token(query_string: bytes) -> bool:
    """Whether a query string carries a ``token`` parameter (any case)."""
    if b"token" not in query_string.lower():
        return False
    text = query_string.decode("latin-1")
    return any(key.strip().lower() == "token" for key, _ in parse_qsl(text, True))


# --- who may talk to the station ------------------------------------------------------------
def parse_host(value: str) -> tuple[str, int | None] | None:
    """``(name, port)`` of a Host header (``name``, ``name:port``, ``[v6]:port``).

    >>> parse_host("LocalHost:8000")
    ('localhost', 8000)
    >>> parse_host("[::1]:80")
    ('::1', 80)
    >>> parse_host("evil.example:8000:1") is None
    True
    """
    value = value.strip()
    if not value or len(value) > 255:
        return None
    if value.startswith("["):
        name, sep, rest = value[1:].partition("]")
        if not sep or (rest and not rest.startswith(":")):
            return None
        port_text = rest[1:] if rest else None
    else:
        name, sep, port_text_ = value.partition(":")
        port_text = port_text_ if sep else None
        if port_text is not None and ":" in port_text:
            return None
    port = None
    if port_text is not None:
        if not port_text.isdigit() or not 0 < int(port_text) < 65536:
            return None
        port = int(port_text)
    name = name.lower().rstrip(".")
    return (name, port) if name else None


def _this_machine_names() -> set[str]:
    """This machine's name and addresses (for a wildcard bind); best effort."""
    names: set[str] = set()
    try:
        host = socket.gethostname()
        names |= {host.lower(), socket.getfqdn().lower()}
        for info in socket.getaddrinfo(host, None):
            names.add(str(info[4][0]).lower())
    except OSError:
        pass
    return {n for n in names if n}


def _normal_origin(origin: str) -> str:
    return origin.strip().rstrip("/").lower()


@dataclass(frozen=True)
class SiteRules:
    """The names and origins the station answers to.

    ``host_names``: what a Host header may name (its port is not checked: a rebinding
    page cannot choose the name). ``origins``: extra browser origins besides the
    station's own (``scheme://host[:port]``, e.g. a reverse proxy's).
    """

    host_names: frozenset[str]
    origins: frozenset[str] = frozenset()

    @classmethod
    def for_station(
        cls, bind_host: str, extra_hosts: Iterable[str] = (), extra_origins: Iterable[str] = ()
    ) -> SiteRules:
        """The station's own names for ``bind_host``, plus the configured extras.

        >>> rules = SiteRules.for_station("127.0.0.1", ["gcs.local"])
        >>> sorted(rules.host_names)
        ['127.0.0.1', '::1', 'gcs.local', 'localhost']
        """
        names = set(LOOPBACK_NAMES)
        if bind_host in _WILDCARDS:
            names |= _this_machine_names()
        else:
            names.add(bind_host.lower().strip("[]"))
        for extra in extra_hosts:
            parsed = parse_host(extra)
            if parsed is not None:
                names.add(parsed[0])
        return cls(frozenset(names), frozenset(_normal_origin(o) for o in extra_origins))

    def host_problem(self, host: str | None) -> str | None:
        if host is None:
            return "A Host header is required."
        parsed = parse_host(host)
        if parsed is None or parsed[0] not in self.host_names:
            shown = host[:60].encode("ascii", "backslashreplace").decode()
            return (
                f"This station does not answer to the name {shown!r}; use one of its own "
                "(add more with --allowed-hosts)."
            )
        return None

    def origin_problem(self, origin: str | None, scheme: str, host: str) -> str | None:
        """None for no Origin (not a browser, or a same-origin GET) or an allowed one."""
        if origin is None:
            return None
        web_scheme = {"ws": "http", "wss": "https"}.get(scheme, scheme)
        normal = _normal_origin(origin)
        if normal == f"{web_scheme}://{host.strip().lower()}" or normal in self.origins:
            return None
        shown = origin[:80].encode("ascii", "backslashreplace").decode()
        return (
            f"Requests from the page at {shown!r} are refused: only the station's own "
            "pages may use it (add an origin with --allowed-origins)."
        )

    @staticmethod
    def site_problem(headers: Headers, path: str) -> str | None:
        """Fetch metadata: refuse what another site's page made the browser fetch."""
        site = headers.get("sec-fetch-site")
        if site not in ("cross-site", "same-site"):
            return None  # same-origin, typed by the user ("none"), or not a browser
        navigating = (
            headers.get("sec-fetch-mode") == "navigate"
            and headers.get("sec-fetch-dest") == "document"
        )
        if navigating and not path.startswith(("/api/", "/ws")):
            return None  # a link to the dashboard from elsewhere opens it, nothing more
        return "Requests made by another site's page are refused."


# --- the middleware -------------------------------------------------------------------------
class StationGuard:
    """ASGI middleware applying :class:`SiteRules`, the token-in-URL rule and
    operator-first to every request and WebSocket (see the module docstring).

    ``station()`` gives the running station (its token, its rejection counters) or
    None while it is not running (then only the site rules apply; the routes say 503).
    """

    def __init__(self, app: ASGIApp, rules: SiteRules, station: Callable[[], Any]) -> None:
        self.app = app
        self.rules = rules
        self.station = station

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        path = str(scope.get("path", ""))
        status, problem = self._problem(scope, headers, path)
        station = self.station()
        if (
            problem is None
            and kind == "http"
            and scope.get("method") in _MUTATING
            and path.startswith("/api/")
            and station is not None
        ):
            problem = token_problem(station.token, headers.get("authorization"))
            status = 401
        if problem is not None:
            if station is not None and status != 401:
                counter = station.rejections
                (counter.request if kind == "http" else counter.socket)(problem)
            if kind == "http":
                await _json_answer(send, status, problem, bearer=status == 401)
            else:
                await _refuse_websocket(send, problem)
            return
        if kind == "websocket":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                message["headers"] = [*message.get("headers", []), *_SECURITY_HEADERS]
            await send(message)

        await self.app(scope, receive, send_with_headers)

    def _problem(self, scope: Scope, headers: Headers, path: str) -> tuple[int, str | None]:
        host = headers.get("host")
        problem = self.rules.host_problem(host)
        if problem is not None:
            return 400, problem
        assert host is not None
        problem = self.rules.origin_problem(
            headers.get("origin"), str(scope.get("scheme", "http")), host
        )
        if problem is None:
            problem = self.rules.site_problem(headers, path)
        if problem is not None:
            return 403, problem
        if url_has_token(scope.get("query_string", b"")):
            return 400, TOKEN_IN_URL
        return 200, None


async def _json_answer(send: Send, status: int, detail: str, *, bearer: bool = False) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [
        (b"content-type", b"application/json"),
        (b"content-length", str(len(body)).encode()),
        *_SECURITY_HEADERS,
    ]
    if bearer:
        headers.append((b"www-authenticate", b"Bearer"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


async def _refuse_websocket(send: Send, detail: str) -> None:
    """Refuse a WebSocket before it opens: the server answers the upgrade with 403.

    (An HTTP answer with the sentence would be nicer, but uvicorn logs an error for
    every such refusal, and browsers do not show it to the page anyway.)
    """
    await send({"type": "websocket.close", "code": 1008, "reason": detail[:120]})


# --- the logs -------------------------------------------------------------------------------
_QUERY_TOKEN = re.compile(r"(?i)(token=)[^&\s\"']*")
_REDACTED = "[redacted]"
_secrets: set[str] = set()


def redact(text: str) -> str:
    """``text`` with every known secret and any ``token=`` query value blanked."""
    for secret in _secrets:
        if secret in text:
            text = text.replace(secret, _REDACTED)
    if "oken=" in text or "OKEN=" in text:
        text = _QUERY_TOKEN.sub(r"\1" + _REDACTED, text)
    return text


def _redact_value(value: Any) -> Any:
    return redact(value) if isinstance(value, str) else value


def install_log_redaction(*secret_values: str) -> None:
    """Blank ``secret_values`` and ``token=`` query values in every log record made
    from now on, by any logger (a record factory: no handler can miss it)."""
    _secrets.update(v for v in secret_values if v)
    factory = logging.getLogRecordFactory()
    if getattr(factory, "_visland_redacting", False):
        return

    def make_record(*args: Any, **kwargs: Any) -> logging.LogRecord:
        record = factory(*args, **kwargs)
        if isinstance(record.msg, str):
            record.msg = redact(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(_redact_value(a) for a in record.args)
        elif isinstance(record.args, dict):
            record.args = {k: _redact_value(v) for k, v in record.args.items()}
        if record.exc_info and record.exc_info[1] is not None:
            record.exc_text = redact(logging.Formatter().formatException(record.exc_info))
        return record

    make_record._visland_redacting = True  # type: ignore[attr-defined]
    logging.setLogRecordFactory(make_record)
