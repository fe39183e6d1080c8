"""An H joined to the ring around it by the blur, cut from it (`pipeline.ring_cut`).

icao_circle's H lies 0.25 m inside its ring; 91 m away on 640 x 480 frames that is
1.5 px, and the threshold made the H and its ring one round region that no H's shape
matched: 3 of the altitude sweep's 20 views were missed there.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import pipeline.find
from pipeline import Camera, process_frame
from pipeline.bench.sweep import altitude_points
from pipeline.bench.tally import TURN, pose_errors
from pipeline.candidates import candidates
from pipeline.render import get_design
from pipeline.ring_cut import cut_from_rings
from pipeline.shapes import regions
from tests.pipeline.bench_support import design_reference, sweep_frames

CAM = Camera.from_fov(640, 480, 60.0)


@pytest.mark.parametrize(
    ("design", "cut"),
    [("icao_circle", (1.749 + 2.0) / 2 / 2.3), ("orange_ring", (0.266 + 0.36) / 2 / 0.413)],
)
def test_a_ringed_h_is_cut_between_its_tips_and_its_ring(design, cut):
    assert design_reference(design).ring_cut == pytest.approx(cut, rel=0.02)


@pytest.mark.parametrize("design", ["default", "icao", "thin", "dark_on_light", "grass_paint"])
def test_an_h_without_a_ring_has_no_cut(design):
    assert design_reference(design).ring_cut is None


def _ring_mask(joined: bool) -> tuple[np.ndarray, np.ndarray]:
    """icao_circle's H and ring drawn on a mask 10 px a metre (the ring 46 px wide), the
    H's tips joined to the ring by bridges or not; and the H's corners (pixels)."""
    reference = design_reference("icao_circle")
    centre = np.array([60.0, 60.0])
    corners = centre + 10.0 * (reference.corners_m - reference.h_centre_m)
    mask = np.zeros((120, 120), np.uint8)
    cv2.circle(mask, (60, 60), 23, 255, thickness=3)
    cv2.fillPoly(mask, [np.rint(corners).astype(np.int32)], 255)
    if joined:
        for tip in corners[np.argsort(np.hypot(*(corners - centre).T))[-4:]]:
            out = centre + (tip - centre) * 22.0 / np.hypot(*(tip - centre))
            cv2.line(mask, tuple(np.rint(tip).astype(int)), tuple(np.rint(out).astype(int)), 255, 2)
    return mask, corners


def test_an_h_joined_to_its_ring_is_cut_out_as_an_h():
    reference = design_reference("icao_circle")
    mask, corners = _ring_mask(joined=True)
    found = regions(mask, min_area=24.0, max_area=1e5)
    assert not candidates(found, reference)  # (one round region: no H's shape)
    cut = cut_from_rings(found, mask, reference)
    assert len(cut) == 1
    # The H whole, and of the bridges only what lies within the cut (2.5 px beyond its
    # tips), none of the ring.
    x, y, w, h = cut[0].box
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    assert x <= lo[0] + 1 and y <= lo[1] + 1 and x + w >= hi[0] and y + h >= hi[1]
    outer = 24.5  # (the ring's outer radius, pixels)
    reach = np.hypot(*(cut[0].contour - 60.0).T).max()
    # (+1.5: the ellipse is fitted to the ring's outermost pixels' centres, and the cut's
    # outline runs through its own outermost pixels)
    assert reach <= reference.ring_cut * outer + 1.5
    assert candidates(cut, reference)


def test_a_ring_apart_from_its_h_gives_no_cut():
    reference = design_reference("icao_circle")
    mask, _ = _ring_mask(joined=False)
    found = regions(mask, min_area=24.0, max_area=1e5)
    assert candidates(found, reference)  # (the H is a region of its own)
    assert cut_from_rings(found, mask, reference) == []


@pytest.mark.parametrize("j", [5, 7])
def test_a_far_h_joined_to_its_ring_is_found(j, monkeypatch):
    point = 9  # (91 m)
    altitude = altitude_points(get_design("icao_circle"), CAM)[point]
    pad, empty, view, hint, reference = sweep_frames(
        "icao_circle", CAM, point, altitude, j, per_point=20
    )
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected, res.reason
    errors = [
        pose_errors(res.pose, T @ view.position_m, T @ view.R_pad_cam)[0] for T in (np.eye(3), TURN)
    ]  # (its H is symmetric: the bench gives no heading)
    assert min(errors) < 5.0
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
    # Not cut from its ring, it is not found.
    monkeypatch.setattr(pipeline.find, "cut_from_rings", lambda *args: [])
    assert not process_frame(pad, reference, CAM, gravity_hint=hint).detected
