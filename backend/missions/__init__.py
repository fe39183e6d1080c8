"""Vision missions: hover over the pad, land on it (ArduCopter precision landing or GCS
guidance), with failsafes and a record of every run.

>>> from backend.missions import LandConfig, LandMission
>>> mission = LandMission(link, LandConfig(strategy="plnd"), now=0.0)  # doctest: +SKIP
>>> mission.step(now, VisionSample(result, camera, t_capture))  # doctest: +SKIP
"""

from backend.missions.config import ABORT_MODES, STRATEGIES, HoverConfig, LandConfig, Mount
from backend.missions.geometry import PadFix, heading_error_deg, pad_fix
from backend.missions.hover import HoverMission
from backend.missions.land import LandMission
from backend.missions.mission import TERMINAL, Mission, TouchdownTruth, VisionSample
from backend.missions.record import OUTCOMES, RunRecord, Touchdown

__all__ = [
    "ABORT_MODES",
    "OUTCOMES",
    "STRATEGIES",
    "TERMINAL",
    "HoverConfig",
    "HoverMission",
    "LandConfig",
    "LandMission",
    "Mission",
    "Mount",
    "PadFix",
    "RunRecord",
    "Touchdown",
    "TouchdownTruth",
    "VisionSample",
    "heading_error_deg",
    "pad_fix",
]
