"""The OpenAPI document: every route, the operator token, the errors, the WebSocket.

FastAPI builds the routes' part from their response models; this adds what it cannot
see: the WebSocket's message models (``backend.api.messages``) as components, the
token being optional for viewing (required only with ``view_requires_token``), and
the API's own 422 body (a sentence, not FastAPI's list of errors).

``python -m backend openapi OUT.json`` writes the document without starting a
server; ``make types`` turns it into the dashboard's TypeScript types.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from pydantic.json_schema import models_json_schema

from backend.api.messages import WS_MODELS

_REF = "#/components/schemas/{model}"

WS_DESCRIPTION = """

**WebSocket `/ws`.** Server to browser, JSON text: `HelloMessage` (first), then
`TelemetryMessage` (10 Hz), `StatusMessage` (1 Hz and whenever a mission moves),
`FrameMessage` (each processed frame), `EventMessage`, `PongMessage`. Binary: a
4-byte big-endian length N, N bytes of JSON (`BinaryFrameHeader`), then the JPEG.
Browser to server, JSON text: `AuthMessage` first (the token: required within 5 s
when viewing needs it, and checked whenever sent; missing, wrong or garbled closes
the socket with 4401, none in time with 4408), `PingMessage`, `SubscribeMessage`.
Garbage closes the socket with code 1003 and a sentence.

**Token.** Commands and uploads need `Authorization: Bearer <token>` (the token is
kept in DATA_DIR/token), checked before the body is read; viewing needs it (or the
view cookie of `POST /api/session`) only when the `view_requires_token` setting is
on. The token never goes in a URL: a `token` query parameter is refused (400).

**Who may ask.** A request must name the station by one of its own names in `Host`
(else 400) and, from a browser, come from the station's own pages (`Origin`, fetch
metadata; else 403). The 3D view is at `/view3d/` under the same rules.
"""


def build_openapi(app: FastAPI) -> dict[str, Any]:
    """The whole document for ``app``."""
    doc = get_openapi(
        title=app.title,
        version=app.version,
        description=(app.description or "") + WS_DESCRIPTION,
        routes=app.routes,
    )
    components = doc.setdefault("components", {})
    schemas = components.setdefault("schemas", {})
    _, ws = models_json_schema([(m, "serialization") for m in WS_MODELS], ref_template=_REF)
    for name, schema in ws.get("$defs", {}).items():
        schemas.setdefault(name, schema)
    schemes = components.get("securitySchemes", {})
    schemes.pop("ViewerToken", None)
    for methods in doc.get("paths", {}).values():
        for operation in methods.values():
            security = operation.get("security")
            if security and any("ViewerToken" in s for s in security):
                # Viewing: open, or the operator token when view_requires_token is on.
                operation["security"] = [{}, {"OperatorToken": []}]
            invalid = operation.get("responses", {}).get("422")
            if invalid is not None and "HTTPValidationError" in json.dumps(invalid):
                invalid["content"] = {
                    "application/json": {"schema": {"$ref": _REF.format(model="ErrorResponse")}}
                }
    for unused in ("HTTPValidationError", "ValidationError"):
        schemas.pop(unused, None)
    return doc


def install_openapi(app: FastAPI) -> None:
    """Serve :func:`build_openapi`'s document at ``/openapi.json`` (built once)."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = build_openapi(app)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
