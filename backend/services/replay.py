"""A recorded flight as one timeline for the dashboard's replay.

Everything is on the UNIX clock: the .tlog's record stamps, ``t_unix`` of each result
in results.jsonl, and the mission runs' state changes (their start time plus the
state's offset). The dashboard plays it back: frames with their overlays, telemetry,
mission states and the local-frame views, in step with one scrubber.
"""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path
from typing import Any

from pymavlink import mavutil

log = logging.getLogger(__name__)

#: Telemetry samples per second kept for replay (the page interpolates nothing: the
#: nearest sample before the scrubber is shown).
TELEMETRY_HZ = 10.0
#: Contour points kept per frame (the page draws the outline, not every pixel).
CONTOUR_POINTS = 64
_MESSAGES = [
    "HEARTBEAT",
    "ATTITUDE",
    "LOCAL_POSITION_NED",
    "GLOBAL_POSITION_INT",
    "SYS_STATUS",
    "STATUSTEXT",
]


def _finite(value: Any) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def read_tlog(path: Path) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Telemetry samples (at most :data:`TELEMETRY_HZ`) and the vehicle's texts from a tlog.

    A tlog cut short (a crash while writing) is read up to its last whole record.
    """
    samples: list[dict[str, Any]] = []
    texts: list[dict[str, Any]] = []
    if not path.is_file() or path.stat().st_size == 0:
        return samples, texts
    state: dict[str, Any] = {
        "mode": None,
        "armed": None,
        "n": None,
        "e": None,
        "d": None,
        "roll": None,
        "pitch": None,
        "yaw": None,
        "alt": None,
        "battery_v": None,
    }
    last_t = -math.inf
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    try:
        while True:
            try:
                msg = conn.recv_match(type=_MESSAGES)
            except Exception:  # a torn last record: what came before stands
                break
            if msg is None:
                break
            if msg.get_srcComponent() == mavutil.mavlink.MAV_COMP_ID_MISSIONPLANNER:
                continue  # our own heartbeats and commands
            t = float(getattr(msg, "_timestamp", 0.0))
            kind = msg.get_type()
            if kind == "HEARTBEAT":
                if msg.type == mavutil.mavlink.MAV_TYPE_GCS:
                    continue
                state["mode"] = mavutil.mode_string_v10(msg)
                state["armed"] = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            elif kind == "ATTITUDE":
                state["roll"], state["pitch"], state["yaw"] = (
                    _finite(msg.roll),
                    _finite(msg.pitch),
                    _finite(msg.yaw),
                )
            elif kind == "LOCAL_POSITION_NED":
                state["n"], state["e"], state["d"] = _finite(msg.x), _finite(msg.y), _finite(msg.z)
            elif kind == "GLOBAL_POSITION_INT":
                state["alt"] = msg.relative_alt / 1000.0
            elif kind == "SYS_STATUS":
                if msg.voltage_battery != 0xFFFF:
                    state["battery_v"] = msg.voltage_battery / 1000.0
            elif kind == "STATUSTEXT":
                texts.append({"t": t, "severity": int(msg.severity), "text": str(msg.text)})
                continue
            if t - last_t >= 1.0 / TELEMETRY_HZ:
                last_t = t
                samples.append({"t": t, **state})
    finally:
        conn.close()
    return samples, texts


def read_results(path: Path, flight_id: int) -> list[dict[str, Any]]:
    """One entry per processed frame (results.jsonl), with its recorded JPEG's URL."""
    frames: list[dict[str, Any]] = []
    if not path.is_file():
        return frames
    with path.open(encoding="utf-8", errors="replace") as fh:
        for line in fh:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue  # a line cut by a crash
            if not isinstance(row, dict) or "t_unix" not in row:
                continue
            result = row.get("result") or {}
            contour = result.get("contour_px") or []
            step = max(1, math.ceil(len(contour) / CONTOUR_POINTS))
            pose = result.get("pose") or None
            frames.append(
                {
                    "seq": int(row.get("seq", 0)),
                    "t": float(row["t_unix"]),
                    "url": (
                        f"/api/flights/{flight_id}/frames/{int(row['seq'])}.jpg"
                        if row.get("frame")
                        else None
                    ),
                    "detected": bool(result.get("detected")),
                    "corners_px": result.get("corners_px") or [],
                    "contour_px": contour[::step],
                    "overlay": row.get("overlay"),
                    "position_m": None if pose is None else pose.get("position_m"),
                    "latency_ms": _finite(row.get("latency_ms")),
                    "reason": str(result.get("reason", "")),
                }
            )
    return frames


def mission_states(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The mission runs' state changes on the UNIX clock."""
    out = []
    for run in runs:
        detail = run.get("detail") or {}
        states = [
            {
                "t": float(run["started"]) + float(s.get("t", 0.0)),
                "state": s.get("state", ""),
                "reason": s.get("reason", ""),
            }
            for s in detail.get("states", [])
        ]
        out.append(
            {
                "id": run["id"],
                "kind": run["kind"],
                "strategy": detail.get("strategy"),
                "outcome": run.get("outcome"),
                "started": run["started"],
                "ended": run.get("ended"),
                "states": states,
            }
        )
    return out
