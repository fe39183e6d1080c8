"""pipeline.bench: per-design figures, sweeps against ArUco and AprilTag 3, plots."""

from __future__ import annotations

import itertools
import json

import cv2
import numpy as np
import pytest

from pipeline.bench import run_designs
from pipeline.bench.__main__ import main
from pipeline.bench.frames import altitude_for, view_options
from pipeline.bench.markers import AprilTagDetector, ArucoDetector, marker_texture
from pipeline.bench.plot import line_panel, nice_ticks
from pipeline.bench.sweep import YAW_POINTS_DEG, altitude_points, range90, run_sweep
from pipeline.bench.tally import WRONG_POSE_PCT, Tally
from pipeline.camera import Camera
from pipeline.preprocess import DEFAULT_METHOD
from pipeline.render import DESIGNS, make_scene, random_view, render_view
from pipeline.result import Pose

TODAY_KEYS = ("detection_rate", "false_positive_rate", "position_error_pct",
              "rotation_error_deg", "ms_per_frame", "stages_ms", "aruco",
              "speed_ratio_vs_aruco", "method", "threshold_methods")  # fmt: skip


def test_design_bench_reports_every_key_per_design() -> None:
    out = run_designs(["default", "icao"], 2, 0, [DEFAULT_METHOD], degrade="real")
    json.dumps(out)
    assert set(out["designs"]) == {"default", "icao"} and out["degrade"] == "real"
    for name, r in out["designs"].items():
        for key in TODAY_KEYS:
            assert key in r, (name, key)
        assert r["design"] == name and 0.0 <= r["detection_rate"] <= 1.0
        assert r["altitude_m"] == pytest.approx(altitude_for(DESIGNS[name]))
    # The 4.5 m ICAO pad flies 4.5 / 0.55 times higher: the same pixel spans.
    assert out["designs"]["icao"]["altitude_m"] == pytest.approx([4.5 / 0.55, 27 / 0.55])
    np.testing.assert_allclose(
        out["designs"]["icao"]["pad_span_px"], out["designs"]["default"]["pad_span_px"]
    )
    s = out["summary"]
    for key in ("detection_rate_mean", "detection_rate_min", "false_positive_rate_max",
                "designs_meeting_accuracy_bars", "references_refused"):  # fmt: skip
        assert key in s


def test_degrade_levels() -> None:
    assert view_options("today") == {}
    assert view_options("clean")["snr_db"] is None
    assert view_options("real")["realistic"] and view_options("real")["max_tilt_deg"] == 35.0
    with pytest.raises(ValueError, match="degrade"):
        view_options("harsh")


@pytest.mark.parametrize("kind", ["aruco", "apriltag"])
def test_markers_give_the_true_pose(kind: str) -> None:
    """The comparison's markers are detected and their corners matched the right way."""
    cam = Camera.from_fov(640, 480, 60.0)
    tex, width = marker_texture(kind, 0.55)
    scene = make_scene(tex, width, rng=1, floor="concrete")
    det = (ArucoDetector if kind == "aruco" else AprilTagDetector)(0.55)
    rng = np.random.default_rng(0)
    for _ in range(4):
        v = random_view(
            rng, cam, altitude=(1.5, 3.0), snr_db=None, lighting=False, pad_size_m=width
        )
        pose = det.pose(render_view(scene, cam, v, rng), cam)
        assert pose is not None
        assert np.linalg.norm(pose.position_m - v.position_m) < 0.02 * v.altitude_m


def test_tally_counts_wrong_poses_of_the_frames() -> None:
    """A pose over WRONG_POSE_PCT of the altitude off is wrong, not imprecise, and silently
    so unless flagged ambiguous; a frame with no pose is missed, not wrong."""
    cam = Camera.from_fov(640, 480, 60.0)
    v = random_view(np.random.default_rng(3), cam, altitude=(4.0, 4.0), snr_db=None, lighting=False)
    tally = Tally()
    for off_pct, ambiguous in ((2.0, False), (WRONG_POSE_PCT - 0.5, False),
                               (WRONG_POSE_PCT + 0.5, True), (30.0, False)):  # fmt: skip
        shift = np.array([off_pct / 100 * v.altitude_m, 0.0, 0.0])
        tally.score(True, Pose(v.position_m + shift, v.R_pad_cam, 0.1, False, ambiguous), v, False)
    tally.score(False, None, v, False)
    s = tally.summary()
    assert s["wrong_pose_rate"] == pytest.approx(2 / 5)
    assert s["silent_wrong_pose_rate"] == pytest.approx(1 / 5)  # (not flagged ambiguous)
    assert s["detection_rate"] == pytest.approx(4 / 5)


def test_altitude_points_reach_twelve_pixels() -> None:
    cam = Camera.from_fov(640, 480, 60.0)
    pts = altitude_points(DESIGNS["default"], cam)
    assert pts[0] == 1.0 and pts[-1] == pytest.approx(cam.fx * 0.55 / 12, abs=1e-3)
    assert all(b > a for a, b in itertools.pairwise(pts))
    hd = altitude_points(DESIGNS["default"], Camera.from_fov(1280, 720, 60.0))
    assert hd[-1] == pytest.approx(2 * pts[-1], abs=2e-3)
    full_hd = altitude_points(DESIGNS["default"], Camera.from_fov(1920, 1080, 60.0))
    assert full_hd[-1] == pytest.approx(3 * pts[-1], abs=3e-3)
    assert range90([1, 2, 3], [0.5, 1.0, 1.0]) is None


def test_altitude_sweep_json_and_plot(tmp_path) -> None:
    out = run_sweep("altitude", resolutions=[(640, 480)], frames=1, seed=0, plot_dir=str(tmp_path))
    json.dumps(out)
    res = out["resolutions"]["640x480"]
    assert set(res["range90_m"]) == {"visland", "aruco", "apriltag"}
    assert res["altitude_where_pad_spans_22px_m"] == pytest.approx(554.256 * 0.55 / 22, rel=1e-4)
    first = res["points"][0]
    assert first["altitude_m"] == 1.0 and first["pad_span_px"] > 300
    for det in ("visland", "aruco", "apriltag"):
        assert set(first[det]) == {
            "detection_rate", "position_error_pct", "rotation_error_deg", "wrong_pose_rate",
            "silent_wrong_pose_rate", "false_positive_rate", "ms_per_frame",
        }  # fmt: skip
    # At 1 m every detector sees its marker or pad, right, and nothing on the empty floor.
    for det in ("visland", "aruco", "apriltag"):
        assert first[det]["detection_rate"] == 1.0
        assert first[det]["wrong_pose_rate"] == 0.0 and first[det]["false_positive_rate"] == 0.0
    assert len(out["plots"]) == 1 and cv2.imread(out["plots"][0]) is not None


def test_sweep_cli_snr(capsys) -> None:
    assert main(["--sweep", "snr", "--frames", "1", "--resolution", "640x480"]) == 0
    out = json.loads(capsys.readouterr().out)
    xs = [p["snr_db"] for p in out["resolutions"]["640x480"]["points"]]
    assert xs[0] == 5.0 and xs[-1] == 40.0


def test_sweep_cli_at_1920x1080(capsys) -> None:
    """A 1080p camera's frames are swept at their own size (by --resolution only)."""
    assert main(["--sweep", "tilt", "--frames", "1", "--resolution", "1920x1080"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out["resolutions"]) == ["1920x1080"]
    near = out["resolutions"]["1920x1080"]["points"][0]
    assert near["tilt_deg"] == 0.0 and near["visland"]["detection_rate"] == 1.0


def test_sweep_cli_yaw(capsys) -> None:
    """Hovering, the camera turned from the pad's axes: at 0 the H's sides lie along the
    pixel grid, as a vehicle facing the pad's heading sees them."""
    assert main(["--sweep", "yaw", "--frames", "1", "--resolution", "640x480"]) == 0
    out = json.loads(capsys.readouterr().out)
    points = out["resolutions"]["640x480"]["points"]
    assert [p["yaw_deg"] for p in points] == list(YAW_POINTS_DEG)
    assert points[0]["visland"]["detection_rate"] == 1.0


def test_cli_rejects_bad_input(capsys) -> None:
    for argv in (["--design", "nope", "--frames", "1"], ["--frames", "0"], ["--sweep", "depth"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
    assert "design must be one of" in capsys.readouterr().err


def test_plot_helpers() -> None:
    assert nice_ticks(0, 25) == [0, 5, 10, 15, 20, 25]
    img = line_panel({"a": ([1, 2, 3], [0.1, None, 10.0])}, title="t", xlabel="x", ylabel="y",
                     log_y=True)  # fmt: skip
    assert img.shape == (340, 760, 3) and (img < 128).any()


def test_report_writes_markdown_and_figures(tmp_path) -> None:
    from pipeline.bench.report import SNRS_DB, write_report

    out = write_report(str(tmp_path), frames=1, sweep=False, rbm=False)
    json.dumps(out)
    md = (tmp_path / "report.md").read_text()
    assert "| the seed | we measure | agree |" in md and "0.02" in md and "36" in md
    for name in ("fig5_3_invariants.png", "fig5_3_pose.png", "fig5_4_corner_pca.png"):
        assert name in out["figures"] and cv2.imread(str(tmp_path / name)) is not None
    adaptive = out["noise"]["methods"][DEFAULT_METHOD]
    assert [p["snr_db"] for p in adaptive["points"]] == list(SNRS_DB)
    # At 60 dB the H is found and its invariants are those of the clean view.
    top = adaptive["points"][-1]
    assert top["detection_rate"] == 1.0 and top["hu1"]["median"] < 1e-3
    assert {row["agree"] for row in out["comparison"]} <= {"yes", "no", "partly", "-"}


def test_attitude_hint_and_tracking_runs(capsys) -> None:
    from pipeline.bench.track import run_track

    out = run_designs(["default"], 3, 0, [DEFAULT_METHOD], hint=True)
    assert out["designs"]["default"]["attitude_hint_deg"] > 0
    track = run_track(frames=12, seed=0)
    for run in (track, track["facing_the_pad"]):
        for res in ("640x480", "1920x1080"):
            r = run[res]
            assert set(r["found_by"]) <= {"follow", "track", "search", "missed"}
            assert sum(r["found_by"].values()) == 12
            assert r["ms_cold"]["median"] > 0
        # Most of a descent is followed or tracked from frame to frame.
        ways = run["640x480"]["found_by"]
        assert ways.get("follow", 0) + ways.get("track", 0) >= 8
