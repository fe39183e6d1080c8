"""The whole pad's marks in the pose (``pipeline.measure``): fitted around an H whose
marks' strokes are about as thin as the frame's blur or whose own perspective is
mostly noise, and left out where not found."""

import numpy as np

from pipeline import Reference, process_frame
from tests.pipeline.bench_support import (
    BLACK_ON_YELLOW,
    CAM,
    bench_frames,
    design_frame,
    score_bench_frames,
)


def test_a_printed_ring_blurred_into_one_line_does_not_leave_the_pose_to_the_h_alone():
    # The bench's paper_ring at 1.3-1.6 m: its ring's stroke is 1.4 px, its two sides
    # blurred into one line, so most of the marks were not found with them; the whole
    # pad was refused and the pose fell to the H alone (25-32 px), 5.9-6.5 degrees and
    # 10-11 % of the altitude off. Fitted again without the ring, the sheet's edges and
    # the triangle pin it (now 0.05-0.3 degrees, 0.1-0.5 %).
    tally = score_bench_frames("paper_ring", (21, 25, 40, 43, 62))
    assert tally.detected == 5
    assert max(tally.rot_deg) < 1.0 and max(tally.pos_pct) < 2.0, (tally.rot_deg, tally.pos_pct)


def test_a_pad_whose_marks_were_not_found_is_posed_on_its_h_not_on_marks_placed_by_it():
    # Too few of the marks' edges found (far pads, blur, JPEG, a slant), the pose was
    # fitted to the 100-odd points the H's homography alone placed, whose count
    # outweighed the attitude. The bench's orange_ring in the real-world mix at 8-10 m
    # (its H 24-29 px, seen at 19-27 degrees): 4.9-6.2 degrees and 9-13 % of the
    # altitude off (now 1.0-1.5 degrees, 2.1-2.7 %); red_on_black at 9-12 m: 1.6-3.9
    # degrees, 2.8-6.8 % (now 0.6-1.2 degrees, 1.2-2.2 %).
    for design, frames, level in (
        ("orange_ring", (3, 12, 19), "real"),
        ("red_on_black", (48, 61, 76, 97, 98), "today"),
    ):
        tally = score_bench_frames(design, frames, level=level)
        assert tally.detected == len(frames), design
        assert max(tally.rot_deg) < 2.0 and max(tally.pos_pct) < 3.5, (
            design,
            tally.rot_deg,
            tally.pos_pct,
        )


def test_a_small_h_whose_perspective_misplaces_its_sheet_still_finds_the_sheet():
    # The bench's paper_ring at 2.5-3.2 m: an H of 14-17 px on a sheet four times its
    # size. The perspective of the H's own homography, mostly its noise, put the
    # sheet's corners up to 10 px off, beyond where its edges are looked for; the
    # marks were not found and the H, too small to count alone, was refused. From
    # the homography's affine part at the H's centre the sheet is found.
    tally = score_bench_frames("paper_ring", (16, 61, 96))
    assert tally.detected == 3
    assert max(tally.rot_deg) < 2.0 and max(tally.pos_pct) < 3.0, (tally.rot_deg, tally.pos_pct)


def test_a_hemmed_pads_rim_does_not_make_it_larger() -> None:
    # orange_ring's dark hem lies 1-3 px wide beyond its rim on the bench's clean views
    # at 4.4-12 m (with the attitude hint): the rim's edge, pushed out by the hem's, made
    # the pad larger and the altitude 0.55 % short (median; now within 0.1 %).
    errors = []
    for i in range(24):
        frame, _, g, view, reference = bench_frames("orange_ring", 0, i, "clean")
        if view.position_m[2] < 4.4:
            continue
        res = process_frame(frame, reference, CAM, gravity_hint=g)
        assert res.detected and res.pose is not None
        errors.append(100.0 * (res.pose.position_m[2] / view.position_m[2] - 1.0))
    assert len(errors) >= 12
    assert abs(float(np.median(errors))) < 0.2, np.round(errors, 2)


def test_a_faint_rim_pins_the_pose_as_a_rim_does() -> None:
    # A black H on a yellow disc on a white sheet: on its learned channel the disc's rim
    # steps a third as far as the H, and was no mark; posed on the H alone, its clean
    # views came 1.17 % of the altitude off (median of 30; now 0.29 %).
    d = BLACK_ON_YELLOW
    reference = Reference.from_image(d.draw().image, d.size_m)
    errors = []
    for i in range(20):
        frame, g, view = design_frame(d, i, "clean")
        res = process_frame(frame, reference, CAM, gravity_hint=g)
        assert res.detected and res.pose is not None
        # (the pad's half turns look alike: the nearer of the two)
        turned = np.diag([-1.0, -1.0, 1.0]) @ view.position_m
        off = min(np.linalg.norm(res.pose.position_m - p) for p in (view.position_m, turned))
        errors.append(100.0 * off / view.position_m[2])
    assert float(np.median(errors)) < 0.6, np.round(errors, 2)
