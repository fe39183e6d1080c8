"""pipeline.bench --picture: a user's own pad, known by its picture, in the bench's scenes."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.bench.__main__ import main
from pipeline.bench.picture_design import picture_design
from pipeline.camera import Camera
from pipeline.render import DESIGNS, camera_rotation, render
from tests.pipeline.bench_support import PHOTOS, needs_photos


def _picture(tmp_path: Path, name: str = "default", size_px: int = 400) -> Path:
    path = tmp_path / "my pad.png"
    cv2.imwrite(str(path), DESIGNS[name].draw(size_px).image)
    return path


def test_the_design_of_a_picture_is_read_from_the_picture(tmp_path) -> None:
    """Its H's corners, paint and symmetry, as the reference reads them: those the
    default pad was drawn with."""
    drawn = DESIGNS["default"]
    d = picture_design(_picture(tmp_path), drawn.size_m)
    assert d.name == "picture:my pad.png" and d.size_m == drawn.size_m
    np.testing.assert_allclose(d.h_corners_m, drawn.h_corners_m, atol=0.005 * drawn.size_m)
    assert d.h_size_m == pytest.approx(drawn.h_size_m, rel=0.02)
    np.testing.assert_allclose(d.h_bgr, drawn.h_bgr, atol=12)
    assert d.symmetric and d.draw().image.shape == (400, 400, 3)
    assert d.draw(100).image.shape == (100, 100, 3)
    # Laid on the floor as the picture it is: seen from straight above at 2 m, the
    # pad's middle is the picture's.
    cam = Camera.from_fov(640, 480, 60.0)
    scene = d.scene(np.random.default_rng(0), floor="concrete")
    frame = render(scene, cam, np.array([0.0, 0.0, 2.0]), camera_rotation(0.0))
    seen = cv2.cvtColor(frame[200:280, 280:360], cv2.COLOR_BGR2GRAY).astype(float)
    drawn_mid = cv2.cvtColor(d.image[160:240, 160:240], cv2.COLOR_BGR2GRAY).astype(float)
    assert abs(seen.mean() - drawn_mid.mean()) < 25


def test_a_picture_of_a_pad_is_benched_as_a_design(tmp_path, capsys) -> None:
    path = _picture(tmp_path)
    assert main(["--picture", str(path), "--size", "0.55", "--frames", "4", "--hint"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out["designs"]) == ["picture:my pad.png"]
    r = out["designs"]["picture:my pad.png"]
    assert r["design"] == "picture:my pad.png" and r["pad_size_m"] == 0.55
    assert r["altitude_m"] == [1.0, 6.0] and r["attitude_hint_deg"] is not None
    assert r["detection_rate"] == 1.0 and r["false_positive_rate"] == 0.0
    assert r["position_error_pct"]["median"] < 2.0
    assert out["summary"]["designs"] == 1


def test_a_picture_of_a_pad_is_swept(tmp_path, capsys) -> None:
    path = _picture(tmp_path, "dark_on_light")
    argv = ["--sweep", "tilt", "--frames", "1", "--resolution", "640x480"]
    assert main([*argv, "--picture", str(path), "--size", "0.5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["design"] == "picture:my pad.png" and out["pad_size_m"] == 0.5
    near = out["resolutions"]["640x480"]["points"][0]
    assert near["tilt_deg"] == 0.0 and near["visland"]["detection_rate"] == 1.0


def test_a_picture_of_a_pad_is_posed_on_frames_drawn_another_way(tmp_path, capsys) -> None:
    """--vector warps the picture through the camera by OpenCV; a picture need not be
    square (its height follows its aspect, as on the bench's floors)."""
    path = tmp_path / "wide pad.png"
    cv2.imwrite(str(path), DESIGNS["dark_on_light"].draw(400).image[50:350])
    assert main(["--vector", "--frames", "3", "--picture", str(path), "--size", "0.5"]) == 0
    r = json.loads(capsys.readouterr().out)["designs"]["picture:wide pad.png"]
    assert r["renderer"].startswith("the design's picture warped")
    for level in ("clean", "noisy"):
        hinted = r[level]["with_exact_hint"]
        assert hinted["detection_rate"] == 1.0 and hinted["position_error_pct"]["median"] < 1.0


@needs_photos
def test_a_real_photos_pad_is_benched_from_its_rectified_photo(capsys) -> None:
    """The orange pad's reference is a rectified photo (the shared photos'): laid on the
    bench's floors, it is found as the drawn designs are."""
    picture = PHOTOS / "refs" / "orange_rectified.png"
    assert main(["--picture", str(picture), "--size", "1.1", "--frames", "6", "--hint"]) == 0
    r = json.loads(capsys.readouterr().out)["designs"]["picture:orange_rectified.png"]
    assert r["detection_rate"] == 1.0 and r["false_positive_rate"] == 0.0
    assert r["altitude_m"] == pytest.approx([2.0, 12.0])


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--picture", "{pad}"], "--picture needs --size"),
        (["--size", "0.5"], "--size goes with --picture"),
        (["--picture", "{pad}", "--size", "0.5", "--design", "icao"], "separate runs"),
        (["--picture", "{pad}", "--size", "0.5", "--track"], "design bench, --sweep or --vector"),
        (["--picture", "{pad}", "--size", "-1"], "positive number of metres"),
        (["--picture", "{blank}", "--size", "0.5"], "blank.png: "),
        (["--picture", "{missing}", "--size", "0.5"], "cannot read"),
        (["--picture", "{text}", "--size", "0.5"], "as a picture"),
    ],
)
def test_a_bad_picture_or_size_is_refused_clearly(tmp_path, capsys, argv, said) -> None:
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((200, 200, 3), 128, np.uint8))
    text = tmp_path / "notes.png"
    text.write_text("not a picture")
    paths = {"pad": _picture(tmp_path), "blank": blank, "missing": tmp_path / "no.png"}
    paths["text"] = text
    argv = [a.format(**{k: str(v) for k, v in paths.items()}) for a in argv]
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--frames", "1"])
    assert exc.value.code == 2
    assert said in capsys.readouterr().err
