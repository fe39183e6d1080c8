"""GET /api/health: is the server alive."""

from __future__ import annotations

from fastapi import APIRouter

from backend.api.schemas import Health
from backend.station import VERSION

router = APIRouter(tags=["health"])


@router.get("/health", response_model=Health)
async def health() -> Health:
    """Always ``{"ok": true, "version": ...}`` while the server runs."""
    return Health(ok=True, version=VERSION)
