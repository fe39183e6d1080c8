"""The pipeline on real photos of real H pads: ``python -m pipeline.bench --photos DIR``.

``DIR`` holds a ``manifest.json`` as ``../shared/photos`` does: each positive photo's
pad design and a hand-checked box around its H, negatives with no H, and the
references of each design. Each positive is searched with every reference of its
design drawn in its own polarity, and a detection counts when all 12 corners lie in
the box grown by 10 % of its size (3 px at least) on every side (the manifest's
``box_rule``); each negative is searched with every reference, the inverted ones and
the default pad's too, and any detection there is a false positive.

The renderer's frames share its author's blind spots; these photos do not, but they
are few. ``--augment K`` sees each photo K more times through what real cameras and
flights add, the degradations the vision issues name: turned any way, scaled 0.6-1.5,
keystoned (the far side up to a fifth shorter than the near one, as a tilted camera
sees it), exposure (gamma 0.6-1.6, gain 0.7-1.3), directional motion blur up to 5 px,
sensor noise and JPEG at quality 40-95.
The box is carried through the same warp (the upright box around its four corners).
The canvas beyond the photo is the photo's mean colour: a mirrored border would
draw symmetric, H-like shapes that are not on the ground.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import cv2
import numpy as np

from pipeline import Camera, Reference, process_frame
from pipeline.bench.tally import stats
from pipeline.cores import use_one_core
from pipeline.picture import read_picture

FOV_DEG = 70.0  # the photos' cameras are unknown; the corners do not depend on it
SCALE = (0.6, 1.5)
MAX_KEYSTONE = 0.25  # the picture's far edge up to 1 - 0.875 / 1.125 (a fifth) shorter
GAMMA, GAIN = (0.6, 1.6), (0.7, 1.3)
MAX_BLUR_PX = 5
MAX_NOISE = 6.0  # sensor noise, levels (0-255), its standard deviation at most
JPEG_QUALITY = (40, 95)


def load_manifest(photos_dir: str | Path) -> dict:
    """The manifest of a photos folder; ValueError when there is none."""
    path = Path(photos_dir) / "manifest.json"
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"photos: no manifest.json in {photos_dir}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"photos: {path} is not JSON ({exc.msg})") from None


def references_of(manifest: dict, *, same_polarity: bool) -> list[tuple[str, dict]]:
    """(design, reference entry) for the references drawn in their pads' own polarity,
    or those drawn inverted (another pad design in fact: a dark H for a light one)."""
    return [
        (design, ref)
        for design, info in manifest["designs"].items()
        for ref in info["references"]
        if ("inverted" in ref["kind"]) != same_polarity
    ]


def in_box(corners: np.ndarray, box: tuple[float, float, float, float]) -> bool:
    """Whether every corner lies in ``box`` (x, y, width, height) grown by the
    manifest's rule: 10 % of its width and height on every side, 3 px at least."""
    x, y, w, h = box
    gx, gy = max(3.0, 0.1 * w), max(3.0, 0.1 * h)
    inside_x = (corners[:, 0] >= x - gx) & (corners[:, 0] <= x + w + gx)
    inside_y = (corners[:, 1] >= y - gy) & (corners[:, 1] <= y + h + gy)
    return bool(np.all(inside_x & inside_y))


def degrade_photo(image: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The photo seen another way (see the module's notes), and the homography from
    its pixels to the new picture's (3 x 3)."""
    h, w = image.shape[:2]
    turn = cv2.getRotationMatrix2D((w / 2, h / 2), rng.uniform(0.0, 360.0), rng.uniform(*SCALE))
    c = np.abs(turn[:, :2])
    out_w, out_h = int(c[0, 0] * w + c[0, 1] * h), int(c[1, 0] * w + c[1, 1] * h)
    turn[:, 2] += [out_w / 2 - w / 2, out_h / 2 - h / 2]
    k = rng.uniform(-1.0, 1.0, 2) * MAX_KEYSTONE / max(out_w, out_h)
    centre = np.array([[1.0, 0.0, out_w / 2], [0.0, 1.0, out_h / 2], [0.0, 0.0, 1.0]])
    keystone = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [k[0], k[1], 1.0]])
    T = centre @ keystone @ np.linalg.inv(centre) @ np.vstack([turn, [0.0, 0.0, 1.0]])
    mean = tuple(float(v) for v in image.reshape(-1, image.shape[2]).mean(axis=0))
    out = cv2.warpPerspective(
        image, T, (out_w, out_h), borderMode=cv2.BORDER_CONSTANT, borderValue=mean
    )
    light = (out / 255.0) ** rng.uniform(*GAMMA) * rng.uniform(*GAIN)
    out = np.clip(255.0 * light, 0, 255).astype(np.uint8)
    length = int(rng.integers(1, MAX_BLUR_PX + 1))
    if length > 1:
        kernel = np.zeros((length, length), np.float32)
        kernel[length // 2, :] = 1.0
        spin = cv2.getRotationMatrix2D(
            (length / 2 - 0.5, length / 2 - 0.5), rng.uniform(0.0, 180.0), 1.0
        )
        kernel = cv2.warpAffine(kernel, spin, (length, length))
        out = cv2.filter2D(out, -1, kernel / kernel.sum())
    noisy = out + rng.normal(0.0, rng.uniform(0.0, MAX_NOISE), out.shape)
    out = np.clip(noisy, 0, 255).astype(np.uint8)
    quality = int(rng.integers(JPEG_QUALITY[0], JPEG_QUALITY[1] + 1))
    _, jpeg = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, quality])
    return cv2.imdecode(jpeg, cv2.IMREAD_COLOR), T


def run_photos(photos_dir: str | Path, *, augment: int = 0, seed: int = 0) -> dict:
    """The figures on the photos as they are, and with ``augment`` degraded views of
    each (seed ``seed``)."""
    if augment < 0:
        raise ValueError(f"augment must be 0 or more, got {augment}")
    use_one_core()
    root = Path(photos_dir)
    manifest = load_manifest(root)
    references: dict[str, Reference] = {}

    def reference(entry: dict) -> Reference:
        if entry["file"] not in references:
            picture = _read(root, entry["file"])
            references[entry["file"]] = Reference.from_image(picture, entry["pad_size_m"])
        return references[entry["file"]]

    own = references_of(manifest, same_polarity=True)
    every = [e for _, e in own + references_of(manifest, same_polarity=False)]
    every.append(manifest["default_reference"])
    scores = {"original": _Score(), "augmented": _Score()}
    for index, item in enumerate(manifest["items"]):
        photo = _read(root, item["file"])  # (read once: seen as it is, then degraded)
        views = [("original", item["file"], photo, np.eye(3))]
        for k in range(augment):
            views.append(
                ("augmented", f"{item['file']} #{k}", *degraded_view(photo, seed, index, k))
            )
        for name, label, image, T in views:
            score = scores[name]
            if item["kind"] == "pos":
                box = carried_box(item["h_box"], T)
                for design, entry in own:
                    if design == item["design"]:
                        score.positive(image, reference(entry), box, design, label, entry)
            else:
                for entry in every:
                    score.negative(image, reference(entry), label, entry)
    out = {"photos_dir": str(root), "fov_deg": FOV_DEG, "original": scores["original"].summary()}
    if augment:
        out["augmented"] = {
            **scores["augmented"].summary(),
            "views_per_photo": augment,
            "seed": seed,
        }
    return out


def degraded_view(
    photo: np.ndarray, seed: int, index: int, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """View ``k`` of the manifest's item ``index`` in a run of seed ``seed`` (each view
    drawn apart, so that one can be looked at again alone): `degrade_photo`'s."""
    return degrade_photo(photo, np.random.default_rng([seed, index, k]))


def carried_box(box: list[float], T: np.ndarray) -> tuple[float, float, float, float]:
    """The upright box around ``box`` (x, y, width, height) warped by ``T``."""
    x, y, w, h = box
    corners = np.array([[[x, y], [x + w, y], [x + w, y + h], [x, y + h]]], np.float64)
    warped = cv2.perspectiveTransform(corners, T)[0]
    lo, hi = warped.min(axis=0), warped.max(axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1])


def _read(root: Path, file: str) -> np.ndarray:
    try:
        return read_picture(root / file)
    except ValueError as exc:
        raise ValueError(f"photos: {exc}") from None


class _Score:
    """Positives found in their box and detections on negatives, per design."""

    def __init__(self) -> None:
        self.per_design: dict[str, list[int]] = {}
        self.misses: list[str] = []
        self.negative_checks = 0
        self.hits: list[str] = []
        self.seconds: list[float] = []

    def _detect(self, image: np.ndarray, reference: Reference):
        h, w = image.shape[:2]
        camera = Camera.from_fov(w, h, FOV_DEG)
        t0 = time.perf_counter()
        res = process_frame(image, reference, camera)
        self.seconds.append(time.perf_counter() - t0)
        return res

    def positive(self, image, reference, box, design: str, label: str, entry: dict) -> None:
        res = self._detect(image, reference)
        found = res.detected and in_box(res.corners_px, box)
        tally = self.per_design.setdefault(design, [0, 0])
        tally[0] += found
        tally[1] += 1
        if not found:
            why = res.reason or "found outside the H's box"
            self.misses.append(f"{label} with {entry['file']}: {why}")

    def negative(self, image, reference, label: str, entry: dict) -> None:
        self.negative_checks += 1
        if self._detect(image, reference).detected:
            self.hits.append(f"{label} with {entry['file']}")

    def summary(self) -> dict:
        found = sum(f for f, _ in self.per_design.values())
        checks = sum(n for _, n in self.per_design.values())
        return {
            "positives": {
                "checks": checks,
                "found": found,
                "rate": found / checks if checks else None,
                "per_design": {
                    d: {"checks": n, "found": f, "rate": f / n}
                    for d, (f, n) in self.per_design.items()
                },
                "misses": self.misses,
            },
            "negatives": {
                "checks": self.negative_checks,
                "false_positives": len(self.hits),
                "rate": len(self.hits) / self.negative_checks if self.negative_checks else None,
                "hits": self.hits,
            },
            "ms_per_photo": stats([1e3 * s for s in self.seconds]),
        }
