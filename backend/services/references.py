"""Reference pictures of the pad: measure, store, activate, list; the active one's verifier.

The active reference is kept in memory with its summary, so the vision worker and the
status snapshot never touch the database; listing and storing go to SQLite (the
routes call these from worker threads). Each reference's corner-pattern verifier is
trained in the background (:mod:`backend.verifier_training`) and used once ready.
"""

from __future__ import annotations

import hashlib
import logging
import secrets
import shutil
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from backend.imaging import decode_image, draw_reference
from backend.services.events import EventLog
from backend.storage import Storage
from backend.verifier_training import VerifierStatus, VerifierTrainer
from pipeline import Camera, FrameResult, Reference, process_frame
from pipeline.render import make_pad_image

log = logging.getLogger(__name__)

REFERENCE_IMAGES = ("original", "threshold", "corners")


class NoUsableH(ValueError):
    """The picture decodes but holds no usable H (HTTP 422, the pipeline's reason)."""


@dataclass(frozen=True)
class ActiveReference:
    """The reference the pipeline matches against, with its stored row."""

    id: int
    reference: Reference
    row: dict[str, Any]


ActiveListener = Callable[[ActiveReference], None]


class ReferenceService:
    """References under ``folder`` (pictures) and in ``storage`` (rows)."""

    def __init__(
        self, storage: Storage, folder: Path, events: EventLog, *, verifier_views: int
    ) -> None:
        self._storage = storage
        self._folder = Path(folder)
        self._folder.mkdir(parents=True, exist_ok=True)
        self._events = events
        self._lock = threading.Lock()
        self._active: ActiveReference | None = None
        self._summary: dict[str, Any] | None = None
        self._listeners: tuple[ActiveListener, ...] = ()
        self.trainer = VerifierTrainer(
            lambda ref_id: self._folder / str(ref_id),
            views=verifier_views,
            on_change=self._on_verifier_change,
        )

    # --- the active one (hot paths: no database) -----------------------------------------
    @property
    def active(self) -> ActiveReference | None:
        return self._active

    def current(self) -> Reference | None:
        """The active reference's measurements (what the vision worker matches)."""
        active = self._active
        return None if active is None else active.reference

    def active_summary(self) -> dict[str, Any] | None:
        """The active reference's summary, as of its last change."""
        return self._summary

    def process(
        self,
        image_bgr: np.ndarray,
        reference: Reference,
        camera: Camera,
        *,
        yaw_hint: float | None = None,
        gravity_hint: np.ndarray | None = None,
        prior: FrameResult | None = None,
    ) -> FrameResult:
        """``process_frame`` with the active reference's pattern verifier, once trained."""
        active = self._active
        verifier = None
        if active is not None and active.reference is reference:
            verifier = self.trainer.verifier(active.id)
        return process_frame(
            image_bgr,
            reference,
            camera,
            yaw_hint=yaw_hint,
            gravity_hint=gravity_hint,
            verifier=verifier,
            prior=prior,
        )

    def listen(self, listener: ActiveListener) -> None:
        """Call ``listener(active)`` whenever another reference becomes active."""
        self._listeners = (*self._listeners, listener)

    # --- start-up ------------------------------------------------------------------------
    def load_initial(self, path: Path | None, pad_size_m: float) -> None:
        """The reference to start with: the given picture, else the stored active one,
        else the default pad picture. A given picture without an H raises NoUsableH."""
        if path is not None:
            image = decode_image(Path(path).read_bytes())
            self.add(image, Path(path).name, pad_size_m, quiet=True)
            return
        row = self._storage.active_reference()
        if row is not None:
            try:
                self.activate(row["id"], quiet=True)
                return
            except Exception as exc:
                log.exception("the stored active reference %s cannot be loaded", row["id"])
                # (the operator's dashboard says so: the pad it will look for is another)
                self._events.emit(
                    "reference",
                    f"reference {row['id']} ({row['name']}), active when the station stopped, "
                    f"could not be loaded: {exc}. The default pad is active instead.",
                    {"id": row["id"]},
                )
        self.add(make_pad_image(), "default pad", pad_size_m, quiet=True)

    def close(self) -> None:
        self.trainer.close()

    # --- the operator --------------------------------------------------------------------
    def add(
        self, image_bgr: np.ndarray, name: str, pad_size_m: float, *, quiet: bool = False
    ) -> dict[str, Any]:
        """Measure, store and activate a reference picture; returns its summary.

        Raises :class:`NoUsableH` with the pipeline's reason; on any failure the active
        reference stays as it was.
        """
        try:
            reference = Reference.from_image(image_bgr, pad_size_m)
        except ValueError as exc:
            raise NoUsableH(str(exc)) from exc
        except cv2.error as exc:
            # The vision tripped over this picture (a fault of its own, logged for us);
            # for the operator it is a picture that could not be measured.
            log.warning("the vision failed on an uploaded picture: %s", str(exc).strip())
            raise NoUsableH("The vision could not measure this picture.") from exc
        digest = hashlib.sha256(image_bgr.tobytes()).hexdigest()
        for row in self._storage.list_references():
            if row["data"].get("sha256") == digest and row["pad_size_m"] == float(pad_size_m):
                return self._set_active(row["id"], reference, quiet=quiet)
        tmp = self._folder / f"new-{secrets.token_hex(6)}"
        tmp.mkdir()
        try:
            _write_images(tmp, reference)
            data = {**reference.to_dict(), "sha256": digest}
            ref_id = self._storage.add_reference(name, pad_size_m, "", data)
            final = self._folder / str(ref_id)
            tmp.rename(final)
            self._storage.set_reference_dir(ref_id, str(final))
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return self._set_active(ref_id, reference, quiet=quiet)

    def activate(self, ref_id: int, *, quiet: bool = False) -> dict[str, Any]:
        """Re-activate a stored reference; ``KeyError`` if unknown."""
        row = self._storage.get_reference(ref_id)
        if row is None:
            raise KeyError(ref_id)
        image = cv2.imread(str(Path(row["dir"]) / "original.png"), cv2.IMREAD_COLOR)
        if image is None:
            raise FileNotFoundError(f"reference {ref_id}: its picture is missing")
        try:
            reference = Reference.from_image(np.asarray(image), row["pad_size_m"])
        except ValueError as exc:
            raise NoUsableH(str(exc)) from exc
        return self._set_active(ref_id, reference, quiet=quiet)

    def list(self) -> list[dict[str, Any]]:
        """Every stored reference's summary, newest first (reads the database)."""
        return [self.summary(row) for row in self._storage.list_references()]

    def image_path(self, ref_id: int, kind: str) -> Path | None:
        """One of a reference's pictures (:data:`REFERENCE_IMAGES`), if it exists."""
        row = self._storage.get_reference(ref_id)
        if row is None or kind not in REFERENCE_IMAGES:
            return None
        path = Path(row["dir"]) / f"{kind}.png"
        return path if path.is_file() else None

    def summary(self, row: dict[str, Any]) -> dict[str, Any]:
        """The contract's summary of a stored reference row."""
        data = row["data"]
        rid = row["id"]
        return {
            "id": rid,
            "name": row["name"],
            "pad_size_m": row["pad_size_m"],
            "created": row["created"],
            "active": bool(row["active"]),
            "corners_m": data["corners_m"],
            "hu": data["hu"],
            "orientation_deg": data["orientation_deg"],
            "eccentricity": data["eccentricity"],
            "symmetric": data["symmetric"],
            # (references stored before these were learned have none)
            "marks": len(data.get("marks", ())),
            "letter_hs": len(data.get("lesser_hs", ())),
            "outline_share": data.get("outline_share"),
            "slant_deg": data.get("slant_deg"),
            "image_size": data["image_size"],
            "images": {k: f"/api/references/{rid}/image/{k}" for k in REFERENCE_IMAGES},
            "verifier": self.trainer.status(rid).to_dict(),
        }

    # --- inside --------------------------------------------------------------------------
    def _set_active(self, ref_id: int, reference: Reference, *, quiet: bool) -> dict[str, Any]:
        with self._lock:
            self._storage.activate_reference(ref_id)
            row = self._storage.get_reference(ref_id)
            assert row is not None  # just activated it
            active = ActiveReference(ref_id, reference, row)
            self._active = active
            self._summary = self.summary(row)
        self.trainer.request(ref_id, reference)
        self._summary = self.summary(row)  # with the verifier's state after the request
        for listener in self._listeners:
            try:
                listener(active)
            except Exception:
                log.exception("a reference listener failed")
        if not quiet:
            self._events.emit(
                "reference", f"reference {ref_id} ({row['name']}) active", {"id": ref_id}
            )
        return self._summary

    def _on_verifier_change(self, ref_id: int, status: VerifierStatus) -> None:
        active = self._active
        if active is not None and active.id == ref_id:
            # Progress reaches the dashboard in the status message's reference summary.
            self._summary = self.summary(active.row)
        if status.state in ("ready", "unavailable", "failed"):
            self._events.emit(
                "reference",
                f"reference {ref_id}: {status.detail}",
                {"id": ref_id, "verifier": status.to_dict()},
            )


def _write_images(folder: Path, reference: Reference) -> None:
    image = reference.image
    mask = np.where(np.asarray(reference.mask) > 0, 255, 0).astype(np.uint8)
    if mask.shape[:2] != image.shape[:2]:
        size = (image.shape[1], image.shape[0])
        mask = np.asarray(cv2.resize(mask, size, interpolation=cv2.INTER_NEAREST), np.uint8)
    for name, picture in (
        ("original", image),
        ("threshold", mask),
        ("corners", draw_reference(reference)),
    ):
        if not cv2.imwrite(str(folder / f"{name}.png"), picture):
            raise OSError(f"could not write {folder / name}.png")
