"""Synthetic camera frames of the landing pad at a known pose.

Used by the tests, the accuracy benchmark, the network's training data and the
simulated camera. `DESIGNS` holds named pad designs with their ground truth; `View`
carries a frame's degradations, the real world's among them (perspective, motion
blur, cast shadows, glare, exposure, JPEG; `random_view(..., realistic=True)`).

Pad frame: origin at the pad centre, +x to the picture's right edge, +y to its top
edge, +z up; camera frame: OpenCV (x right, y down, z forward); a pose is (camera
centre in the pad frame, R_pad_cam).

Examples
--------
>>> import numpy as np
>>> from pipeline.camera import Camera
>>> rng = np.random.default_rng(3)
>>> scene = make_scene(make_pad_image(512), PAD_SIZE_M, rng=rng, lookalikes=2)
>>> cam = Camera.from_fov(320, 240, 60.0)
>>> view = random_view(rng, cam)
>>> render_view(scene, cam, view, rng).shape
(240, 320, 3)
"""

from pipeline.render.degrade import (
    Exposure,
    Glare,
    Lighting,
    MotionBlur,
    Shadow,
    degrade,
    random_lighting,
)
from pipeline.render.designs import DESIGNS, Design, DesignPicture, HShape, get_design
from pipeline.render.floor import FLOOR_KINDS, OUTDOOR_KINDS, TEXTURED_KINDS, make_floor
from pipeline.render.pad import (
    BOARD_BGR,
    H_CROSSBAR_HEIGHT,
    H_HEIGHT,
    H_LEG_WIDTH,
    H_WIDTH,
    LOOKALIKE_KINDS,
    PAD_SIZE_M,
    PAINT_BGR,
    PadGeometry,
    make_lookalike,
    make_pad_image,
)
from pipeline.render.raster import project_points, render
from pipeline.render.scene import Decal, Scene, make_scene
from pipeline.render.view import View, camera_rotation, random_extras, random_view, render_view

__all__ = [
    "BOARD_BGR",
    "DESIGNS",
    "FLOOR_KINDS",
    "H_CROSSBAR_HEIGHT",
    "H_HEIGHT",
    "H_LEG_WIDTH",
    "H_WIDTH",
    "LOOKALIKE_KINDS",
    "OUTDOOR_KINDS",
    "PAD_SIZE_M",
    "PAINT_BGR",
    "TEXTURED_KINDS",
    "Decal",
    "Design",
    "DesignPicture",
    "Exposure",
    "Glare",
    "HShape",
    "Lighting",
    "MotionBlur",
    "PadGeometry",
    "Scene",
    "Shadow",
    "View",
    "camera_rotation",
    "degrade",
    "get_design",
    "make_floor",
    "make_lookalike",
    "make_pad_image",
    "make_scene",
    "project_points",
    "random_extras",
    "random_lighting",
    "random_view",
    "render",
    "render_view",
]
