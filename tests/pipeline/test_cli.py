import json
import subprocess
import sys

import cv2
import numpy as np

from pipeline import Camera
from pipeline.bench import run
from pipeline.preprocess import DEFAULT_METHOD
from pipeline.render import camera_rotation, make_pad_image, make_scene, render


def _py(*args, cwd=None):
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=120, cwd=cwd
    )


def test_analyze_prints_the_result_and_writes_the_annotated_frame(tmp_path):
    pad = make_pad_image(800)
    cam = Camera.from_fov(640, 480, 60.0)
    scene = make_scene(pad, 0.55, rng=np.random.default_rng(2))
    frame = render(scene, cam, np.array([0.1, 0.1, 2.0]), camera_rotation(20.0))
    cv2.imwrite(str(tmp_path / "pad.png"), pad)
    cv2.imwrite(str(tmp_path / "frame.png"), frame)
    out = tmp_path / "annotated.png"
    done = _py(
        "-m", "pipeline", "analyze", str(tmp_path / "frame.png"),
        "--reference", str(tmp_path / "pad.png"), "--pad-size", "0.55", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["detected"] is True
    assert abs(result["pose"]["position_m"][2] - 2.0) < 0.05
    annotated = cv2.imread(str(out))
    assert annotated.shape == frame.shape and not np.array_equal(annotated, frame)


def test_analyze_reports_a_bad_reference_in_one_line(tmp_path):
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.zeros((100, 100, 3), np.uint8))
    done = _py(
        "-m", "pipeline", "analyze", str(blank), "--reference", str(blank), "--pad-size", "1"
    )
    assert done.returncode == 2
    assert done.stderr.startswith("error: ") and "no shape stands out" in done.stderr
    missing = _py(
        "-m", "pipeline", "analyze", "nope.png", "--reference", str(blank), "--pad-size", "1"
    )
    assert missing.returncode == 2 and "cannot read nope.png" in missing.stderr


def test_demo_writes_a_picture(tmp_path):
    out = tmp_path / "demo.png"
    done = _py("-m", "pipeline", "demo", "--out", str(out), "--seed", "1")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["detected"] in (True, False)
    assert cv2.imread(str(out)) is not None


def test_bench_reports_every_key():
    out = run(2, 0, [DEFAULT_METHOD])
    for key in ("detection_rate", "false_positive_rate", "position_error_pct",
                "rotation_error_deg", "ms_per_frame", "stages_ms", "aruco",
                "speed_ratio_vs_aruco"):  # fmt: skip
        assert key in out
    for key in ("median", "p95"):
        assert key in out["position_error_pct"] and key in out["aruco"]["ms_per_frame"]
    assert 0.0 <= out["detection_rate"] <= 1.0
    json.dumps(out)
