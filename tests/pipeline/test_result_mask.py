"""The threshold mask the pipeline worked on comes back with the result (for showing)."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.preprocess import binarize, subsample
from pipeline.render import camera_rotation, make_pad_image, make_scene, render


def test_the_result_carries_the_mask_it_used_and_keeps_it_out_of_json():
    pad = make_pad_image(600)
    reference = Reference.from_image(pad, 0.55)
    camera = Camera.from_fov(960, 720, 60)  # wider than 640: worked on subsampled
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(5))
    frame = render(scene, camera, np.array([0.0, 0.1, 2.5]), camera_rotation(10.0))
    result = process_frame(frame, reference, camera, yaw_hint=10.0, method="otsu")
    assert result.detected
    assert result.mask is not None and result.mask.dtype == np.uint8
    assert result.mask.shape == (480, 640)
    assert set(np.unique(result.mask)) <= {0, 255}
    work, _ = subsample(frame)
    assert np.array_equal(result.mask, binarize(work, "otsu").mask)  # the one it used
    assert "mask" not in result.to_dict()
    blank = process_frame(
        np.zeros((480, 640, 3), np.uint8), reference, Camera.from_fov(640, 480, 60)
    )
    assert not blank.detected and blank.mask is not None and blank.mask.shape == (480, 640)
    assert cv2.countNonZero(blank.mask) == 0


def test_a_followed_pads_mask_is_its_windows_threshold_laid_where_the_window_is():
    pad = make_pad_image(600)
    reference = Reference.from_image(pad, 0.55)
    camera = Camera.from_fov(640, 480, 60)
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(5))
    at, step = np.array([0.1, 0.0, 2.0]), np.array([0.01, 0.0, 0.0])
    first = process_frame(render(scene, camera, at, camera_rotation(10.0)), reference, camera)
    moved = render(scene, camera, at + step, camera_rotation(10.0))
    followed = process_frame(moved, reference, camera, prior=first)
    assert followed.found_by == "follow"
    mask = followed.mask
    assert mask is not None and mask.shape == (480, 640) and mask.dtype == np.uint8
    # Paint where the H is; nothing outside the pad's window (its box and some room).
    h = followed.corners_px
    inside = np.zeros_like(mask)
    cv2.fillPoly(inside, [h.astype(np.int32).reshape(-1, 1, 2)], 255)
    assert cv2.countNonZero(mask & inside) > 0.8 * cv2.countNonZero(inside)
    reach = 0.5 * 1.3 * reference.pad_over_h * float(np.ptp(h, axis=0).max()) + 12
    ys, xs = np.nonzero(mask)
    off = np.abs(np.column_stack([xs, ys]) - h.mean(axis=0)).max()
    assert off <= reach
    assert followed.mask is mask  # made once, when first asked for
