"""``python -m pipeline.bench --photos DIR [--augment K]`` on a photos folder of its own
(the layout of ``../shared/photos``), and the degradations it sees the photos through."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from pipeline import Reference
from pipeline.bench.__main__ import main
from pipeline.bench.photos import MAX_BLUR_PX, degrade_photo, in_box, load_manifest, run_photos
from pipeline.render import make_pad_image

PAD_PX, PAD_M = 160, 0.55
AT = (150, 90)  # where the pad's picture lies on the positive photo


def _photos(tmp_path) -> dict:
    """A photos folder: the default pad on a plain floor (its H's box from the
    reference's corners), a floor without it, and the pad's picture as the reference."""
    pad = make_pad_image(PAD_PX)
    (tmp_path / "refs").mkdir()
    cv2.imwrite(str(tmp_path / "refs" / "pad.png"), pad)
    floor = np.full((360, 480, 3), (96, 110, 104), np.uint8)
    cv2.randn(noise := np.zeros(floor.shape, np.int16), 0, 4)
    floor = np.clip(floor + noise, 0, 255).astype(np.uint8)
    photo = floor.copy()
    photo[AT[1] : AT[1] + PAD_PX, AT[0] : AT[0] + PAD_PX] = pad
    cv2.imwrite(str(tmp_path / "pos.png"), photo)
    cv2.imwrite(str(tmp_path / "neg.png"), floor)
    corners = Reference.from_image(pad, PAD_M).corners_m * (PAD_PX / PAD_M)
    x = corners[:, 0] + PAD_PX / 2 + AT[0]
    y = PAD_PX / 2 - corners[:, 1] + AT[1]
    box = [float(x.min()), float(y.min()), float(np.ptp(x)), float(np.ptp(y))]
    ref = {"file": "refs/pad.png", "pad_size_m": PAD_M, "kind": "synthetic", "note": ""}
    manifest = {
        "designs": {"default": {"desc": "the default pad", "references": [ref]}},
        "default_reference": ref,
        "items": [
            {"file": "pos.png", "kind": "pos", "design": "default", "h_box": box},
            {"file": "neg.png", "kind": "neg", "design": None},
        ],
    }
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    return manifest


def test_the_photos_as_they_are_and_degraded(tmp_path) -> None:
    _photos(tmp_path)
    out = run_photos(tmp_path, augment=2, seed=0)
    original = out["original"]
    assert original["positives"]["checks"] == 1
    assert original["positives"]["found"] == 1, original["positives"]["misses"]
    assert original["positives"]["per_design"]["default"]["rate"] == 1.0
    # the negative with every reference: its one and the default (the same picture)
    assert original["negatives"] == {"checks": 2, "false_positives": 0, "rate": 0.0, "hits": []}
    augmented = out["augmented"]
    assert augmented["views_per_photo"] == 2 and augmented["seed"] == 0
    assert augmented["positives"]["checks"] == 2
    assert augmented["negatives"]["checks"] == 4
    assert augmented["ms_per_photo"]["median"] > 0
    again = run_photos(tmp_path, augment=2, seed=0)["augmented"]  # (seeded: the same views)
    assert again["positives"] == augmented["positives"]
    assert again["negatives"] == augmented["negatives"]


def test_a_degraded_photo_carries_its_box(tmp_path) -> None:
    """A bright square's pixels stay in the box its corners are carried to, under every
    turn, scale, keystone, exposure, blur, noise and JPEG the seeds draw."""
    photo = np.full((200, 300, 3), 90, np.uint8)
    x, y, w, h = 170, 60, 50, 30
    photo[y : y + h, x : x + w] = 230
    for seed in range(12):
        image, T = degrade_photo(photo, np.random.default_rng(seed))
        assert image.dtype == np.uint8 and image.ndim == 3
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        _, mask = cv2.threshold(gray, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        boxes = cv2.connectedComponentsWithStats(mask)[2]
        bx, by, bw, bh, _ = boxes[1 + int(np.argmax(boxes[1:, 4]))]
        corners = np.array([[[x, y], [x + w, y], [x + w, y + h], [x, y + h]]], np.float64)
        carried = cv2.perspectiveTransform(corners, T)[0]
        reach = MAX_BLUR_PX  # (the blur spreads the square's edge)
        assert bx >= carried[:, 0].min() - reach and bx + bw <= carried[:, 0].max() + reach
        assert by >= carried[:, 1].min() - reach and by + bh <= carried[:, 1].max() + reach
        assert bw * bh > 0.5 * (np.ptp(carried[:, 0]) * np.ptp(carried[:, 1])) / 2


def test_the_box_rule() -> None:
    box = (10.0, 20.0, 40.0, 20.0)  # grown by 4 px across and 3 px (the least) down
    assert in_box(np.array([[6.0, 17.0], [54.0, 43.0]]), box)
    assert not in_box(np.array([[5.9, 30.0]]), box)
    assert not in_box(np.array([[30.0, 43.1]]), box)


def test_a_folder_without_a_manifest_is_a_clear_error(tmp_path, capsys) -> None:
    with pytest.raises(ValueError, match=r"no manifest\.json"):
        load_manifest(tmp_path)
    (tmp_path / "manifest.json").write_text("{not json")
    with pytest.raises(ValueError, match="is not JSON"):
        load_manifest(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(["--photos", str(tmp_path)])
    assert exc.value.code == 2
    assert "is not JSON" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--photos", str(tmp_path), "--augment", "-1"])
    assert "--augment must be 0 or more" in capsys.readouterr().err


def test_a_photo_that_cannot_be_read_is_named(tmp_path) -> None:
    manifest = _photos(tmp_path)
    (tmp_path / "pos.png").write_bytes(b"not a picture")
    with pytest.raises(ValueError, match=r"cannot read .*pos\.png"):
        run_photos(tmp_path)
    assert manifest["items"][0]["file"] == "pos.png"


def test_cli_prints_the_photos_json(tmp_path, capsys) -> None:
    _photos(tmp_path)
    assert main(["--photos", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["original"]["positives"]["found"] == 1
    assert "augmented" not in out
