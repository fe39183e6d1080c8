"""The API docs, offline: Swagger UI at ``/docs`` and ReDoc at ``/redoc``.

Their scripts and styles are not fetched from a CDN: the dashboard's build copies them
from the pinned npm packages (swagger-ui-dist, redoc; frontend/package.json) into
``frontend/dist/docs-assets/``, and the station serves them from there.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

ASSETS_URL = "/docs-assets"


def install_docs(app: FastAPI, dist: Path) -> None:
    """Serve /docs and /redoc with the assets under ``dist/docs-assets``."""
    assets = dist / "docs-assets"
    missing = (
        "<!doctype html><title>Visland API docs</title><h1>The API docs are not built</h1>"
        "<p>Their scripts come with the dashboard's build: run <code>make install</code> "
        "(or <code>cd frontend && npm ci && npm run build</code>), then reload. The "
        'document itself is at <a href="/openapi.json">/openapi.json</a>.</p>'
    )

    @app.get("/docs", include_in_schema=False)
    def swagger() -> HTMLResponse:
        if not (assets / "swagger-ui-bundle.js").is_file():
            return HTMLResponse(missing, status_code=503)
        return get_swagger_ui_html(
            openapi_url="/openapi.json",
            title=f"{app.title}: API",
            swagger_js_url=f"{ASSETS_URL}/swagger-ui-bundle.js",
            swagger_css_url=f"{ASSETS_URL}/swagger-ui.css",
            swagger_favicon_url=f"{ASSETS_URL}/favicon-32x32.png",
        )

    @app.get("/redoc", include_in_schema=False)
    def redoc() -> HTMLResponse:
        if not (assets / "redoc.standalone.js").is_file():
            return HTMLResponse(missing, status_code=503)
        return get_redoc_html(
            openapi_url="/openapi.json",
            title=f"{app.title}: API",
            redoc_js_url=f"{ASSETS_URL}/redoc.standalone.js",
            redoc_favicon_url=f"{ASSETS_URL}/favicon-32x32.png",
            with_google_fonts=False,
        )

    if assets.is_dir():
        app.mount(ASSETS_URL, StaticFiles(directory=assets), name="docs-assets")
