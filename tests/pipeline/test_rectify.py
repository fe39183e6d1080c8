"""pipeline.rectify: the pad's outline suggested on perspective photos, and rectification.

Rendered photos (the default pad warped by a known homography onto a noisy floor) give
the truth to measure against; a real photo of a round pad from ../shared/photos (skipped
when absent) must give an outline from which a reference can be made.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline import Reference
from pipeline.rectify import order_corners, rectify, suggest_outline
from pipeline.render import make_pad_image
from tests.pipeline.bench_support import PHOTOS, needs_photos

TRUTH = [
    [[210, 110], [470, 130], [520, 380], [150, 350]],
    [[100, 200], [400, 150], [600, 300], [50, 450]],
    [[250, 60], [420, 90], [430, 300], [200, 280]],
]


def rendered_photo(corners, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pad = make_pad_image(400)
    floor = rng.normal(120, 25, (480, 640, 3)).clip(0, 255).astype(np.uint8)
    floor = cv2.GaussianBlur(floor, (7, 7), 0)
    src = np.float32([[0, 0], [400, 0], [400, 400], [0, 400]])
    H = cv2.getPerspectiveTransform(src, np.float32(corners))
    warped = cv2.warpPerspective(pad, H, (640, 480))
    mask = cv2.warpPerspective(np.full((400, 400), 255, np.uint8), H, (640, 480))
    return np.where(mask[..., None] > 0, warped, floor)


@pytest.mark.parametrize(("seed", "corners"), list(enumerate(TRUTH)))
def test_the_pad_outline_is_found_on_rendered_perspective_photos(seed, corners):
    outline = suggest_outline(rendered_photo(corners, seed))
    assert outline.kind == "quad"
    error = np.abs(outline.quad - np.asarray(corners, float)).max()
    assert error < 4.0, (error, outline.quad.round(1).tolist())


def test_the_rectified_photo_is_a_reference_like_the_pad_itself():
    photo = rendered_photo(TRUTH[1], 1)
    flat = rectify(photo, suggest_outline(photo).quad, size_px=400)
    ref = Reference.from_image(flat, 0.55)
    truth = Reference.from_image(make_pad_image(400), 0.55)
    # the H's corners in metres agree within a centimetre on a 0.55 m pad
    assert np.abs(np.asarray(ref.corners_m) - np.asarray(truth.corners_m)).max() < 0.01


def test_rectify_checks_its_inputs():
    img = np.zeros((100, 100, 3), np.uint8)
    with pytest.raises(ValueError, match="corners_px must be 4 finite"):
        rectify(img, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="convex quadrilateral"):
        rectify(img, np.array([[0, 0], [50, 50], [50, 0], [0, 50]], float))  # crossed
    with pytest.raises(ValueError, match="image_bgr"):
        rectify(np.zeros((10, 10), np.uint8), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="too small"):
        suggest_outline(np.zeros((10, 10, 3), np.uint8))


def test_a_photo_without_an_h_gets_the_middle_as_a_guess():
    blank = np.full((300, 400, 3), 128, np.uint8)
    outline = suggest_outline(blank)
    assert outline.kind == "h_box" and outline.h_box is None
    assert order_corners(outline.quad).tolist() == outline.quad.tolist()


@needs_photos
def test_a_real_round_pad_photographed_at_an_angle_gives_a_reference():
    manifest = json.loads((PHOTOS / "manifest.json").read_text())
    item = next(i for i in manifest["items"] if i["file"].endswith("acbchiella_frame-0080.jpg"))
    photo = cv2.imread(str(PHOTOS / item["file"]), cv2.IMREAD_COLOR)
    outline = suggest_outline(photo)
    assert outline.kind == "ellipse" and outline.ellipse is not None
    # the H found lies inside the hand-checked box around it
    x, y, w, h = item["h_box"]
    hx, hy, hw, _ = outline.h_box
    assert x - 0.1 * w <= hx and hx + hw <= x + 1.1 * w and y - 0.1 * h <= hy <= y + 1.1 * h
    # the H's centre is near the middle of the suggested square
    centre = outline.ellipse.mean(axis=0)
    assert np.hypot(*(centre - [x + w / 2, y + h / 2])) < 0.25 * w
    ref = Reference.from_image(rectify(photo, outline.ellipse), 1.1)
    assert len(ref.corners_px) == 12
