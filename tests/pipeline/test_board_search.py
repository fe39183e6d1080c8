"""A pad too far for its H to be placed, found by its board (`pipeline.board_search`).

At 20 m the 0.55 m pad spans 15 px of a 640 x 480 frame at 60 degrees, its H 8 px
with legs of 1.5: on the bench's far views (`pipeline.bench --sweep altitude`) the
H's corners could not be placed on 12 of 40 frames (9 since its board is read as
the camera blurred the enlarged view), while the board around it still showed as a
quadrilateral.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

import pipeline.board_search
from pipeline import Camera, Reference, process_frame
from pipeline.bench.frames import SCENE_EVERY, make_scenes, make_view
from pipeline.bench.hint import gravity_hint
from pipeline.bench.tally import Tally
from pipeline.board_search import (
    _board_outlines,
    _board_whole,
    _clockwise,
    _fit_board,
    _floor_and_noise,
    _outline_mark,
    _quad_starts,
    _ring_contrast,
    find_boards,
)
from pipeline.candidates import MIN_H_AREA_PX
from pipeline.homography_fit import apply_h
from pipeline.preprocess import binarize_channel, border_pixels, to_channel
from pipeline.render import camera_rotation, get_design, make_pad_image, make_scene, render
from pipeline.render.view import render_view
from pipeline.shapes import regions
from pipeline.view import View
from tests.pipeline.bench_support import bench_frames, sweep_frames

CAM = Camera.from_fov(640, 480, 60.0)
DESIGN = get_design("default")


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(DESIGN.draw().image, DESIGN.size_m)


def _far_view(j: int, altitude: float = 20.0):
    """Frame ``j`` of a far point of the altitude sweep's kind: the pad's frame, its
    empty twin, the view and the attitude hint."""
    scenes = make_scenes(DESIGN, [0, 2000 + j // SCENE_EVERY], "today", ())
    view, noise_seed = make_view([0, 503, j, 11], CAM, DESIGN, "today", altitude=(altitude,) * 2)
    pad = render_view(scenes.pad, CAM, view, np.random.default_rng(noise_seed))
    empty = render_view(scenes.empty, CAM, view, np.random.default_rng(noise_seed))
    return pad, empty, view, gravity_hint(view.R_pad_cam, [0, 3, j, 12])


def _boards(frame: np.ndarray, reference: Reference) -> tuple[View, list[np.ndarray]]:
    """The boards found on the frame enlarged twice, as `process_frame`'s last search
    (around its marks and in its mask's holes)."""
    view = View.enlarged(frame.shape, 1280)
    binary = binarize_channel(to_channel(view.image(frame), reference.projection), "adaptive")
    holes: list = []
    area = binary.mask.size / 2
    shapes = regions(binary.mask, min_area=MIN_H_AREA_PX, max_area=area, holes=holes)
    return view, find_boards(binary.smooth, shapes, reference, view.scale, holes)


@pytest.mark.parametrize("j", [11, 19, 23])
def test_a_pad_whose_h_is_too_small_to_place_is_found_by_its_board(reference, j):
    frame, _, view, hint = _far_view(j)
    res = process_frame(frame, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    tally = Tally()
    tally.score(True, res.pose, view, DESIGN.symmetric)
    assert tally.pos_pct[0] < 3.0 and tally.rot_deg[0] < 2.0, (tally.pos_pct, tally.rot_deg)
    # The board alone places the pad's centre where the camera sees it.
    enlarged, found = _boards(frame, reference)
    centre = view.R_pad_cam.T @ -view.position_m
    seen = (CAM.K @ centre)[:2] / centre[2]
    placed = apply_h(np.linalg.inv(enlarged.matrix) @ found[0], np.zeros((1, 2)))[0]
    assert np.hypot(*(placed - seen)) < 0.5, (placed, seen)


@pytest.mark.parametrize("j", [20, 26, 29])
def test_a_board_is_grown_from_its_core_where_the_floor_comes_near_its_rim(j):
    # 18 m: the level right next to the H, blurred toward the floor's, joined the
    # board to the floor's blotches, or set a contrast the floor's noise drowned.
    frame, _, view, hint, reference = sweep_frames("default", CAM, 13, 18.0, j)
    res = process_frame(frame, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    tally = Tally()
    tally.score(True, res.pose, view, DESIGN.symmetric)
    assert tally.pos_pct[0] < 5.0, tally.pos_pct


@pytest.mark.parametrize("j", [10, 12, 13, 18])
def test_a_dark_h_painted_on_a_light_floor_is_no_dark_h_on_its_board(j):
    # The dark-on-light pad's H painted straight on the floor, 16 m away: its pattern
    # is the pad's (NCC 0.9), but no board's outline is where the fit puts it.
    _, empty, _, hint, reference = sweep_frames("dark_on_light", CAM, 13, 16.364, j)
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected


@pytest.mark.slow
def test_a_pad_32_m_away_on_a_1280x720_frame_is_found_on_the_frame_doubled():
    # At its own resolution the pad's H (10 px, legs of 2) fell apart under the
    # threshold on a light floor: none of these 10 frames was found.
    wide = Camera.from_fov(1280, 720, 60.0)
    found = 0
    for j in range(30, 40):
        frame, _, _, hint, reference = sweep_frames("default", wide, 17, 32.0, j)
        found += process_frame(frame, reference, wide, gravity_hint=hint).detected
    assert found >= 8, found


@pytest.mark.parametrize("j", range(0, 40, 4))
def test_no_board_is_found_on_the_same_floor_without_the_pad(reference, j):
    _, empty, _, hint = _far_view(j)
    assert _boards(empty, reference)[1] == []
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected


def _square_on_a_floor(
    side_px: float, board: float, floor: float = 170.0, disc: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """A board (a square turned 25 degrees, or a disc) of level ``board`` on a noisy
    floor, drawn 8 times finer and averaged; and the square's corners (pixels)."""
    k = 8
    big = np.full((200 * k, 240 * k), floor, np.float32)
    a = np.radians(25.0)
    corners = np.array(
        [[np.cos(a + t), np.sin(a + t)] for t in np.radians([45, 135, 225, 315])]
    ) * side_px / np.sqrt(2) + [120.0, 100.0]
    pts = np.round(((corners + 0.5) * k - 0.5) * 16).astype(np.int32)
    if disc:
        cv2.circle(big, (120 * k, 100 * k), int(side_px * k / 2), board, -1)
    else:
        cv2.fillPoly(big, [pts], board, shift=4)
    levels = cv2.resize(big, (240, 200), interpolation=cv2.INTER_AREA)
    noise = np.random.default_rng(0).normal(0.0, 3.0, levels.shape)
    return np.clip(levels + noise, 0, 255).astype(np.uint8), corners


def _holes(levels: np.ndarray, floor: float, board: float) -> list:
    holes: list = []
    mask = ((levels > (floor + board) / 2) * 255).astype(np.uint8)
    regions(mask, min_area=MIN_H_AREA_PX, max_area=mask.size / 2, holes=holes)
    return holes


def test_a_board_the_threshold_left_whole_is_read_from_its_hole():
    # A board darker than its floor: the floor around it is the mask's, the board a hole.
    levels, corners = _square_on_a_floor(50.0, 60.0)
    (hole,) = [h for h in _holes(levels, 170.0, 60.0) if h.area > 500]
    board = _board_whole(levels, hole, 24.0, 200.0)
    assert board is not None and 100.0 <= board.contrast <= 120.0, board
    # Its corners, clockwise on screen, within a pixel and a half of the square's.
    offset = np.abs(board.quad[:, None, :] - corners[None, :, :]).max(axis=2).min(axis=1)
    assert offset.max() < 1.5, (board.quad, corners)
    assert np.array_equal(board.quad, _clockwise(board.quad))


@pytest.mark.parametrize(
    "what, side, board, disc, least",
    [
        ("a disc", 50.0, 60.0, True, 24.0),
        ("a board barely off its floor", 50.0, 164.0, False, 24.0),
        ("a board narrower than a board is looked for", 16.0, 60.0, False, 24.0),
    ],
)
def test_a_hole_that_is_no_board_is_none(what, side, board, disc, least):
    levels, _ = _square_on_a_floor(side, board, disc=disc)
    holes = [h for h in _holes(levels, 170.0, board) if h.area > 100]
    assert holes  # (there is a hole to read)
    assert all(_board_whole(levels, h, least, 200.0) is None for h in holes), what


def _paper_posed_by_its_board(point: int, altitude: float, j: int, per_point: int = 40) -> Tally:
    """paper_ring's frame ``j`` of the altitude sweep's ``point`` (``per_point`` frames a
    point): the pad found by its board (its empty twin not taken), and its pose's errors."""
    frame, empty, view, hint, reference = sweep_frames(
        "paper_ring", CAM, point, altitude, j, per_point
    )
    res = process_frame(frame, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected
    tally = Tally()
    tally.score(True, res.pose, view, get_design("paper_ring").symmetric)
    return tally


@pytest.mark.parametrize("j", [11, 13, 16])
def test_a_sheet_whose_h_the_threshold_loses_is_found_by_the_hole_it_leaves(j):
    # 7.6 m away (the sweep's 22 px point): an H of 5 px with strokes under a pixel is
    # no mark of the mask, nor grows a board; the sheet is the mask's hole.
    tally = _paper_posed_by_its_board(11, 7.636, j)
    assert tally.pos_pct[0] < 3.0 and tally.rot_deg[0] < 2.0, (tally.pos_pct, tally.rot_deg)


@pytest.mark.parametrize("j", [3, 7])
def test_a_sheet_on_a_textured_floor_is_grown_around_its_h_the_most_alone_mark(j, monkeypatch):
    # 6.5 m away on a noisy floor (the sweep's views, 20 a point): the H's mark, 12 px on
    # the doubled view, ranked 100-160th by area among the floor's marks, past the
    # MAX_SEEDS grown around; on its plain sheet, the first or second most alone.
    tally = _paper_posed_by_its_board(10, 6.545, j, per_point=20)
    assert tally.pos_pct[0] < 3.0 and tally.rot_deg[0] < 2.0, (tally.pos_pct, tally.rot_deg)
    monkeypatch.setattr(pipeline.board_search, "MAX_LONE_SEEDS", 0)
    frame, _, _, hint, reference = sweep_frames("paper_ring", CAM, 10, 6.545, j, 20)
    assert not process_frame(frame, reference, CAM, gravity_hint=hint).detected


@pytest.mark.parametrize("j", [26, 33])
def test_an_h_of_strokes_under_two_pixels_counts_by_a_looser_pattern(j):
    # 4.4 m away: strokes of 1.5 px blurred into the sheet, the H's pattern at 0.6-0.7,
    # under the bar of a larger H's.
    tally = _paper_posed_by_its_board(7, 4.364, j)
    assert tally.pos_pct[0] < 3.0, tally.pos_pct


def test_an_h_of_wider_strokes_matching_as_little_is_no_pad():
    # paper_ring 2.6 m away, overexposed (the real-world mix's view 4): its H's strokes
    # of 2.1 px matched at 0.6-0.7, and so taken the pad was posed 7 % off.
    pad, _, hint, _, reference = bench_frames("paper_ring", 0, 4, "real")
    assert not process_frame(pad, reference, CAM, gravity_hint=hint).detected


def test_a_dark_square_holding_a_bright_blob_that_is_no_h_is_not_a_pad(reference):
    # What the board search grows from: a small bright mark on a dark square. The
    # square is found; what it holds is not the pad's pattern.
    frame = np.full((480, 640, 3), 120, np.uint8)
    rng = np.random.default_rng(3)
    for x, y in ((100, 100), (300, 240), (500, 380)):
        frame[y - 8 : y + 8, x - 8 : x + 8] = 30
        frame[y - 3 : y + 3, x - 3 : x + 3] = 230  # a square blob
    frame[180:196, 400:416] = 30
    frame[182:194, 407:409] = 230  # a bar
    noisy = np.clip(frame + rng.normal(0, 6, frame.shape), 0, 255).astype(np.uint8)
    assert _boards(noisy, reference)[1] == []


def test_only_a_pad_whose_picture_is_its_board_is_looked_for_by_it():
    assert Reference.from_image(make_pad_image(800), 0.55).board_is_outline
    for name in ("orange_ring", "grass_paint"):  # a disc on its floor, paint on grass
        design = get_design(name)
        assert not Reference.from_image(design.draw().image, design.size_m).board_is_outline


@pytest.mark.parametrize("i", [52, 73, 98])
def test_a_board_whose_h_is_too_thin_for_its_edges_is_found_by_the_hs_pattern(i):
    # paper_ring at 2.8-3.2 m (design bench views): a 14 px H with strokes of 1.5 px
    # under a blur of 1, a third of its sides' edges found; its pattern matched at
    # NCC 0.75-0.82.
    d = get_design("paper_ring")
    reference = Reference.from_image(d.draw().image, d.size_m)
    scenes = make_scenes(d, [0, i // SCENE_EVERY], "today", ())
    view, noise_seed = make_view([0, i, 7], CAM, d, "today")
    frame = render_view(scenes.pad, CAM, view, np.random.default_rng(noise_seed))
    hint = gravity_hint(view.R_pad_cam, [0, i, 11])
    res = process_frame(frame, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    tally = Tally()
    tally.score(True, res.pose, view, d.symmetric)
    assert tally.pos_pct[0] < 3.0 and tally.rot_deg[0] < 3.0, (tally.pos_pct, tally.rot_deg)


@pytest.mark.parametrize("design", ["default", "icao_circle", "thin"])
def test_a_pad_whose_h_a_glare_joined_to_its_board_is_found_by_its_board(design):
    # The real-world mix's view 26: a glare on the H and a 4 px smear; the thresholded
    # H and glare make no H's outline, the board around them still four edges.
    pad, empty, hint, view, reference = bench_frames(design, 0, 26, "real")
    res = process_frame(pad, reference, CAM, gravity_hint=hint)
    assert res.detected and res.found_by == "board", res.reason
    tally = Tally()
    tally.score(True, res.pose, view, get_design(design).symmetric)
    assert tally.pos_pct[0] < 3.0 and tally.rot_deg[0] < 2.0, (tally.pos_pct, tally.rot_deg)
    assert not process_frame(empty, reference, CAM, gravity_hint=hint).detected


class _Verdict:
    def __init__(self, answer: bool) -> None:
        self.answer, self.seen = answer, 0

    def accepts(self, corners_px, contour_px, camera) -> bool:
        self.seen += corners_px.shape == (12, 2)
        return self.answer


def test_the_verifier_judges_a_pad_found_by_its_board_too():
    pad, _, hint, _, reference = bench_frames("default", 0, 26, "real")
    yes, no = _Verdict(True), _Verdict(False)
    assert process_frame(pad, reference, CAM, gravity_hint=hint, verifier=yes).found_by == "board"
    assert yes.seen
    refused = process_frame(pad, reference, CAM, gravity_hint=hint, verifier=no)
    assert not refused.detected and "verifier rejected" in refused.reason


@pytest.mark.parametrize("seed", range(4))
def test_the_boards_levels_are_numpys_median_and_percentile(seed):
    # The floor's level and noise and a ring's contrast, counted over the uint8 levels,
    # against numpy's order statistics on windows of every kind: narrow level ranges
    # (ties everywhere), even and odd counts, a ring of one pixel.
    rng = np.random.default_rng(seed)
    for _ in range(300):
        h, w = (int(v) for v in rng.integers(10, 80, 2))
        lo, hi = sorted(int(v) for v in rng.integers(0, 256, 2))
        win = rng.integers(lo, hi + 1, (h, w)).astype(np.uint8)
        ring = (rng.random((h, w)) < rng.random()).astype(np.uint8)
        if rng.random() < 0.1:
            ring[:] = 0
            ring[rng.integers(h), rng.integers(w)] = 1
        ring[0, 0] |= not ring.any()
        border = border_pixels(win, 2)
        floor = float(np.median(border))
        assert _floor_and_noise(win, 2) == (
            floor,
            1.4826 * float(np.median(np.abs(border - floor))),
        )
        around = win[ring > 0]
        darker = float(np.median(around)) < floor
        for percent in (10.0, 5.0):
            q = percent if darker else 100 - percent
            assert _ring_contrast(win, ring, percent, floor) == abs(
                float(np.percentile(around, q)) - floor
            )


def test_a_faint_rim_is_not_the_outline_a_far_board_must_show():
    # A faint rim's edge is lost on the enlarged far view (a black H on a yellow disc on
    # a white sheet: at 6.5-8 m, 0 of its sides found where the H's were 0.9): the board
    # is then judged as the pad without marks was, by its H and pattern.
    d = get_design("orange_ring")
    ref = Reference.from_image(d.draw().image, d.size_m)
    (rim,) = [k for k, m in enumerate(ref.marks) if m.rim]
    assert _outline_mark(ref) == rim
    faint = dataclasses.replace(ref.marks[rim], faint=True)
    marks = tuple(faint if k == rim else m for k, m in enumerate(ref.marks))
    widest = max(
        (k for k in range(len(marks)) if k != rim),
        key=lambda k: float(np.ptp(marks[k].corners_m, axis=0).max()),
    )
    assert _outline_mark(dataclasses.replace(ref, marks=marks)) == widest


def _inset_border_pad() -> np.ndarray:
    """A white H on a dark board with a yellow border band inset in a margin of the
    board's own colour (800 px for 1 m)."""
    pad = np.full((800, 800, 3), 40, np.uint8)
    pad[30:770, 30:770] = (0, 200, 255)
    pad[54:746, 54:746] = 40
    pad[170:590, 235:315] = pad[170:590, 485:565] = pad[340:420, 235:565] = 250
    return pad


def test_a_board_grown_to_an_inset_border_is_fitted_as_that_border():
    # A board grown from the H stops at the band's inner edge where the band stands
    # apart from the margin beyond (a glare on the band did so in 1 of 30 views of the
    # real-world mix): taken for the pad's outer edge, it posed the pad 13 % too far.
    reference = Reference.from_image(_inset_border_pad(), 1.0)
    outlines = _board_outlines(reference)
    inner = min(outlines, key=lambda o: float(np.ptp(o[:, 0])))
    assert len(outlines) >= 2 and np.ptp(inner, axis=0) == pytest.approx([0.865, 0.865], abs=0.01)
    scene = make_scene(_inset_border_pad(), 1.0, rng=np.random.default_rng(4), floor="plain")
    R = camera_rotation(20.0)
    position = np.array([0.3, -0.2, 14.0])
    frame = render(scene, CAM, position, R, rng=np.random.default_rng(5))
    view = View.enlarged(frame.shape, 1280)
    levels = binarize_channel(
        to_channel(view.image(frame), reference.projection), "adaptive"
    ).smooth
    # (pad metres -> view pixels, as the camera sees the pad)
    K = view.camera(CAM).K
    truth = K @ np.column_stack([R.T[:, 0], R.T[:, 1], -R.T @ position])
    for outline in (outlines[0], inner):
        quad = apply_h(truth, outline)
        starts = _quad_starts(_clockwise(quad), outlines)
        fitted = _fit_board(levels, reference, starts, _outline_mark(reference))
        assert fitted is not None
        span = np.ptp(apply_h(fitted[1], reference.corners_m), axis=0)
        want = np.ptp(apply_h(truth, reference.corners_m), axis=0)
        assert span == pytest.approx(want, rel=0.03), (outline.tolist(), span, want)
