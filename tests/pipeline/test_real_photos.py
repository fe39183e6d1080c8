"""The pipeline on real photos of real H pads (``../shared/photos``, skipped when absent).

Each design's reference is used as the manifest gives it; a detection counts when
all 12 corners lie in the hand-checked box around the H, grown by 10 % of its size
(at least 3 px) on every side, as the manifest's ``box_rule`` says.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline import Camera, Reference, process_frame

PHOTOS = Path(__file__).resolve().parents[2].parent / "shared" / "photos"
pytestmark = pytest.mark.skipif(
    not (PHOTOS / "manifest.json").exists(), reason="../shared/photos is not beside the checkout"
)
FOV_DEG = 70.0  # the photos' cameras are unknown; the corners do not depend on it


@cache
def _manifest() -> dict:
    return json.loads((PHOTOS / "manifest.json").read_text())


@cache
def _reference(file: str, size: float) -> Reference:
    return Reference.from_image(cv2.imread(str(PHOTOS / file)), size)


def _detect(item: dict, reference: Reference):
    image = cv2.imread(str(PHOTOS / item["file"]))
    h, w = image.shape[:2]
    return process_frame(image, reference, Camera.from_fov(w, h, FOV_DEG))


def _in_box(corners: np.ndarray, box: list[int]) -> bool:
    x, y, w, h = box
    gx, gy = max(3.0, 0.1 * w), max(3.0, 0.1 * h)
    inside_x = (corners[:, 0] >= x - gx) & (corners[:, 0] <= x + w + gx)
    inside_y = (corners[:, 1] >= y - gy) & (corners[:, 1] <= y + h + gy)
    return bool(np.all(inside_x & inside_y))


def _references(same_polarity: bool):
    """(design, reference entry): the references drawn in the pads' own polarity, or
    those drawn inverted (a different pad design in fact: dark H for a light one)."""
    if not (PHOTOS / "manifest.json").exists():
        return []
    out = []
    for design, info in _manifest()["designs"].items():
        for ref in info["references"]:
            if ("inverted" in ref["kind"]) != same_polarity:
                out.append((design, ref))
    return out


@pytest.mark.slow
def test_positives_are_found_with_their_designs_references():
    found = total = 0
    misses = []
    for design, entry in _references(same_polarity=True):
        reference = _reference(entry["file"], entry["pad_size_m"])
        for item in _manifest()["items"]:
            if item["kind"] != "pos" or item["design"] != design:
                continue
            res = _detect(item, reference)
            total += 1
            if res.detected and _in_box(res.corners_px, item["h_box"]):
                found += 1
            else:
                why = res.reason or "outside the box"
                misses.append(f"{item['file']} with {entry['file']}: {why}")
    assert total > 0
    assert found / total >= 0.9, misses


@pytest.mark.slow
def test_no_detection_on_the_negatives_with_any_reference():
    entries = [e for _, e in _references(True) + _references(False)]
    entries.append(_manifest()["default_reference"])
    hits = []
    for entry in entries:
        reference = _reference(entry["file"], entry["pad_size_m"])
        for item in _manifest()["items"]:
            if item["kind"] == "neg" and _detect(item, reference).detected:
                hits.append(f"{item['file']} with {entry['file']}")
    assert hits == []


def test_every_reference_picture_is_accepted():
    for _, entry in _references(True) + _references(False):
        ref = _reference(entry["file"], entry["pad_size_m"])
        assert ref.corners_m.shape == (12, 2)


def test_a_dark_h_reference_learns_its_polarity():
    design = "dark_H_in_ring_on_white_paper"
    entry = next(e for d, e in _references(True) if d == design)
    assert _reference(entry["file"], entry["pad_size_m"]).polarity == "dark"
