"""The encoding: invariant to where, how big and how turned a candidate is; not to its shape."""

import math

import cv2
import numpy as np
import pytest

from pipeline import Camera, Reference
from pipeline.candidates import match_corners
from pipeline.learn.data import frame_candidates, stretched_texture
from pipeline.learn.encoding import Encoder, kabsch_rotation, normalise, polygon_area
from pipeline.render import camera_rotation, make_pad_image, make_scene, render
from pipeline.shapes import css_polygon


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(600), 0.55)


@pytest.fixture(scope="module")
def wide(reference):
    """The reference's pad 1.4 times as wide (the gate cannot tell it from the pad)."""
    return stretched_texture(reference.image, 1.4, 0.0)


@pytest.fixture(scope="module")
def fat():
    """A pad whose H has legs a quarter wider."""
    return make_pad_image(600, leg_width=0.15)


@pytest.fixture(scope="module")
def encoder(reference):
    return Encoder.for_corners(reference.corners_m, symmetric=reference.symmetric)


CAM = Camera.from_fov(640, 480, 60.0)
SIMILARITY_BLOCKS = ("corners", "shape", "anisotropy", "residual", "offsets")


_SCENES: dict = {}


def _h_candidate(reference, texture, yaw=25.0, tilt=0.0, size_m=0.55, height=2.0, gate=0.4):
    """The H candidate (ordered corners, contour) of a real rendered frame.

    The camera leans ``tilt`` degrees toward pad direction 40 deg and stands back
    so that the pad stays near the middle of the picture.
    """
    key = (id(texture), size_m)
    if key not in _SCENES:  # a scene takes ~0.3 s to build; the pictures live all module long
        _SCENES[key] = make_scene(texture, size_m, rng=np.random.default_rng(1), floor="plain")
    scene = _SCENES[key]
    R = camera_rotation(yaw, tilt_deg=tilt, tilt_dir_deg=40.0)
    back = height * math.tan(math.radians(tilt))
    a = math.radians(40.0)
    position = np.array([0.05 - back * math.cos(a), 0.02 - back * math.sin(a), height])
    frame = render(scene, CAM, position, R)
    # Otsu keeps a stretched H's strokes whole, so it reaches the corner check
    # (the adaptive threshold thins it enough for the Hu gate to drop it first).
    cands = frame_candidates(frame, reference, max_residual=gate, method="otsu")
    assert len(cands) == 1
    return cands[0].corners, cands[0].contour


def _similarity(points, angle_deg, scale, shift):
    a = math.radians(angle_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return (points @ R.T) * scale + shift


def test_code_is_binary_and_sized(reference, encoder):
    corners, contour = _h_candidate(reference, reference.image)
    code = encoder.encode(corners, contour)
    assert code.shape == (encoder.size,)
    blocks = encoder.blocks
    names = ["corners", "shape", "anisotropy", "residual", "metric", "offsets", "size"]
    assert list(blocks) == names
    assert blocks["corners"] == slice(0, 24 * 24) and blocks["size"].stop == encoder.size
    assert blocks["offsets"].stop - blocks["offsets"].start == 6 * 2 * 12  # folded pairs
    assert set(np.unique(code)) == {0.0, 1.0}
    # Twelve corners light a good number of cells, but far from all of them.
    assert 40 < code[: 24 * 24].sum() < 300


@pytest.mark.parametrize(
    ("angle", "scale", "shift"),
    [
        (0.0, 1.0, (37.0, -12.5)),
        (0.0, 2.7, (0.0, 0.0)),
        (180.0, 1.0, (5.0, 5.0)),
        (63.0, 0.4, (9, 1)),
    ],
)
def test_similarity_invariance(reference, encoder, angle, scale, shift):
    # The shape readings do not care where in the image, how big or how turned.
    corners, contour = _h_candidate(reference, reference.image)
    base = encoder.encode(corners, contour)
    moved = encoder.encode(
        _similarity(corners, angle, scale, shift), _similarity(contour, angle, scale, shift)
    )
    for name in SIMILARITY_BLOCKS:
        block = encoder.blocks[name]
        assert np.array_equal(base[block], moved[block]), name


@pytest.mark.parametrize("angle", [180.0, 90.0, 33.0])
def test_camera_roll_invariance(reference, encoder, angle):
    # Turning the camera about its optical axis changes nothing at all: the rays'
    # homography only turns, the area stays.
    corners, contour = _h_candidate(reference, reference.image, tilt=15.0)
    centre = CAM.K[:2, 2]
    base = encoder.encode(corners, contour)

    def roll(p):
        return _similarity(p - centre, angle, 1.0, centre)

    assert np.array_equal(base, encoder.encode(roll(corners), roll(contour)))


def test_perspective_reading_sees_through_tilt(reference, encoder, wide):
    # A close, tilted view stretches the H's image, but the rays' homography of the
    # right H is a rotation; a stretched H's is not.
    corners, contour = _h_candidate(reference, reference.image, tilt=20.0, height=1.2)
    aligned, _ = encoder.align(corners, contour)
    assert encoder.distortion(aligned)[0] > 2 * encoder.metric_anisotropy(corners, CAM)
    assert encoder.metric_anisotropy(corners, CAM) < 0.05
    assert np.abs(encoder.offsets(corners)).max() < 0.05
    corners, _ = _h_candidate(reference, wide, tilt=20.0, height=1.5, size_m=0.55 * 1.4)
    assert encoder.metric_anisotropy(corners, CAM) == pytest.approx(math.log(1.4), abs=0.06)


def test_offsets_see_other_leg_proportions(reference, encoder, fat):
    # Legs a quarter wider: the pipeline's homography gate lets this one through. The
    # corners as read off its outline (the seed's corners: a homography fitted to the
    # H's edges puts the reference's corners on it, which no offset can tell apart).
    _, contour = _h_candidate(reference, fat, height=1.5)
    _, right = _h_candidate(reference, reference.image, height=1.5)
    wider, right = _read_corners(contour, reference), _read_corners(right, reference)
    assert np.abs(encoder.offsets(wider)).max() > 2 * np.abs(encoder.offsets(right)).max()


def _read_corners(contour: np.ndarray, reference) -> np.ndarray:
    outline = np.round(contour).astype(np.int32)
    poly = css_polygon(outline, len(reference.corners_m))
    assert poly is not None
    area = abs(cv2.contourArea(contour.astype(np.float32)))
    return match_corners(poly, reference.corners_m, area)[0]


def test_half_turn_start_gives_the_same_code(reference, encoder):
    # A symmetric H's corner list may start at either end: corner i <-> i + 6.
    corners, contour = _h_candidate(reference, reference.image)
    assert np.array_equal(
        encoder.encode(corners, contour), encoder.encode(np.roll(corners, 6, axis=0), contour)
    )


def test_two_views_of_the_h_agree_more_than_h_and_stretched_h(reference, encoder, wide):
    a = encoder.encode(*_h_candidate(reference, reference.image, yaw=10.0))
    b = encoder.encode(*_h_candidate(reference, reference.image, yaw=140.0, tilt=10.0))
    # Keep the metres per texel: the stretched pad is wider on the floor. The
    # pipeline's homography gate lets it through (_h_candidate gates at 0.1).
    c = encoder.encode(*_h_candidate(reference, wide, yaw=30.0, size_m=0.55 * 1.4))
    assert np.abs(a - b).sum() < 0.5 * np.abs(a - c).sum()


def test_asymmetric_reference_keeps_the_half_turn(reference):
    enc = Encoder.for_corners(reference.corners_m, symmetric=False)
    corners, contour = _h_candidate(reference, reference.image)
    code = enc.encode(corners, contour)
    assert code.shape == (enc.size,)


def test_helpers():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    assert polygon_area(square) == 4.0
    norm, centre, scale = normalise(square)
    assert np.allclose(centre, [1, 1]) and scale == 0.5 and polygon_area(norm) == pytest.approx(1)
    R = kabsch_rotation(norm, _similarity(norm, 30.0, 1.0, 0.0))
    assert math.degrees(math.atan2(R[1, 0], R[0, 0])) == pytest.approx(30.0)


@pytest.mark.parametrize(
    ("corners", "contour", "name"),
    [
        (np.zeros((11, 2)), np.zeros((20, 2)), "corners_px"),
        (np.zeros((12, 3)), np.zeros((20, 2)), "corners_px"),
        (np.full((12, 2), np.nan), np.zeros((20, 2)), "corners_px"),
        (np.zeros((12, 2)), np.zeros((20, 2)), "corners_px"),  # no area
        ("twelve", np.zeros((20, 2)), "corners_px"),
        (None, np.zeros((2, 2)), "corners_px"),
    ],
)
def test_bad_input_names_the_argument(encoder, corners, contour, name):
    with pytest.raises(ValueError, match=name):
        encoder.encode(corners, contour)


def test_bad_contour(reference, encoder):
    corners, _ = _h_candidate(reference, reference.image)
    with pytest.raises(ValueError, match="contour_px"):
        encoder.encode(corners, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="contour_px"):
        encoder.encode(corners, np.array([[0, 0], [1, np.inf], [2, 2]]))


def test_bad_grid(reference):
    with pytest.raises(ValueError, match="corner_grid"):
        Encoder.for_corners(reference.corners_m, corner_grid=2)
    with pytest.raises(ValueError, match="shape_grid"):
        Encoder.for_corners(reference.corners_m, shape_grid=12.5)
