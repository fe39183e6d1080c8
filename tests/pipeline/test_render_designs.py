"""Pad designs and the real world's degradations: geometry, determinism, effects."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline.camera import Camera
from pipeline.render import (
    DESIGNS,
    FLOOR_KINDS,
    Exposure,
    Glare,
    MotionBlur,
    PadGeometry,
    Shadow,
    camera_rotation,
    degrade,
    get_design,
    make_pad_image,
    make_scene,
    project_points,
    random_view,
    render,
    render_view,
)
from pipeline.render.designs import HShape, polygon_outline, star

CAM = Camera.from_fov(640, 480, 60.0)
PX = 400


@pytest.fixture(scope="module")
def pictures():
    return {name: d.draw(PX) for name, d in DESIGNS.items()}


def test_registry_has_the_designs_the_issue_names() -> None:
    want = {"default", "icao", "dark_on_light", "thin", "serif_octagon", "orange_ring"}
    want |= {"red_on_black", "grass_paint", "paper_ring"}
    assert want <= set(DESIGNS) and len(DESIGNS) >= 9
    assert get_design("icao") is DESIGNS["icao"]
    with pytest.raises(ValueError, match="design must be one of"):
        get_design("nope")


def test_default_design_is_the_seed_pad_unchanged() -> None:
    for px in (64, 333, 1100):
        assert np.array_equal(DESIGNS["default"].draw(px).image, make_pad_image(px))
    np.testing.assert_allclose(DESIGNS["default"].h_corners_m, PadGeometry().h_corners_m)


def test_icao_h_is_three_by_one_point_eight() -> None:
    for name in ("icao", "icao_circle"):
        c = DESIGNS[name].h_corners_m
        span = c.max(axis=0) - c.min(axis=0)
        np.testing.assert_allclose(span, [1.8, 3.0], atol=1e-9)
        np.testing.assert_allclose(c[1, 0] - c[0, 0], 0.4, atol=1e-9)  # the leg's stroke


def test_thin_design_legs_under_ten_percent() -> None:
    h = DESIGNS["thin"].h
    assert 0.08 <= h.leg / h.width <= 0.10


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_every_design_renders_at_any_size(name: str, pictures) -> None:
    pic = pictures[name]
    assert pic.image.shape == (PX, PX, 3) and pic.image.dtype == np.uint8
    assert pic.h_corners_m.shape == (12, 2) and pic.size_m == DESIGNS[name].size_m
    small = DESIGNS[name].draw(48)
    assert small.image.shape == (48, 48, 3)
    if pic.alpha is not None:
        assert pic.alpha.shape == (PX, PX) and pic.alpha.dtype == np.uint8
        assert pic.alpha.min() == 0 and pic.alpha.max() == 255


def _to_px(corners_m: np.ndarray, size_m: float, n: int) -> np.ndarray:
    """Pad metres -> picture pixel coordinates (pixel centres at integers)."""
    u = (corners_m[:, 0] / size_m + 0.5) * n - 0.5
    v = (0.5 - corners_m[:, 1] / size_m) * n - 0.5
    return np.column_stack([u, v])


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_h_corners_land_on_the_pictures_edges(name: str, pictures) -> None:
    """Across the middle of every side of the H (between neighbouring corners) the
    picture changes from the H's colour to what surrounds it half-way exactly on the
    side, to a quarter of a pixel: the ground truth is where the picture says."""
    pic = pictures[name]
    img = pic.image.astype(np.float32)
    px = _to_px(pic.h_corners_m, pic.size_m, PX)
    steps = np.arange(-3.0, 3.01, 0.125)
    for i in range(12):
        a, b = px[i], px[(i + 1) % 12]
        mid = (a + b) / 2
        # Walking the corners clockwise on screen, the H lies to the right of each side.
        out_dir = np.array([b[1] - a[1], a[0] - b[0]]) / np.linalg.norm(b - a)
        pts = mid[None, :] + steps[:, None] * out_dir[None, :]
        maps = pts.astype(np.float32).reshape(1, -1, 2)
        prof = cv2.remap(img, maps, None, cv2.INTER_LINEAR).reshape(-1, 3).astype(np.float64)
        inner, outer = prof[:4].mean(axis=0), prof[-4:].mean(axis=0)
        span = outer - inner
        assert np.linalg.norm(span) > 40, (name, i, inner, outer)
        t = (prof - inner) @ span / (span @ span)  # 0 on the H, 1 off it
        k = int(np.argmax(t >= 0.5))
        crossing = steps[k - 1] + (0.5 - t[k - 1]) / (t[k] - t[k - 1]) * (steps[k] - steps[k - 1])
        assert abs(crossing) < 0.25, (name, i, crossing)


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_h_area_matches_the_geometry(name: str) -> None:
    """The H's coverage sums to the polygon's area (exact for the block H's)."""
    d = DESIGNS[name]
    cover = d.h.coverage(PX)
    poly = _to_px(d.h_corners_m, d.size_m, PX) + 0.5
    area = cv2.contourArea(poly.astype(np.float32))
    extra = 0.0
    if d.h.serif:  # the serif caps reach past the block H's outline
        extra = 4 * 2 * d.h.serif * d.h.serif_height * PX**2
    assert cover.sum() == pytest.approx(area + extra, rel=1e-6)


def test_symmetry_flags() -> None:
    for name, d in DESIGNS.items():
        pic = d.draw(200)
        turned = np.rot90(pic.image, 2).astype(np.float64)
        diff = np.abs(turned - pic.image).mean()
        if d.grain or d.painted:
            continue  # texture is not symmetric; the marks decide (checked below)
        assert (diff < 1.0) == d.symmetric, (name, diff)
    # Asymmetric marks: the triangle, the stars.
    assert not DESIGNS["paper_ring"].symmetric and not DESIGNS["serif_octagon"].symmetric
    assert DESIGNS["icao"].symmetric and DESIGNS["orange_ring"].symmetric


def test_shapes_cover_their_areas() -> None:
    n = 512
    ring = polygon_outline(6, 0.4, 0.05, 0.0).coverage(n).sum() / n**2
    apothem = 0.4 * np.cos(np.pi / 6)
    inner_apothem = apothem - 0.05
    want = 6 * np.tan(np.pi / 6) * (apothem**2 - inner_apothem**2)
    assert ring == pytest.approx(want, rel=0.01)
    s = star((0.0, 0.0), 0.3).coverage(n).sum() / n**2
    assert 0.05 < s < 0.3**2 * np.pi / 2
    with pytest.raises(ValueError, match="H proportions"):
        HShape(0.3, 0.4, 0.2, 0.05)


def test_round_and_painted_pads_let_the_floor_through() -> None:
    d = DESIGNS["orange_ring"]
    scene = d.scene(np.random.default_rng(0), floor="plain")
    img = render(scene, CAM, np.array([0.0, 0.0, 3.0]), camera_rotation(0.0))
    corner = project_points(CAM, np.array([0.0, 0.0, 3.0]), camera_rotation(0.0), [(0.53, 0.53)])
    x, y = np.round(corner[0]).astype(int)
    # Just inside the square's corner but outside the disc: the plain grey floor.
    assert abs(int(img[y - 3, x - 3, 2]) - int(img[y - 3, x - 3, 0])) < 20
    cx, cy = 319, 239 - int(0.2 * 1.1 / 3.0 * CAM.fx)  # on the disc, above the H
    assert img[cy, cx, 2] > img[cy, cx, 0] + 80  # orange
    painted = DESIGNS["grass_paint"].scene(np.random.default_rng(0))
    assert painted.floor_kind == "grass"


@pytest.mark.parametrize("kind", ["sand", "carpet", "wood"])
def test_new_floors_listed(kind: str) -> None:
    assert kind in FLOOR_KINDS
    scene = make_scene(make_pad_image(128), 0.55, rng=3, floor=kind)
    assert scene.floor_kind == kind


def test_floor_any_and_textured() -> None:
    kinds = {make_scene(make_pad_image(64), 0.55, rng=s, floor="any").floor_kind for s in range(6)}
    assert "plain" not in kinds and len(kinds) >= 3
    with pytest.raises(ValueError, match="floor"):
        make_scene(make_pad_image(64), 0.55, rng=0, floor="lava")


# ---------------------------------------------------------------- degradations


def _scene():
    return make_scene(make_pad_image(512), 0.55, rng=np.random.default_rng(5), floor="concrete")


@pytest.fixture(scope="module")
def clean_frame():
    return render(_scene(), CAM, np.array([0.05, 0.02, 1.8]), camera_rotation(20.0))


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return 10 * np.log10(255.0**2 / max(mse, 1e-12))


def test_jpeg_quality_lowers_psnr(clean_frame) -> None:
    psnr = [_psnr(degrade(clean_frame, jpeg_quality=q), clean_frame) for q in (95, 70, 30)]
    assert psnr[0] > psnr[1] > psnr[2] and psnr[2] < 40
    with pytest.raises(ValueError, match="jpeg_quality"):
        degrade(clean_frame, jpeg_quality=0)


def test_motion_blur_is_directional() -> None:
    """A smear along an edge leaves it sharp; across it, the ramp is the smear's length."""
    edge = np.full((40, 60, 3), 40, np.uint8)
    edge[:, 30:] = 220  # a vertical edge
    along = degrade(edge, motion_blur=MotionBlur(5.0, 90.0))
    assert np.abs(along.astype(int) - edge).max() <= 1
    for angle in (0.0, 180.0):
        across = degrade(edge, motion_blur=MotionBlur(5.0, angle))[20, :, 0].astype(int)
        ramp = np.count_nonzero((across > 45) & (across < 215))
        assert 4 <= ramp <= 6, (angle, across[24:36])
    slanted = degrade(edge, motion_blur=MotionBlur(5.0, 45.0))[20, :, 0].astype(int)
    ramp45 = np.count_nonzero((slanted > 45) & (slanted < 215))
    assert 2 <= ramp45 <= 5  # 5 px at 45 degrees spans ~3.5 px across the edge
    k = MotionBlur(4.0, 30.0).kernel()
    assert k.sum() == pytest.approx(1.0) and k.shape[0] == k.shape[1]


def test_shadow_darkens_inside_its_polygon_only() -> None:
    scene = _scene()
    pos, R = np.array([0.0, 0.0, 2.0]), camera_rotation(0.0)
    clean = render(scene, CAM, pos, R).astype(np.float64)
    # The shadow covers the plane's x > 0.3 half (to the image's right).
    shadow = Shadow(((0.3, -50.0), (50.0, -50.0), (50.0, 50.0), (0.3, 50.0)), 0.5, 1.0)
    out = render(scene, CAM, pos, R, shadow=shadow).astype(np.float64)
    edge = project_points(CAM, pos, R, [(0.3, 0.0)])[0, 0]
    right, left = int(edge) + 10, int(edge) - 10
    assert out[:, right:].mean() == pytest.approx(0.5 * clean[:, right:].mean(), rel=0.03)
    assert np.abs(out[:, :left] - clean[:, :left]).max() <= 1
    with pytest.raises(ValueError, match="darkness"):
        Shadow(((0, 0), (1, 0), (0, 1)), 1.5)


def test_glare_saturates_its_core(clean_frame) -> None:
    out = degrade(clean_frame, glare=Glare((100.0, 120.0), 15.0, 400.0))
    assert (out[120, 100] == 255).all()
    far = out[400:, 500:].astype(int) - clean_frame[400:, 500:]
    assert np.abs(far).max() <= 1


def test_exposure_gain_gamma_and_clipping(clean_frame) -> None:
    bright = degrade(clean_frame, exposure=Exposure(gain=2.0))
    assert (bright == 255).mean() > (clean_frame == 255).mean() + 0.05
    flat = np.full((4, 4, 3), 64, np.uint8)
    assert int(degrade(flat, exposure=Exposure(gamma=0.5))[0, 0, 0]) == round(
        255 * (64 / 255) ** 0.5
    )
    with pytest.raises(ValueError, match="gamma"):
        Exposure(gamma=0.0)


def test_realistic_views_are_deterministic_per_seed() -> None:
    d = DESIGNS["orange_ring"]
    out = []
    for seed in (4, 4, 5):
        rng = np.random.default_rng(seed)
        scene = d.scene(rng, floor="any", lookalikes=1)
        view = random_view(rng, CAM, max_tilt_deg=35.0, pad_size_m=d.size_m,
                           altitude=(2.0, 6.0), realistic=True)  # fmt: skip
        out.append((render_view(scene, CAM, view, rng), json.dumps(view.to_dict())))
    assert np.array_equal(out[0][0], out[1][0]) and out[0][1] == out[1][1]
    assert not np.array_equal(out[0][0], out[2][0])


def test_realistic_draws_leave_todays_view_unchanged() -> None:
    """The new degradations are drawn after the old ones: poses and noise stay put."""
    a = random_view(np.random.default_rng(9), CAM)
    b = random_view(np.random.default_rng(9), CAM, realistic=True)
    np.testing.assert_array_equal(a.position_m, b.position_m)
    assert a.snr_db == b.snr_db and a.light == b.light
    assert a.motion_blur is None and a.jpeg_quality is None


def test_realistic_views_cover_every_degradation() -> None:
    rng = np.random.default_rng(1)
    seen = {"motion_blur": 0, "shadow": 0, "glare": 0, "exposure": 0, "jpeg_quality": 0}
    tilts = []
    for _ in range(60):
        v = random_view(rng, CAM, max_tilt_deg=35.0, realistic=True)
        tilts.append(v.tilt_deg)
        for k in seen:
            seen[k] += getattr(v, k) is not None
        if v.motion_blur is not None:
            assert 0.5 <= v.motion_blur.length_px <= 5.0
        if v.jpeg_quality is not None:
            assert 30 <= v.jpeg_quality <= 95
    assert all(n > 5 for n in seen.values()), seen
    assert max(tilts) > 25


def test_cli_renders_a_design(tmp_path, capsys) -> None:
    from pipeline.render.__main__ import main as cli_main

    out = tmp_path / "icao.png"
    argv = [
        "--out",
        str(out),
        "--design",
        "icao",
        "--realistic",
        "--width",
        "160",
        "--height",
        "120",
    ]
    assert cli_main(argv) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["design"] == "icao" and info["view"]["position_m"][2] > 4.5 / 0.55 * 0.99
    assert cv2.imread(str(out)).shape == (120, 160, 3)
