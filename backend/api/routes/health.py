"""GET /api/health: is the server alive."""

from __future__ import annotations

from fastapi import APIRouter

from backend.station import VERSION

router = APIRouter(tags=["health"])


@router.get("/health")
def health() -> dict:
    """Always ``{"ok": true, "version": ...}`` while the server runs."""
    return {"ok": True, "version": VERSION}
