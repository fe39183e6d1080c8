"""The pad renderer: geometry to a fraction of a pixel, distortion, noise, bad input."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from pipeline.camera import Camera
from pipeline.render import (
    BOARD_BGR,
    FLOOR_KINDS,
    LOOKALIKE_KINDS,
    PAD_SIZE_M,
    PAINT_BGR,
    Lighting,
    PadGeometry,
    camera_rotation,
    degrade,
    make_floor,
    make_lookalike,
    make_pad_image,
    make_scene,
    project_points,
    random_lighting,
    random_view,
    render,
    render_view,
)
from pipeline.render.__main__ import main as cli_main
from pipeline.render.pad import rect_coverage
from pipeline.result import yaw_of

CAM = Camera.from_fov(640, 480, 60.0)
DIST_CAM = Camera(
    640, 480, Camera.from_fov(640, 480, 70.0).K, np.array([-0.25, 0.08, 1e-3, -1.5e-3, 0.0])
)
BLACK = float(np.mean(BOARD_BGR))
WHITE = float(np.mean(PAINT_BGR))


@pytest.fixture(scope="module")
def pad_image() -> np.ndarray:
    return make_pad_image(1100)


@pytest.fixture(scope="module")
def plain_scene(pad_image: np.ndarray):
    return make_scene(pad_image, PAD_SIZE_M, rng=np.random.default_rng(1), floor="plain")


@pytest.fixture(scope="module")
def busy_scene(pad_image: np.ndarray):
    return make_scene(pad_image, PAD_SIZE_M, rng=np.random.default_rng(2), lookalikes=3)


def _gray(img: np.ndarray) -> np.ndarray:
    return img.astype(np.float64).mean(axis=2)


def _polygon_centroid_area(pts: np.ndarray) -> tuple[np.ndarray, float]:
    m = cv2.moments(pts.astype(np.float32).reshape(-1, 1, 2))
    return np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]), m["m00"]


# ---------------------------------------------------------------- the pad picture


def test_pad_image_matches_geometry(pad_image: np.ndarray) -> None:
    g = PadGeometry()
    assert pad_image.shape == (1100, 1100, 3) and pad_image.dtype == np.uint8
    gray = _gray(pad_image)
    # Black rim all round, the H's centre white.
    assert gray[:20].max() < 40 and gray[:, :20].max() < 40 and gray[550, 550] > 220
    # The white area equals the H plus the two bars, to a fraction of a percent.
    white_frac = ((gray - BLACK) / (WHITE - BLACK)).mean()
    bars = 2 * g.side_bar_width * g.side_bar_length
    expected = g.h_area_m2 / g.size_m**2 + bars
    assert white_frac == pytest.approx(expected, rel=2e-3)
    # Each H corner sits on a texel boundary: of the four texels touching it, one is
    # white at the 8 outer (convex) corners and three at the 4 inner (concave) ones.
    px_per_m = 1100 / g.size_m
    whites = []
    for corner in g.h_corners_m:
        c = corner * [px_per_m, -px_per_m] + 550 - 0.5  # texel centres at integers
        offsets = [(dx, dy) for dx in (-0.75, 0.75) for dy in (-0.75, 0.75)]
        touching = [np.round(c + off).astype(int) for off in offsets]
        vals = np.array([gray[y, x] for x, y in touching])
        assert np.all((vals < 40) | (vals > 220))  # no partial texels: the edges are exact
        whites.append(int((vals > 220).sum()))
    assert sorted(whites) == [1] * 8 + [3] * 4
    assert [whites[i] for i in (2, 3, 8, 9)] == [3, 3, 3, 3]


def test_pad_symmetric_under_half_turn(pad_image: np.ndarray) -> None:
    assert np.abs(pad_image.astype(int) - np.rot90(pad_image, 2).astype(int)).max() <= 1
    corners = PadGeometry().h_corners_m
    np.testing.assert_allclose(corners, -np.roll(corners, -6, axis=0), atol=1e-12)


def test_strokes_visible_at_six_metres() -> None:
    g = PadGeometry()
    px_per_m = CAM.fx / 6.0
    assert g.leg_width * g.size_m * px_per_m >= 3.0
    assert g.crossbar_height * g.size_m * px_per_m >= 3.0
    assert 0.4 <= g.h_height <= 0.6  # about half the board


@pytest.mark.parametrize(
    "kwargs",
    [
        {"size_px": 10},
        {"size_px": 100.5},
        {"h_width": 0.0},
        {"h_width": 1.2},
        {"leg_width": 0.3},
        {"crossbar_height": 0.6},
        {"h_height": float("nan")},
        {"board_bgr": (0, 0)},
        {"paint_bgr": (300, 0, 0)},
    ],
)
def test_pad_image_bad_input(kwargs: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(kwargs)).split("_bgr")[0]):
        make_pad_image(**kwargs)


def test_pad_geometry_bad_input() -> None:
    with pytest.raises(ValueError, match="size_m"):
        PadGeometry(size_m=-1.0)
    with pytest.raises(ValueError, match="side_bar"):
        PadGeometry(side_bar_width=0.3)


def test_rect_coverage_is_exact_area() -> None:
    cover = rect_coverage([(0.113, 0.207, 0.491, 0.777)], 37)
    assert cover.sum() == pytest.approx((0.491 - 0.113) * (0.777 - 0.207) * 37**2, rel=1e-12)


# ---------------------------------------------------------------- look-alikes


def _true_h_mask(size: int) -> np.ndarray:
    g = PadGeometry()
    s = 0.9 / g.h_height
    rects = [
        (0.5 + x0 * s, 0.5 - y1 * s, 0.5 + x1 * s, 0.5 - y0 * s) for x0, y0, x1, y1 in g._h_rects()
    ]
    return rect_coverage(rects, size) > 0.5


@pytest.mark.parametrize("kind", LOOKALIKE_KINDS)
def test_lookalikes_are_shapes_but_not_the_h(kind: str) -> None:
    rng = np.random.default_rng(7)
    true_h = _true_h_mask(128)
    for _ in range(10):
        mask = make_lookalike(kind, 128, rng)
        assert mask.shape == (128, 128) and mask.dtype == np.uint8
        shape = mask > 127
        assert 0.03 < shape.mean() < 0.85, kind
        # Its outline stays inside the square (nothing cut off at the border).
        assert not shape[0].any() and not shape[-1].any(), kind
        iou = (shape & true_h).sum() / (shape | true_h).sum()
        assert iou < 0.9, kind
    n_parts = cv2.connectedComponents(make_lookalike(kind, 128, rng))[0] - 1
    if kind in ("II", "h_no_bar", "broken_h"):
        assert n_parts >= 2
    elif kind in ("rectangle", "cross", "wide_h"):
        assert n_parts == 1


def test_lookalike_bad_input() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="kind"):
        make_lookalike("H", 64, rng)
    with pytest.raises(ValueError, match="size_px"):
        make_lookalike("cross", 4, rng)
    with pytest.raises(ValueError, match="rng"):
        make_lookalike("cross", 64, 3)  # type: ignore[arg-type]


# ---------------------------------------------------------------- floor and scene


@pytest.mark.parametrize("kind", FLOOR_KINDS)
def test_floor_is_mid_grey_and_seamless(kind: str) -> None:
    tile = make_floor(kind, np.random.default_rng(4), 256).astype(np.float64)
    assert 70 < tile.mean() < 170
    # Across the wrap-around seam the texture changes no more than between neighbours.
    inner = np.abs(np.diff(tile, axis=1)).mean()
    seam = np.abs(tile[:, 0] - tile[:, -1]).mean()
    assert seam < 2.0 * inner + 1.0
    inner_v = np.abs(np.diff(tile, axis=0)).mean()
    assert np.abs(tile[0] - tile[-1]).mean() < 2.0 * inner_v + 1.0


def test_lookalikes_beside_the_pad_not_on_it(busy_scene) -> None:
    assert len(busy_scene.lookalikes) == 3
    half = PAD_SIZE_M / 2
    pad_poly = np.array([(-half, half), (half, half), (half, -half), (-half, -half)])
    for i, d in enumerate(busy_scene.lookalikes):
        assert d.kind in LOOKALIKE_KINDS
        assert np.hypot(*d.center_m) < 4 * PAD_SIZE_M  # near enough to be in view
        # Separating-axis test of two convex quads: some edge normal separates them.
        assert _separated(d.corners_m, pad_poly)
        for other in busy_scene.lookalikes[i + 1 :]:
            assert _separated(d.corners_m, other.corners_m)


def _separated(a: np.ndarray, b: np.ndarray) -> bool:
    for poly in (a, b):
        for k in range(4):
            edge = poly[(k + 1) % 4] - poly[k]
            n = np.array([-edge[1], edge[0]])
            pa, pb = a @ n, b @ n
            if pa.max() < pb.min() or pb.max() < pa.min():
                return True
    return False


def test_lookalikes_show_up_in_renders(busy_scene) -> None:
    """From 4 m straight above, the look-alikes' white paint is in the picture."""
    img = render(busy_scene, CAM, np.array([0, 0, 4.0]), camera_rotation(0.0))
    gray = _gray(img)
    visible = 0
    for d in busy_scene.lookalikes:
        px = project_points(CAM, np.array([0, 0, 4.0]), camera_rotation(0.0), [d.center_m])[0]
        if 10 < px[0] < 630 and 10 < px[1] < 470:
            x, y = np.round(px).astype(int)
            visible += gray[y - 12 : y + 13, x - 12 : x + 13].max() > 180
    assert visible >= 1


def test_pad_visible_false_has_no_pad(pad_image: np.ndarray) -> None:
    seen = []
    for visible in (True, False):
        scene = make_scene(
            pad_image, PAD_SIZE_M, rng=5, floor="asphalt", lookalikes=2, pad_visible=visible
        )
        img = render(scene, CAM, np.array([0.1, -0.1, 3.0]), camera_rotation(30.0))
        seen.append((_gray(img) < 45).sum())
        assert len(scene.lookalikes) == 2 and scene.pad_visible is visible
    # The board is ~2700 px of near-black at 3 m; without it (almost) none remain.
    assert seen[0] > 2000 and seen[1] < 50


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((np.zeros((0, 0, 3), np.uint8), 0.5), {}, "texture_bgr"),
        ((np.zeros((10, 10, 4), np.uint8), 0.5), {}, "texture_bgr"),
        ((np.zeros((10, 10, 3), np.float32), 0.5), {}, "texture_bgr"),
        (("pad.png", 0.5), {}, "texture_bgr"),
        ((np.zeros((10, 10, 3), np.uint8), 0.0), {}, "size_m"),
        ((np.zeros((10, 10, 3), np.uint8), float("nan")), {}, "size_m"),
        ((np.zeros((10, 10, 3), np.uint8), 0.5), {"floor": "lava"}, "floor"),
        ((np.zeros((10, 10, 3), np.uint8), 0.5), {"lookalikes": 9}, "lookalikes"),
        ((np.zeros((10, 10, 3), np.uint8), 0.5), {"lookalikes": 1.5}, "lookalikes"),
        (
            (np.zeros((10, 10, 3), np.uint8), 0.5),
            {"lookalikes": 1, "lookalike_kinds": ["H"]},
            "kinds",
        ),
        ((np.zeros((10, 10, 3), np.uint8), 0.5), {"rng": "x"}, "rng"),
    ],
)
def test_make_scene_bad_input(args: tuple, kwargs: dict, match: str) -> None:
    kwargs = {"rng": 0} | kwargs
    with pytest.raises(ValueError, match=match):
        make_scene(*args, **kwargs)


# ---------------------------------------------------------------- geometry


def _h_coverage(img: np.ndarray, corners_px: np.ndarray) -> np.ndarray:
    """Fraction of white paint per pixel near the H (board black = 0, paint = 1)."""
    near = np.zeros(img.shape[:2], np.uint8)
    cv2.fillPoly(near, [np.round(corners_px * 16).astype(np.int32)], 1, shift=4)
    near = cv2.dilate(near, np.ones((7, 7), np.uint8))
    return np.clip((_gray(img) - BLACK) / (WHITE - BLACK), 0, 1) * near


def test_h_lands_where_projectpoints_says(plain_scene) -> None:
    g = PadGeometry()
    rng = np.random.default_rng(11)
    ys, xs = np.mgrid[0 : CAM.height, 0 : CAM.width]
    for _ in range(8):
        v = random_view(rng, CAM, altitude=(1.0, 6.0), max_tilt_deg=15.0)
        img = render(plain_scene, CAM, v.position_m, v.R_pad_cam)
        corners = project_points(CAM, v.position_m, v.R_pad_cam, g.h_corners_m)
        cov = _h_coverage(img, corners)
        centroid = np.array([(cov * xs).sum(), (cov * ys).sum()]) / cov.sum()
        want, area = _polygon_centroid_area(corners)
        assert np.linalg.norm(centroid - want) < 0.1, v.to_dict()
        assert cov.sum() == pytest.approx(area, rel=0.01)


def test_without_supersampling_still_sub_pixel(plain_scene) -> None:
    g = PadGeometry()
    ys, xs = np.mgrid[0 : CAM.height, 0 : CAM.width]
    pos, R = np.array([0.31, -0.17, 3.3]), camera_rotation(57.0, tilt_deg=9.0, tilt_dir_deg=200)
    img = render(plain_scene, CAM, pos, R, supersample=1)
    corners = project_points(CAM, pos, R, g.h_corners_m)
    cov = _h_coverage(img, corners)
    centroid = np.array([(cov * xs).sum(), (cov * ys).sum()]) / cov.sum()
    want, area = _polygon_centroid_area(corners)
    assert np.linalg.norm(centroid - want) < 0.25
    assert cov.sum() == pytest.approx(area, rel=0.02)


def test_edges_land_where_projectpoints_says(plain_scene) -> None:
    """Half-way crossings of the H's left edge match the projected edge within 0.1 px."""
    g = PadGeometry()
    for x_off in (0.0, 0.013, 0.029):  # sub-pixel shifts of the camera
        pos = np.array([x_off, 0.0, 2.0])
        R = camera_rotation(0.0)
        img = _gray(render(plain_scene, CAM, pos, R))
        left = project_points(CAM, pos, R, g.h_corners_m[[0, 11]])  # the left leg's outer edge
        edge_x = left[:, 0].mean()
        for row in range(int(left[0, 1]) + 5, int(left[1, 1]) - 5, 7):
            prof = (img[row] - BLACK) / (WHITE - BLACK)
            i = int(np.floor(edge_x))
            seg = prof[i - 3 : i + 4]
            k = int(np.argmax(seg >= 0.5))
            a, b = seg[k - 1], seg[k]
            crossing = i - 3 + k - 1 + (0.5 - a) / (b - a)
            assert crossing == pytest.approx(edge_x, abs=0.1)


def test_aruco_marker_detected_where_projected() -> None:
    """An outside oracle: OpenCV's ArUco detector finds the rendered marker's corners."""
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    marker = cv2.aruco.generateImageMarker(dictionary, 7, 240)
    quiet = cv2.copyMakeBorder(marker, 40, 40, 40, 40, cv2.BORDER_CONSTANT, value=255)
    scene = make_scene(quiet, 0.32, rng=3, floor="asphalt")  # a grey picture works too
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(dictionary, params)
    s = 0.32 * 240 / 320 / 2
    square = np.array([(-s, s), (s, s), (s, -s), (-s, -s)])  # ArUco's corner order
    poses = [
        (np.array([0.1, 0.05, 1.5]), camera_rotation(25.0, tilt_deg=8.0, tilt_dir_deg=100.0)),
        (np.array([-0.3, 0.2, 2.5]), camera_rotation(-70.0)),
    ]
    for pos, R in poses:
        corners, ids, _ = detector.detectMarkers(render(scene, CAM, pos, R))
        assert ids is not None and ids.ravel().tolist() == [7]
        want = project_points(CAM, pos, R, square)
        assert np.abs(corners[0].reshape(4, 2) - want).max() < 0.6


def test_distortion_points_land_where_projectpoints_says() -> None:
    dot = np.zeros((64, 64, 3), np.uint8)
    dot[16:48, 16:48] = 255
    scene = make_scene(dot, 0.04, rng=1, floor="plain")
    R = camera_rotation(15.0, tilt_deg=5.0, tilt_dir_deg=40.0)
    Kinv = np.linalg.inv(DIST_CAM.K)
    for target in [(320, 240), (40, 40), (600, 450), (100, 400)]:
        und = DIST_CAM.undistort_points(np.array([target], float))[0]
        d = R @ (Kinv @ [und[0], und[1], 1.0])
        pos = 2.0 * d / d[2]  # 2 m up, on the ray through the target and the dot
        want = project_points(DIST_CAM, pos, R, np.zeros((1, 2)))[0]
        assert np.linalg.norm(want - target) < 0.1  # the pose really aims there
        img = _gray(render(scene, DIST_CAM, pos, R))
        x, y = np.round(want).astype(int)
        win = img[max(0, y - 15) : y + 16, max(0, x - 15) : x + 16]
        w = np.clip(win - np.median(win), 0, None) * (win > np.median(win) + 20)
        wy, wx = np.mgrid[0 : win.shape[0], 0 : win.shape[1]]
        got = np.array([(w * wx).sum(), (w * wy).sum()]) / w.sum()
        got += [max(0, x - 15), max(0, y - 15)]
        assert np.linalg.norm(got - want) < 0.1, (target, got, want)


def test_distortion_bends_straight_edges(plain_scene) -> None:
    """The same pose with and without distortion: the pad moves where the model says."""
    ideal = Camera(640, 480, DIST_CAM.K)
    pos, R = np.array([0.6, 0.4, 1.5]), camera_rotation(10.0)
    corners = PadGeometry().h_corners_m
    for cam in (ideal, DIST_CAM):
        img = render(plain_scene, cam, pos, R)
        cov = _h_coverage(img, project_points(cam, pos, R, corners))
        _, area = _polygon_centroid_area(project_points(cam, pos, R, corners))
        assert cov.sum() == pytest.approx(area, rel=0.05)
    shift = project_points(DIST_CAM, pos, R, corners) - project_points(ideal, pos, R, corners)
    assert np.abs(shift).max() > 5  # the test would notice distortion being ignored


# ---------------------------------------------------------------- degradations


@pytest.mark.parametrize("snr", [15.0, 20.0, 30.0])
def test_measured_snr_matches_request(plain_scene, snr: float) -> None:
    pos, R = np.array([3.0, 2.0, 2.0]), camera_rotation(0.0)  # plain mid-grey floor only
    clean = render(plain_scene, CAM, pos, R).astype(np.float64)
    assert 100 < clean.mean() < 150
    noisy = render(plain_scene, CAM, pos, R, snr_db=snr, rng=np.random.default_rng(3))
    noise = noisy.astype(np.float64) - clean
    measured = 10 * np.log10(np.mean(clean**2) / np.mean(noise**2))
    assert measured == pytest.approx(snr, abs=0.5)
    assert abs(noise.mean()) < 0.3  # zero-mean


def test_noise_is_white_and_added_after_blur(plain_scene) -> None:
    pos, R = np.array([3.0, 2.0, 2.0]), camera_rotation(0.0)
    clean = render(plain_scene, CAM, pos, R, blur_sigma_px=2.0).astype(np.float64)
    noisy = render(
        plain_scene, CAM, pos, R, blur_sigma_px=2.0, snr_db=20.0, rng=np.random.default_rng(0)
    )
    n = noisy.astype(np.float64) - clean
    corr = np.corrcoef(n[:, 1:, 0].ravel(), n[:, :-1, 0].ravel())[0, 1]
    assert abs(corr) < 0.03


def test_blur_softens_edges(plain_scene) -> None:
    pos, R = np.array([0.0, 0.0, 2.0]), camera_rotation(0.0)
    sharp = _gray(render(plain_scene, CAM, pos, R))
    soft = _gray(render(plain_scene, CAM, pos, R, blur_sigma_px=1.5))
    assert np.abs(np.diff(soft, axis=1)).max() < 0.6 * np.abs(np.diff(sharp, axis=1)).max()


def test_lighting_gain_gradient_vignetting() -> None:
    m = Lighting(gain=0.8, gradient=0.2, gradient_dir_deg=0.0, vignetting=0.3).gain_map(101, 51)
    assert m[25, 50] == pytest.approx(0.8, abs=1e-6)
    assert m[25, 100] > m[25, 0]  # brighter toward image right
    assert m[0, 0] < m[25, 0]  # darker in the corners
    img = np.full((51, 101, 3), 200, np.uint8)
    out = degrade(img, light=Lighting(gain=0.5))
    assert np.all(out == 100)
    light = random_lighting(np.random.default_rng(0))
    assert 0.65 <= light.gain <= 1.25


@pytest.mark.parametrize(
    "kwargs",
    [
        {"gain": 0.0},
        {"gain": float("inf")},
        {"gradient": 1.0},
        {"vignetting": -0.1},
        {"gradient_dir_deg": float("nan")},
    ],
)
def test_lighting_bad_input(kwargs: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        Lighting(**kwargs)


def test_clipping_to_uint8() -> None:
    out = degrade(np.full((8, 8, 3), 250, np.uint8), light=Lighting(gain=1.2))
    assert out.dtype == np.uint8 and np.all(out == 255)


# ---------------------------------------------------------------- determinism


def test_same_seed_same_frames(pad_image: np.ndarray) -> None:
    frames = []
    for seed in (21, 21, 22):
        rng = np.random.default_rng(seed)
        scene = make_scene(pad_image, PAD_SIZE_M, rng=rng, lookalikes=2)
        view = random_view(rng, CAM)
        frames.append(render_view(scene, CAM, view, rng))
    assert np.array_equal(frames[0], frames[1])
    assert not np.array_equal(frames[0], frames[2])


# ---------------------------------------------------------------- poses


def test_camera_rotation_yaw_and_tilt() -> None:
    np.testing.assert_allclose(camera_rotation(0.0), np.diag([1.0, -1.0, -1.0]), atol=1e-12)
    rng = np.random.default_rng(0)
    for _ in range(50):
        yaw, tilt, tdir = rng.uniform(-179, 180), rng.uniform(0, 30), rng.uniform(0, 360)
        R = camera_rotation(yaw, tilt_deg=tilt, tilt_dir_deg=tdir)
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        assert yaw_of(R) == pytest.approx(yaw, abs=1e-9)
        axis = R[:, 2]
        assert math.degrees(math.acos(-axis[2])) == pytest.approx(tilt, abs=1e-9)
        if tilt > 1:  # the axis leans toward tilt_dir
            lean = math.degrees(math.atan2(axis[1], axis[0]))
            assert (lean - tdir + 180) % 360 - 180 == pytest.approx(0.0, abs=1e-9)


def test_nadir_yaw_zero_sees_pad_upright(plain_scene) -> None:
    """Image right = pad +x, image down = pad -y: the right bar right, the top edge up."""
    pos, R = np.array([0.0, 0.0, 2.0]), camera_rotation(0.0)
    px = project_points(CAM, pos, R, np.array([(0.225, 0.0), (0.0, 0.2)]))
    assert px[0, 0] > 330 and px[1, 1] < 230
    img = _gray(render(plain_scene, CAM, pos, R))
    x, y = np.round(px[0]).astype(int)
    assert img[y, x] > 200  # the right side bar at pad x = +0.225 m


def test_camera_rotation_bad_input() -> None:
    with pytest.raises(ValueError, match="yaw_deg"):
        camera_rotation(float("nan"))
    with pytest.raises(ValueError, match="tilt_deg"):
        camera_rotation(0.0, tilt_deg=-1.0)
    with pytest.raises(ValueError, match="tilt_deg"):
        camera_rotation(0.0, tilt_deg=85.0)


def test_random_view_keeps_pad_inside() -> None:
    rng = np.random.default_rng(9)
    board = PadGeometry().board_corners_m
    for _ in range(60):
        v = random_view(rng, CAM)
        assert 1.0 <= v.altitude_m <= 6.0 and 0 <= v.tilt_deg <= 12.0
        assert 15.0 <= v.snr_db <= 30.0 and 0 <= v.blur_sigma_px <= 1.2
        assert yaw_of(v.R_pad_cam) == pytest.approx(v.yaw_deg, abs=1e-9)
        px = project_points(CAM, v.position_m, v.R_pad_cam, board)
        assert px.min() >= 8 and px[:, 0].max() <= 631 and px[:, 1].max() <= 471


def test_a_view_turned_to_a_given_yaw_draws_the_rest_as_without() -> None:
    for yaw in (0.0, 30.0, -90.0):
        v = random_view(np.random.default_rng(4), CAM, yaw_deg=yaw, max_tilt_deg=3.0)
        assert v.yaw_deg == yaw and yaw_of(v.R_pad_cam) == pytest.approx(yaw, abs=1e-9)
        assert v.tilt_deg <= 3.0
    free = random_view(np.random.default_rng(5), CAM)
    turned = random_view(np.random.default_rng(5), CAM, yaw_deg=10.0)
    assert turned.altitude_m == free.altitude_m and turned.tilt_deg == free.tilt_deg
    assert turned.snr_db == free.snr_db and turned.blur_sigma_px == free.blur_sigma_px
    with pytest.raises(ValueError, match="yaw_deg"):
        random_view(np.random.default_rng(5), CAM, yaw_deg=float("nan"))


def test_view_to_dict_is_json() -> None:
    v = random_view(np.random.default_rng(1), CAM)
    d = json.loads(json.dumps(v.to_dict()))
    assert d["position_m"] == pytest.approx(list(v.position_m))
    assert set(d["light"]) == {"gain", "gradient", "gradient_dir_deg", "vignetting"}


def test_random_view_with_distortion_and_options() -> None:
    rng = np.random.default_rng(10)
    board = PadGeometry().board_corners_m
    for _ in range(20):
        v = random_view(rng, DIST_CAM, snr_db=None, max_blur_px=0.0, lighting=False)
        assert v.snr_db is None and v.blur_sigma_px == 0.0 and v.light is None
        px = project_points(DIST_CAM, v.position_m, v.R_pad_cam, board)
        assert px.min() >= 8 and px[:, 0].max() <= 631 and px[:, 1].max() <= 471


def test_random_view_bad_input() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="altitude"):
        random_view(rng, CAM, altitude=(0.2, 0.3))  # the pad cannot fit the image
    with pytest.raises(ValueError, match="altitude"):
        random_view(rng, CAM, altitude=(6.0, 1.0))
    with pytest.raises(ValueError, match="max_tilt_deg"):
        random_view(rng, CAM, max_tilt_deg=float("nan"))
    with pytest.raises(ValueError, match="rng"):
        random_view(0, CAM)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="camera"):
        random_view(rng, "cam")  # type: ignore[arg-type]


# ---------------------------------------------------------------- render's edges


def test_far_and_tilted_views_see_only_floor_or_sky(busy_scene) -> None:
    # High up: the floor tile repeats without gaps (no black texels from a border).
    img = render(busy_scene, CAM, np.array([5.0, -3.0, 40.0]), camera_rotation(33.0, tilt_deg=15))
    assert _gray(img).min() > 20
    # Tilted past the horizon: the sky fills the top, the floor the bottom.
    R = camera_rotation(0.0, tilt_deg=75.0, tilt_dir_deg=90.0)
    img = render(busy_scene, CAM, np.array([0.0, 0.0, 2.0]), R)
    assert np.all(img[0] == (215, 200, 185)) and not np.all(img[-1] == (215, 200, 185))


@pytest.mark.parametrize(
    ("pos", "R", "kwargs", "match"),
    [
        ((0, 0, 0.0), None, {}, "position_m"),
        ((0, 0, -1.0), None, {}, "position_m"),
        ((0, float("nan"), 1.0), None, {}, "position_m"),
        ((0, 0), None, {}, "position_m"),
        ((0, 0, 2.0), np.eye(3), {}, "looks away"),  # optical axis up
        ((0, 0, 2.0), np.diag([1.0, 1.0, -1.0]), {}, "R_pad_cam"),  # a reflection
        ((0, 0, 2.0), 2 * np.eye(3), {}, "R_pad_cam"),
        ((0, 0, 2.0), np.eye(2), {}, "R_pad_cam"),
        ((0, 0, 2.0), None, {"snr_db": float("nan"), "rng": np.random.default_rng(0)}, "snr_db"),
        ((0, 0, 2.0), None, {"snr_db": 20.0}, "rng"),
        ((0, 0, 2.0), None, {"blur_sigma_px": -1.0}, "blur_sigma_px"),
        ((0, 0, 2.0), None, {"light": 0.5}, "light"),
        ((0, 0, 2.0), None, {"supersample": 5}, "supersample"),
    ],
)
def test_render_bad_input(plain_scene, pos, R, kwargs: dict, match: str) -> None:
    R = camera_rotation(0.0) if R is None else R
    with pytest.raises(ValueError, match=match):
        render(plain_scene, CAM, np.array(pos, float), R, **kwargs)


def test_render_bad_scene_or_camera(plain_scene) -> None:
    with pytest.raises(ValueError, match="scene"):
        render("scene", CAM, np.array([0, 0, 2.0]), camera_rotation(0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="camera"):
        render(plain_scene, None, np.array([0, 0, 2.0]), camera_rotation(0.0))  # type: ignore[arg-type]


def test_cli_writes_a_frame(tmp_path) -> None:
    out = tmp_path / "x.png"
    assert cli_main(["--out", str(out), "--seed", "3", "--width", "320", "--height", "240"]) == 0
    img = cv2.imread(str(out))
    assert img is not None and img.shape == (240, 320, 3)
    assert (_gray(img) < 50).sum() > 100  # the black board is in view
