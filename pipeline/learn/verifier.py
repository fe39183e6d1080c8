"""A per-reference verifier: is this candidate's corner pattern the reference's H?

`train_verifier` renders synthetic views of the reference's pad and of hard
negatives (`pipeline.learn.data`), encodes every candidate
(`pipeline.learn.encoding`), trains a DBN (`pipeline.learn.dbn`) on them and
picks the acceptance threshold on a held-out quarter so that (almost) every
held-out H is still accepted: the verifier must not cost detections.

process_frame calls ``verifier.accepts(corners, contour)`` for each candidate
that passed its corner check: ``corners`` the 12 corners in the reference's
order as ``match_corners`` returns them, ``contour`` the region's boundary,
both in the same pixel coordinates.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from pipeline.camera import Camera
from pipeline.learn.data import ALTITUDE_M, CandidateSet, Progress, collect
from pipeline.learn.dbn import DBN
from pipeline.learn.encoding import Encoder
from pipeline.learn.rbm import single_thread
from pipeline.reference import Reference

DEFAULT_VIEWS = 1000
HELD_OUT_SHARE = 0.25
KEEP_POSITIVES = 0.995  # share of held-out H's the threshold must still accept
MIN_H_SHARE = 0.1  # the H must span at least this share of the pad's width
MIN_POSITIVE_SHARE = 0.3  # of the pad's views must give an H that passes the corner check
MIN_POSITIVES = 12
MIN_NEGATIVES = 8
FORMAT = "visland-verifier/1"
_WEIGHTS = "weights.pt"
_SETTINGS = "verifier.json"


class PoorReference(ValueError):
    """The reference's H cannot be learned; run with the verifier off."""


@dataclass(frozen=True, eq=False)
class Verifier:
    """Scores candidates with a DBN on their encoded corner pattern.

    ``threshold``: the least P(H) accepted; ``info``: training facts (counts,
    held-out rates) for the dashboard and the logs.
    """

    encoder: Encoder
    model: DBN
    threshold: float
    info: dict = field(default_factory=dict)

    def scores(
        self, items: list[tuple[np.ndarray, np.ndarray]], camera: Camera | None = None
    ) -> np.ndarray:
        """P(H) for many (corners_px, contour_px) pairs."""
        if not items:
            return np.zeros(0)
        codes = self.encoder.encode_many(items, camera)
        with single_thread():
            return self.model.predict_proba(torch.from_numpy(codes)).double().numpy()

    def score(
        self, corners_px: np.ndarray, contour_px: np.ndarray, camera: Camera | None = None
    ) -> float:
        """P(H) of one candidate: its ordered corners (N, 2) and contour (M, 2), pixels.

        ``camera``: the intrinsics of the image those pixels are in (process_frame's
        working camera); None assumes the camera the verifier was trained with.
        Raises ValueError naming the argument when the arrays are malformed.
        """
        return float(self.scores([(corners_px, contour_px)], camera)[0])

    def accepts(
        self, corners_px: np.ndarray, contour_px: np.ndarray, camera: Camera | None = None
    ) -> bool:
        """Whether the candidate is the reference's H (score at least the threshold)."""
        return self.score(corners_px, contour_px, camera) >= self.threshold

    def save(self, path: str | Path) -> Path:
        """Write the verifier into the directory ``path`` (weights + JSON settings)."""
        folder = Path(path)
        folder.mkdir(parents=True, exist_ok=True)
        torch.save({"dbn": self.model.state_dict()}, folder / _WEIGHTS)
        settings = {
            "format": FORMAT,
            "template": self.encoder.template.tolist(),
            "extent": self.encoder.extent,
            "symmetric": self.encoder.symmetric,
            "camera": {
                "width": self.encoder.camera.width,
                "height": self.encoder.camera.height,
                "K": self.encoder.camera.K.tolist(),
                "dist": self.encoder.camera.dist.tolist(),
            },
            "corner_grid": self.encoder.corner_grid,
            "shape_grid": self.encoder.shape_grid,
            "hidden": list(self.model.hidden),
            "threshold": self.threshold,
            "info": self.info,
        }
        (folder / _SETTINGS).write_text(json.dumps(settings, indent=2))
        return folder

    @classmethod
    def load(cls, path: str | Path) -> Verifier:
        """Read a verifier written by :meth:`save`; ValueError when it is not one."""
        folder = Path(path)
        try:
            settings = json.loads((folder / _SETTINGS).read_text())
            state = torch.load(folder / _WEIGHTS, weights_only=True)
        except (OSError, json.JSONDecodeError, RuntimeError, EOFError) as exc:
            raise ValueError(f"path {folder} holds no readable verifier: {exc}") from exc
        if not isinstance(settings, dict) or settings.get("format") != FORMAT:
            raise ValueError(f"path {folder} holds no {FORMAT} verifier")
        try:
            cam = settings["camera"]
            camera = Camera(
                int(cam["width"]),
                int(cam["height"]),
                np.asarray(cam["K"], np.float64),
                np.asarray(cam["dist"], np.float64),
            )
            encoder = Encoder(
                np.asarray(settings["template"], np.float64),
                float(settings["extent"]),
                bool(settings["symmetric"]),
                camera,
                int(settings["corner_grid"]),
                int(settings["shape_grid"]),
            )
            model = DBN(encoder.size, tuple(int(h) for h in settings["hidden"]))
            model.load_state_dict(state["dbn"])
            threshold = float(settings["threshold"])
        except (KeyError, TypeError, ValueError, RuntimeError) as exc:
            raise ValueError(f"path {folder} holds a damaged verifier: {exc}") from exc
        model.eval()
        return cls(encoder, model, threshold, dict(settings.get("info", {})))


def train_verifier(
    reference: Reference,
    *,
    seed: int = 0,
    views: int = DEFAULT_VIEWS,
    progress: Progress | None = None,
    camera: Camera | None = None,
    epochs: int = 15,
) -> Verifier:
    """Train a verifier for ``reference`` on ``views`` synthetic views of it (+ as many negatives).

    Parameters
    ----------
    reference : the pad, from ``Reference.from_image``.
    seed : seeds the renderer and the training (same seed, same verifier).
    views : frames of the pad (and as many of negatives) to learn from.
    progress : called with the fraction done (0..1) now and then.
    camera : the camera the synthetic views are taken with (default 640x480, 60 deg).
    epochs : pre-training epochs per RBM (the read-out and fine-tuning scale with it).

    Raises
    ------
    PoorReference
        when the reference's H is too small on its pad, or too few synthetic
        views of it pass the pipeline's corner check to learn from.
    """
    if not isinstance(reference, Reference):
        raise ValueError(f"reference must be a pipeline.Reference, got {type(reference).__name__}")
    if isinstance(views, bool) or not isinstance(views, int) or views <= 0:
        raise ValueError(f"views must be a positive integer, got {views!r}")
    camera = camera or Camera.from_fov(640, 480, 60.0)
    check_reference(reference, camera)

    def data_progress(frac: float) -> None:
        if progress is not None:
            progress(0.7 * frac)

    dataset = collect(reference, views=views, seed=seed, camera=camera, progress=data_progress)
    return fit_verifier(
        reference, dataset, seed=seed, epochs=epochs, camera=camera, progress=progress
    )


def check_reference(reference: Reference, camera: Camera) -> None:
    """Raise PoorReference when the H is too small on its pad to be learned."""
    share = reference.h_size_m / reference.pad_size_m
    if share < MIN_H_SHARE:
        span = camera.K[0, 0] * reference.h_size_m / ALTITUDE_M[1]
        raise PoorReference(
            f"the reference's H spans only {100 * share:.0f} % of the pad's width "
            f"(about {span:.0f} px from {ALTITUDE_M[1]:.0f} m), too small to verify; "
            f"use a pad whose H spans at least {100 * MIN_H_SHARE:.0f} %"
        )


def fit_verifier(
    reference: Reference,
    dataset: CandidateSet,
    *,
    seed: int = 0,
    epochs: int = 15,
    camera: Camera | None = None,
    progress: Progress | None = None,
) -> Verifier:
    """Train the DBN on ``dataset`` (rendered with ``camera``); threshold on its held-out part."""
    positives = dataset.positives
    negatives = len(dataset.labels) - positives
    need = max(MIN_POSITIVES, math.ceil(MIN_POSITIVE_SHARE * dataset.pad_frames))
    if positives < need:
        raise PoorReference(
            f"only {positives} of {dataset.pad_frames} synthetic views of the pad gave an H "
            f"that passes the corner check (at least {need} needed): the reference's H is "
            "too hard to find to be learned; run with the verifier off"
        )
    if negatives < MIN_NEGATIVES:
        raise PoorReference(
            f"only {negatives} negative candidates came out of {dataset.frames} frames "
            f"(at least {MIN_NEGATIVES} needed); render more views"
        )
    encoder = Encoder.for_corners(reference.corners_m, symmetric=reference.symmetric, camera=camera)
    codes = dataset.codes(encoder)
    train, held = split(dataset.labels, seed)
    torch.manual_seed(seed)
    model = DBN(encoder.size, seed=seed)

    def fit_progress(frac: float) -> None:
        if progress is not None:
            progress(0.7 + 0.3 * frac)

    with single_thread():
        model.fit(
            codes[train],
            dataset.labels[train],
            pretrain_epochs=epochs,
            classifier_epochs=4 * epochs,
            fine_tune_epochs=2 * epochs,
            seed=seed,
            progress=fit_progress,
        )
        model.eval()
        held_scores = model.predict_proba(torch.from_numpy(codes[held])).double().numpy()
    y_held = dataset.labels[held]
    threshold = choose_threshold(held_scores[y_held == 1], held_scores[y_held == 0])
    info = {
        "views": dataset.pad_frames,
        "frames": dataset.frames,
        "positives": positives,
        "negatives": negatives,
        "held_out": len(held),
        "held_out_detection": float(np.mean(held_scores[y_held == 1] >= threshold)),
        "held_out_fp": float(np.mean(held_scores[y_held == 0] >= threshold))
        if np.any(y_held == 0)
        else 0.0,
        "seed": seed,
    }
    if progress is not None:
        progress(1.0)
    return Verifier(encoder, model, float(threshold), info)


def split(labels: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Train and held-out indices: a random ``HELD_OUT_SHARE`` of each class is held out."""
    rng = np.random.default_rng([seed, 4242])
    train, held = [], []
    for cls in np.unique(labels):
        idx = np.flatnonzero(labels == cls)
        rng.shuffle(idx)
        n_held = max(1, round(HELD_OUT_SHARE * len(idx))) if len(idx) > 1 else 0
        held.append(idx[:n_held])
        train.append(idx[n_held:])
    return np.sort(np.concatenate(train)), np.sort(np.concatenate(held))


def choose_threshold(pos: np.ndarray, neg: np.ndarray, keep: float = KEEP_POSITIVES) -> float:
    """A threshold on P(H): at least ``keep`` of ``pos`` accepted, as few ``neg`` as that allows.

    The highest threshold that keeps ``keep`` of the positives rejects the most
    negatives; the threshold is put halfway (in log-odds) between it and the
    highest negative score below it, so that both sides get a margin.
    """
    if len(pos) == 0:
        return 0.5
    upper = float(np.quantile(pos, 1.0 - keep, method="lower"))
    below = neg[neg < upper]
    lower = float(below.max()) if len(below) else 0.0
    # A clean split needs no threshold above 0.5: accept as a classifier would.
    lo, hi = _logit(lower), _logit(min(upper, 0.5) if lower < 0.5 else upper)
    return float(_sigmoid(0.5 * (lo + hi)))


def _logit(p: float) -> float:
    p = min(max(p, 1e-9), 1 - 1e-9)
    return math.log(p / (1 - p))


def _sigmoid(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-x))
