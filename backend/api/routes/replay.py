"""A recorded flight for the dashboard's replay: GET /api/flights/{id}/replay.

One timeline on the UNIX clock: each processed frame with its overlay (and its JPEG's
URL when frames were kept), the telemetry from the flight's .tlog at 10 Hz, the
vehicle's texts and the state changes of the mission runs during the flight.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, status

from backend.api.deps import FlightId, FlightsDep, Viewer
from backend.api.errors import VIEWER_ERRORS, errors
from backend.api.schemas import FlightReplay
from backend.services.flights import NoSuchFlight

router = APIRouter(prefix="/flights", tags=["flights"])


@router.get(
    "/{flight_id}/replay",
    dependencies=[Viewer],
    response_model=FlightReplay,
    responses={**VIEWER_ERRORS, **errors(404, 422)},
)
def flight_replay(flight_id: FlightId, flights: FlightsDep) -> dict[str, Any]:
    """Frames, telemetry, texts and mission states of one flight, for replay."""
    try:
        return flights.replay(flight_id)
    except NoSuchFlight as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from None
