"""``python -m pipeline.learn bench --json [--seed N]``: the pattern-learning benchmark.

On the default pad (0.55 m, the renderer's 640x480 60 degree camera):

1. Trains the verifier as ``train_verifier`` does (1000 views of the pad and
   1000 frames of negatives rendered, then the DBN); ``train_s`` is the
   wall-clock time of both.
2. On a held-out candidate set (200 + 200 frames, another seed; candidates up
   to the training gate, residual <= 0.3): classification error of an RBM
   with label units read out by free energy (``rbm_error``), of the verifier's
   DBN (``dbn_error``) and of 5-NN on log Hu invariants (``knn_hu_error``),
   each with its threshold picked on the training run's held-out quarter.
3. Frame level, process_frame's candidate path (Otsu, regions, Hu/solidity,
   12 corners, homography residual <= 0.1) with and without the verifier:
   on 300 pad frames and 300 hard negative frames (a third seed):
   ``detection_*`` is the share of pad frames whose H gets through,
   ``fp_*`` the share of hard negative frames (stretched pads, pads with
   other H proportions, 'II', broken H's, wide H's, letters and other
   look-alikes) in which anything gets through.

Prints one JSON object; tqdm progress on stderr when stderr is a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from contextlib import nullcontext

import cv2
import numpy as np
import torch

from pipeline.camera import Camera
from pipeline.learn.data import (
    MAX_SHAPE_RESIDUAL,
    CandidateSet,
    collect,
    frame_candidates,
    is_pad_h,
    iter_frames,
)
from pipeline.learn.rbm import RBMClassifier, single_thread
from pipeline.learn.verifier import DEFAULT_VIEWS, Verifier, fit_verifier, split
from pipeline.reference import Reference
from pipeline.render import make_pad_image

PAD_SIZE_M = 0.55
KNN_K = 5
SIZES = {  # (training views, test views, frame views, epochs)
    "full": (DEFAULT_VIEWS, 200, 300, 15),
    "quick": (40, 16, 12, 3),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.learn", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    bench = sub.add_parser("bench", help="train and measure; prints one JSON object")
    bench.add_argument("--json", action="store_true", help="print JSON (the only output format)")
    bench.add_argument("--seed", type=int, default=0)
    bench.add_argument("--quick", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    result = run(args.seed, quick=args.quick, show_progress=sys.stderr.isatty())
    print(json.dumps(result, indent=2 if args.json else None))
    return 0


def run(seed: int, *, quick: bool = False, show_progress: bool = False) -> dict:
    """The benchmark's numbers (see the module docstring)."""
    cv2.setNumThreads(1)
    torch.manual_seed(seed)
    views, test_views, frame_views, epochs = SIZES["quick" if quick else "full"]
    camera = Camera.from_fov(640, 480, 60.0)
    reference = Reference.from_image(make_pad_image(), PAD_SIZE_M)

    with _bar(show_progress, "train") as bar:
        t0 = time.perf_counter()
        data_bar = None if bar is None else (lambda frac: bar(0.7 * frac))
        train = collect(reference, views=views, seed=seed, camera=camera, progress=data_bar)
        verifier = fit_verifier(
            reference, train, seed=seed, epochs=epochs, camera=camera, progress=bar
        )
        train_s = time.perf_counter() - t0

    with _bar(show_progress, "test set") as bar:
        test = collect(reference, views=test_views, seed=seed + 1000, camera=camera, progress=bar)
    errors = _errors(verifier, train, test, seed, epochs)

    with _bar(show_progress, "frames") as bar:
        rates = _frame_rates(verifier, reference, camera, frame_views, seed + 2000, bar)
    return {**errors, "train_s": round(train_s, 2), "verifier": rates}


def _errors(verifier: Verifier, train: CandidateSet, test: CandidateSet, seed: int, epochs: int):
    """Classification errors on ``test`` of the RBM, the DBN and k-NN on Hu invariants."""
    enc = verifier.encoder
    x_train, x_test = train.codes(enc), test.codes(enc)
    y_train, y_test = train.labels, test.labels
    fit_idx, held_idx = split(y_train, seed)
    with single_thread():
        rbm = RBMClassifier(enc.size, 100, seed=seed)
        rbm.fit(x_train[fit_idx], y_train[fit_idx], epochs=2 * epochs, seed=seed)
        rbm_held = rbm.log_odds(x_train[held_idx]).double().numpy()
        rbm_test = rbm.log_odds(x_test).double().numpy()
        dbn_held = verifier.model.predict_proba(torch.from_numpy(x_train[held_idx])).double()
        dbn_test = verifier.model.predict_proba(torch.from_numpy(x_test)).double()
    y_held = y_train[held_idx]
    rbm_t = _best_threshold(rbm_held, y_held)
    dbn_t = _best_threshold(dbn_held.numpy(), y_held)
    hu_train, hu_test = train.hu(), test.hu()
    mu, sd = hu_train.mean(axis=0), hu_train.std(axis=0) + 1e-9
    knn = _knn_predict((hu_train[fit_idx] - mu) / sd, y_train[fit_idx], (hu_test - mu) / sd)
    return {
        "rbm_error": round(float(np.mean((rbm_test >= rbm_t) != y_test)), 4),
        "dbn_error": round(float(np.mean((dbn_test.numpy() >= dbn_t) != y_test)), 4),
        "knn_hu_error": round(float(np.mean(knn != y_test)), 4),
    }


def _best_threshold(scores: np.ndarray, labels: np.ndarray) -> float:
    """The threshold with the fewest held-out errors (midpoint between neighbouring scores)."""
    s = np.sort(np.unique(scores))
    cuts = np.concatenate([[s[0] - 1.0], (s[1:] + s[:-1]) / 2, [s[-1] + 1.0]])
    errs = [np.mean((scores >= c) != labels) for c in cuts]
    return float(cuts[int(np.argmin(errs))])


def _knn_predict(x_train: np.ndarray, y_train: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Majority vote of the ``KNN_K`` nearest training points (Euclidean)."""
    d = torch.cdist(torch.from_numpy(x), torch.from_numpy(x_train)).numpy()
    k = min(KNN_K, len(x_train))
    nearest = np.argsort(d, axis=1, kind="stable")[:, :k]
    return (y_train[nearest].mean(axis=1) > 0.5).astype(np.int64)


def _frame_rates(verifier, reference, camera, views, seed, progress) -> dict:
    """Detection and false-positive rates of the candidate path with and without the verifier."""
    hits = {"with": 0, "without": 0}
    fps = {"with": 0, "without": 0}
    pads = negatives = 0
    for done, frame in enumerate(iter_frames(reference, camera, views=views, seed=seed), 1):
        cands = frame_candidates(frame.image, reference, max_residual=MAX_SHAPE_RESIDUAL)
        if frame.kind == "pad":
            pads += 1
            h = [c for c in cands if is_pad_h(c, frame)]
            hits["without"] += bool(h)
            hits["with"] += any(verifier.accepts(c.corners, c.contour, camera) for c in h)
        else:
            negatives += 1
            fps["without"] += bool(cands)
            fps["with"] += any(verifier.accepts(c.corners, c.contour, camera) for c in cands)
        if progress is not None:
            progress(done / (2 * views))
    return {
        "detection_with": round(hits["with"] / max(pads, 1), 4),
        "detection_without": round(hits["without"] / max(pads, 1), 4),
        "fp_with": round(fps["with"] / max(negatives, 1), 4),
        "fp_without": round(fps["without"] / max(negatives, 1), 4),
    }


def _bar(show: bool, label: str):
    """A context giving a progress(frac) callback: a tqdm bar on stderr, or None."""
    if not show:
        return nullcontext(None)
    from tqdm import tqdm

    class _Bar:
        def __enter__(self):
            self.bar = tqdm(total=1000, desc=label, file=sys.stderr, leave=False)
            return self.update

        def update(self, frac: float) -> None:
            self.bar.n = int(1000 * min(max(frac, 0.0), 1.0))
            self.bar.refresh()

        def __exit__(self, *exc):
            self.bar.close()
            return False

    return _Bar()


if __name__ == "__main__":
    raise SystemExit(main())
