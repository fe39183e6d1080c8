"""One encoder for every viewer and the recorder: JPEG and JSON made once per frame.

The :class:`FrameEncoder` takes the newest result from its slot on the processed-frame
bus, on its own thread (never the vision worker's, never the event loop), and
publishes an :class:`EncodedFrame` on the encoded-frame bus: the ``frame`` message
text, the result's JSON (the recorder's ``results.jsonl`` line reuses it), the camera
JPEG and, when a viewer asked for it, the threshold view made from the mask the
pipeline actually used. When nobody wants encoded frames (no viewer, no recording)
it skips the work.

Binary WebSocket frames: 4-byte big-endian header length N, N bytes of UTF-8 JSON
header (``kind``, ``seq``, ``t_capture``, ``width``, ``height``), then the JPEG bytes.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import struct
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from backend.framebus import FrameBus, Slot
from backend.vision_worker import Processed
from pipeline import Camera
from pipeline.moments import hu_distance

log = logging.getLogger(__name__)

#: Hu invariants compared with the reference (the H is symmetric under a half turn,
#: so Hu 3..7 are noise around zero).
HU_COUNT = 2
_JOIN_S = 5.0


def pack_binary(header: dict[str, Any], jpeg: bytes) -> bytes:
    """A binary frame message: length-prefixed JSON header, then the JPEG bytes.

    >>> unpack_binary(pack_binary({"kind": "camera", "seq": 1}, b"\\xff\\xd8"))
    ({'kind': 'camera', 'seq': 1}, b'\\xff\\xd8')
    """
    head = json.dumps(header, separators=(",", ":")).encode()
    return struct.pack(">I", len(head)) + head + jpeg


def unpack_binary(message: bytes) -> tuple[dict[str, Any], bytes]:
    """The inverse of :func:`pack_binary` (tests and tools)."""
    if len(message) < 4:
        raise ValueError("message is shorter than its 4-byte length prefix")
    (n,) = struct.unpack_from(">I", message)
    if 4 + n > len(message):
        raise ValueError(f"header length {n} runs past the message's {len(message)} bytes")
    return json.loads(message[4 : 4 + n].decode()), message[4 + n :]


def _project(points_pad: np.ndarray, position_m: Any, R_pad_cam: Any, camera: Camera) -> np.ndarray:
    """Pad-frame points (N x 3) to pixels through the pose (camera centre, R_pad_cam)."""
    R = np.asarray(R_pad_cam, float)
    rvec, _ = cv2.Rodrigues(R.T)
    tvec = -R.T @ np.asarray(position_m, float).reshape(3)
    px, _ = cv2.projectPoints(np.asarray(points_pad, float), rvec, tvec, camera.K, camera.dist)
    return np.asarray(px).reshape(-1, 2)


def finite_points(points: Any) -> list[list[float]]:
    """Points as ``[[x, y], ...]`` rounded to 0.01 px, non-finite ones left out.

    >>> finite_points(np.array([[1.234, 2.0], [np.nan, 1.0]]))
    [[1.23, 2.0]]
    """
    return [
        [round(float(x), 2), round(float(y), 2)]
        for x, y in np.asarray(points, float).reshape(-1, 2)
        if math.isfinite(x) and math.isfinite(y)
    ]


def overlay_for(processed: Processed) -> dict[str, Any]:
    """What the dashboard draws over the frame beyond the result's own corners and
    contour: the reference's corners put through the pose, the pad's axes and centre."""
    result, camera, reference = processed.result, processed.camera, processed.reference
    overlay: dict[str, Any] = {"reference_corners": [], "axes": None, "target": None}
    pose = result.pose
    if pose is None:
        return overlay
    # Only draw what lies in front of the camera.
    R = np.asarray(pose.R_pad_cam, float)
    pos = np.asarray(pose.position_m, float)
    corners_m = np.asarray(reference.corners_m, float).reshape(-1, 2)
    ref3 = np.column_stack([corners_m, np.zeros(len(corners_m))])
    axis = float(reference.pad_size_m) / 2
    axes3 = np.array([[0, 0, 0], [axis, 0, 0], [0, axis, 0], [0, 0, axis]], float)
    depth = (R.T @ (np.vstack([ref3, axes3]) - pos).T)[2]
    if np.any(depth <= 1e-6):
        return overlay
    overlay["reference_corners"] = finite_points(_project(ref3, pos, R, camera))
    ax = _project(axes3, pos, R, camera)
    if np.all(np.isfinite(ax)):
        o, x, y, z = ([round(float(v), 2) for v in p] for p in ax)
        overlay["axes"] = {"origin": o, "x": x, "y": y, "z": z}
        overlay["target"] = o
    return overlay


def result_dict(processed: Processed) -> dict[str, Any]:
    """The result as JSON data, its points rounded to 0.01 px (finite only)."""
    out = processed.result.to_dict()
    out["corners_px"] = finite_points(processed.result.corners_px)
    out["contour_px"] = finite_points(processed.result.contour_px)
    return out


def reference_distance(processed: Processed) -> float | None:
    """Distance of the frame's Hu invariants from the reference's (None without an H)."""
    result = processed.result
    if not result.detected or not any(result.hu):
        return None
    with contextlib.suppress(Exception):
        hu = np.asarray(result.hu, float)
        d = float(hu_distance(hu, np.asarray(processed.reference.hu, float), count=HU_COUNT))
        return d if math.isfinite(d) else None
    return None


def frame_header(processed: Processed) -> dict[str, Any]:
    """The ``frame`` message without its result (the encoder splices the result in)."""
    frame = processed.frame
    h, w = frame.image.shape[:2]
    return {
        "type": "frame",
        "seq": frame.seq,
        "t_capture": frame.t_capture,
        "latency_ms": round(processed.latency_ms, 2),
        "width": w,
        "height": h,
        "overlay": overlay_for(processed),
        "reference_distance": reference_distance(processed),
    }


def frame_message(processed: Processed) -> dict[str, Any]:
    """The ``frame`` JSON message of one processed frame (as data)."""
    return {**frame_header(processed), "result": result_dict(processed)}


def splice(head: dict[str, Any], key: str, raw_json: str) -> str:
    """``head`` as JSON text with ``key`` set to the already encoded ``raw_json``.

    >>> splice({"a": 1}, "b", '{"c":2}')
    '{"a":1,"b":{"c":2}}'
    """
    text = json.dumps(head, separators=(",", ":"))
    return text[:-1] + ("," if len(text) > 2 else "") + json.dumps(key) + ":" + raw_json + "}"


@dataclass(frozen=True, eq=False)
class EncodedFrame:
    """One processed frame, encoded once for all viewers and the recorder.

    ``text``: the WebSocket ``frame`` message. ``result_json``: the result alone.
    ``jpeg``: the camera picture. ``camera_message``/``threshold_message``: the
    binary WebSocket messages (threshold only when a viewer asked for it).
    """

    processed: Processed
    text: str
    result_json: str
    jpeg: bytes | None
    camera_message: bytes | None
    threshold_message: bytes | None


class FrameEncoder:
    """Encodes the newest processed frame for ``out``'s subscribers, on its own thread.

    Parameters
    ----------
    source : the encoder's slot on the processed-frame bus.
    out : the encoded-frame bus (viewers and the recorder subscribe to it).
    jpeg_quality : returns the JPEG quality now (a runtime setting).

    ``threshold_wanted`` is set by the viewers' hub: whether any viewer shows the
    threshold view (only then is its JPEG made).
    """

    def __init__(
        self,
        source: Slot[Processed],
        out: FrameBus[EncodedFrame],
        *,
        jpeg_quality: Callable[[], int],
    ) -> None:
        self._source = source
        self._out = out
        self._quality = jpeg_quality
        self.threshold_wanted = False
        self._thread: threading.Thread | None = None
        self.encoded = 0
        self.skipped = 0
        self.errors = 0

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="frame-encoder", daemon=True)
            self._thread.start()

    def close(self) -> None:
        self._source.close()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(_JOIN_S)

    def _run(self) -> None:
        while True:
            processed = self._source.take()
            if processed is None:
                return  # closed
            if not self._out.wanted():
                self.skipped += 1
                continue
            try:
                self._out.publish(self.encode(processed))
            except Exception:
                self.errors += 1
                log.exception("encoding frame %d failed", processed.frame.seq)

    def encode(self, processed: Processed) -> EncodedFrame:
        """JPEG and JSON of one processed frame (also usable without the thread)."""
        frame = processed.frame
        quality = int(self._quality())
        result_json = json.dumps(result_dict(processed), separators=(",", ":"))
        text = splice(frame_header(processed), "result", result_json)
        h, w = frame.image.shape[:2]
        head = {"seq": frame.seq, "t_capture": frame.t_capture, "width": w, "height": h}
        jpeg = _jpeg(frame.image, quality)
        camera = None if jpeg is None else pack_binary({"kind": "camera", **head}, jpeg)
        threshold = None
        mask = processed.result.mask
        if mask is not None and self.threshold_wanted:
            mh, mw = mask.shape[:2]
            data = _jpeg(mask, quality)
            if data is not None:
                header = {"kind": "threshold", **head, "width": mw, "height": mh}
                threshold = pack_binary(header, data)
        self.encoded += 1
        return EncodedFrame(processed, text, result_json, jpeg, camera, threshold)


def _jpeg(image: np.ndarray, quality: int) -> bytes | None:
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    return buf.tobytes() if ok else None
