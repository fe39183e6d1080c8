"""Candidate checks against plain statements of what they measure."""

import math

import cv2
import numpy as np

from pipeline import Reference
from pipeline import candidates as candidates_module
from pipeline.candidates import (
    CSS_AFTER_NOTHING_FROM_PX,
    blob_separation,
    candidates,
    locate,
    match_corners,
)
from pipeline.preprocess import Binarized
from pipeline.render import PadGeometry, make_pad_image
from pipeline.shapes import regions

H = PadGeometry().h_corners_m


def _pooled(inside: np.ndarray, band: np.ndarray) -> float:
    pooled = math.sqrt(0.5 * (inside.var() + band.var()))
    return (inside.mean() - band.mean()) / max(pooled, 1.0)


def test_blob_separation_is_the_regions_against_its_band_or_its_quadrants_median():
    rng = np.random.default_rng(2)
    img = rng.normal(60.0, 6.0, (120, 160))
    px = H * 300 + np.array([80.0, 60.0])
    mask = np.zeros(img.shape, np.uint8)
    cv2.fillPoly(mask, [np.round(px).astype(np.int32)], 255)
    img[mask > 0] += 90.0
    img[:, 80:] *= 0.5  # a shadow across the right half
    smooth = np.clip(img, 0, 255).astype(np.uint8)
    region = max(regions(mask, min_area=50, max_area=1e6), key=lambda r: r.area)
    got = blob_separation(smooth, region, stroke_px=3.0)
    # The same by masks: the region (strokes under 4 px are not eroded), a 3 px band
    # past a 1 px gap.
    filled = np.zeros(img.shape, np.uint8)
    cv2.fillPoly(filled, [region.contour.astype(np.int32)], 1)
    inside = filled > 0
    near = cv2.dilate(filled, np.ones((3, 3), np.uint8)) > 0
    band = (cv2.dilate(filled, np.ones((7, 7), np.uint8)) > 0) & ~near
    values = smooth.astype(np.float64)
    whole = _pooled(values[inside], values[band])
    cx, cy = region.contour.mean(axis=0)
    xs, ys = np.meshgrid(np.arange(160), np.arange(120))
    parts = [
        _pooled(values[inside & q], values[band & q])
        for q in ((xs < cx) & (ys < cy), (xs >= cx) & (ys < cy), (xs < cx) & (ys >= cy),
                  (xs >= cx) & (ys >= cy))
    ]  # fmt: skip
    assert math.isclose(got, max(whole, float(np.median(parts))), rel_tol=1e-9)
    assert np.median(parts) > whole  # the shadow: each part stands out more than the whole


def test_corners_far_from_any_h_are_not_fitted_with_a_homography():
    rng = np.random.default_rng(0)
    scribble = rng.uniform(0, 100, (12, 2))
    _, residual, homography = match_corners(scribble, H, area=2000.0)
    assert homography is None and residual > 0.3
    ordered, residual, homography = match_corners(np.roll(H * 500, 5, axis=0), H, area=2000.0)
    assert homography is not None and residual < 1e-6
    np.testing.assert_allclose(ordered, H * 500, atol=1e-9)


def test_a_small_candidate_whose_shape_start_finds_no_h_gets_no_corner_reading(monkeypatch):
    # An H-shaped mask over a channel with no edges: the shape match's start finds none
    # of the H's sides. Its CSS corners are read only when it is large enough for
    # perspective to have put that start out of reach.
    reference = Reference.from_image(make_pad_image(800), 0.55)
    read = []
    monkeypatch.setattr(
        candidates_module, "css_homography", lambda region, *_: read.append(region.area)
    )
    for size in (30.0, 120.0):
        mask = np.zeros((200, 200), np.uint8)
        h_px = H * size / np.ptp(H, axis=0).max() + 100.0  # an H spanning size px
        cv2.fillPoly(mask, [np.round(h_px).astype(np.int32)], 255)
        flat = np.full(mask.shape, 128, np.uint8)
        binary = Binarized(gray=flat, smooth=flat, mask=mask, threshold=100.0)
        (cand,) = candidates(regions(mask, min_area=24, max_area=1e5), reference)
        assert locate(cand, binary, reference) is None
    assert len(read) == 1 and math.sqrt(read[0]) >= CSS_AFTER_NOTHING_FROM_PX
