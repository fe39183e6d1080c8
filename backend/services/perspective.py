"""References from a photo of the pad taken in perspective: photo, corners, preview, activate.

1. The operator uploads a photo: it is kept as a draft and the pad's outline is
   suggested (:func:`pipeline.rectify.suggest_outline`).
2. The operator confirms or moves the four outer corners; the server rectifies the
   photo to the pad seen from above (:func:`pipeline.rectify.rectify`) and measures the
   H on it, without activating anything: the preview.
3. The operator activates the preview: it becomes a reference like an uploaded one.

Nothing changes the active reference before step 3, and a failure at any step leaves
it as it was. Drafts live under ``folder`` (the last :data:`KEEP` photos).
"""

from __future__ import annotations

import secrets
import shutil
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from backend.imaging import draw_reference
from backend.services.references import NoUsableH, ReferenceService
from pipeline import Reference
from pipeline.rectify import Outline, rectify, suggest_outline

#: Drafts kept (older ones are deleted).
KEEP = 8
#: Width of the rectified picture (px).
RECTIFIED_PX = 600


class NoSuchDraft(LookupError):
    """No draft photo or preview with that id (it may have expired)."""


class BadCorners(ValueError):
    """The corners do not outline a pad (one sentence)."""


@dataclass
class Draft:
    """One uploaded photo and its previews."""

    id: str
    name: str
    folder: Path
    size: tuple[int, int]
    outline: Outline
    created: float = field(default_factory=time.time)
    previews: dict[str, dict[str, Any]] = field(default_factory=dict)


class PerspectiveDrafts:
    """Draft photos under ``folder``; activation goes through ``references``."""

    def __init__(self, folder: Path, references: ReferenceService) -> None:
        self._folder = Path(folder)
        shutil.rmtree(self._folder, ignore_errors=True)  # drafts do not outlive a start
        self._folder.mkdir(parents=True, exist_ok=True)
        self._references = references
        self._drafts: OrderedDict[str, Draft] = OrderedDict()
        self._lock = threading.Lock()

    def add_photo(self, image_bgr: np.ndarray, name: str) -> dict[str, Any]:
        """Keep the photo as a draft; returns its id, size and suggested outline."""
        outline = suggest_outline(image_bgr)
        draft_id = secrets.token_hex(6)
        folder = self._folder / draft_id
        folder.mkdir()
        if not cv2.imwrite(str(folder / "photo.png"), image_bgr):
            shutil.rmtree(folder, ignore_errors=True)
            raise OSError("the photo could not be kept on disk")
        h, w = image_bgr.shape[:2]
        draft = Draft(draft_id, name, folder, (w, h), outline)
        with self._lock:
            self._drafts[draft_id] = draft
            while len(self._drafts) > KEEP:
                _, old = self._drafts.popitem(last=False)
                shutil.rmtree(old.folder, ignore_errors=True)
        return self.describe(draft)

    def describe(self, draft: Draft) -> dict[str, Any]:
        return {
            "id": draft.id,
            "name": draft.name,
            "width": draft.size[0],
            "height": draft.size[1],
            "photo": f"/api/reference/perspective/{draft.id}/photo",
            "outline": draft.outline.to_dict(),
        }

    def photo_path(self, draft_id: str) -> Path:
        return self._get(draft_id).folder / "photo.png"

    def preview(
        self, draft_id: str, corners: list[list[float]], pad_size_m: float, aspect: float = 1.0
    ) -> dict[str, Any]:
        """Rectify the draft with ``corners`` (TL, TR, BR, BL) and measure its H.

        Raises :class:`BadCorners` for corners outside the photo or not a convex
        quadrilateral, :class:`NoUsableH` (with the pipeline's reason) when the
        rectified picture holds no usable H. Nothing becomes active.
        """
        draft = self._get(draft_id)
        pts = np.asarray(corners, float)
        w, h = draft.size
        margin = 0.5 * max(w, h)  # a pad cut by the photo's edge may have corners outside
        if (
            np.any(pts[:, 0] < -margin)
            or np.any(pts[:, 0] > w + margin)
            or np.any(pts[:, 1] < -margin)
            or np.any(pts[:, 1] > h + margin)
        ):
            raise BadCorners("The corners lie far outside the photo; drag them onto the pad.")
        photo = cv2.imread(str(draft.folder / "photo.png"), cv2.IMREAD_COLOR)
        if photo is None:
            raise NoSuchDraft(f"The photo of draft {draft_id} is gone; upload it again.")
        try:
            flat = rectify(photo, pts, size_px=RECTIFIED_PX, aspect=aspect)
        except ValueError as exc:
            raise BadCorners(
                "The four corners must go round the pad in order (top-left, top-right, "
                "bottom-right, bottom-left) and enclose it."
            ) from exc
        try:
            reference = Reference.from_image(flat, pad_size_m)
        except ValueError as exc:
            raise NoUsableH(f"{exc} (on the rectified picture; adjust the corners)") from exc
        preview_id = secrets.token_hex(6)
        if not cv2.imwrite(str(draft.folder / f"{preview_id}.png"), flat) or not cv2.imwrite(
            str(draft.folder / f"{preview_id}-corners.png"),
            draw_reference(reference),
        ):
            raise OSError("the rectified picture could not be kept on disk")
        preview = {
            "id": preview_id,
            "draft": draft.id,
            "pad_size_m": float(pad_size_m),
            "aspect": float(aspect),
            "corners": pts.round(2).tolist(),
            "image": f"/api/reference/perspective/{draft.id}/previews/{preview_id}.png",
            "corners_image": (
                f"/api/reference/perspective/{draft.id}/previews/{preview_id}-corners.png"
            ),
            "h_corners": len(reference.corners_px),
            "symmetric": bool(reference.symmetric),
            "detail": f"An H with {len(reference.corners_px)} corners was found on the rectified "
            "picture; activate it to use it.",
        }
        with self._lock:
            draft.previews[preview_id] = preview
        return preview

    def preview_path(self, draft_id: str, name: str) -> Path:
        draft = self._get(draft_id)
        stem = name.removesuffix(".png").removesuffix("-corners")
        if stem not in draft.previews:
            raise NoSuchDraft(f"No preview {stem} of draft {draft_id}.")
        path = draft.folder / name
        if not path.is_file():
            raise NoSuchDraft(f"No preview {stem} of draft {draft_id}.")
        return path

    def activate(self, draft_id: str, preview_id: str) -> dict[str, Any]:
        """Make the preview the active reference; returns its summary."""
        draft = self._get(draft_id)
        preview = draft.previews.get(preview_id)
        if preview is None:
            raise NoSuchDraft(f"No preview {preview_id} of draft {draft_id}.")
        flat = cv2.imread(str(draft.folder / f"{preview_id}.png"), cv2.IMREAD_COLOR)
        if flat is None:
            raise NoSuchDraft(f"The rectified picture {preview_id} is gone; preview again.")
        name = f"{draft.name} (rectified)"
        return self._references.add(np.asarray(flat), name, preview["pad_size_m"])

    def _get(self, draft_id: str) -> Draft:
        with self._lock:
            draft = self._drafts.get(draft_id)
        if draft is None:
            raise NoSuchDraft(f"No photo {draft_id}; it may have expired: upload it again.")
        return draft
