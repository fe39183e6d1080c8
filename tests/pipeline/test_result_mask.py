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
