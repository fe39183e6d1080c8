"""The verifier: trains on the default pad, accepts the H, rejects look-alikes, saves, refuses."""

import dataclasses
import itertools
import json

import numpy as np
import pytest

from pipeline import Camera, Reference
from pipeline.learn import PoorReference, Verifier, train_verifier
from pipeline.learn.data import (
    MAX_SHAPE_RESIDUAL,
    CandidateSet,
    collect,
    frame_candidates,
    iter_frames,
    label_candidates,
)
from pipeline.learn.verifier import choose_threshold, fit_verifier, split
from pipeline.render import make_pad_image

CAMERA = Camera.from_fov(640, 480, 60.0)


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(), 0.55)


@pytest.fixture(scope="module")
def trained(reference):
    """A test-sized verifier (60 views of the pad, 60 of negatives, short training)."""
    seen = []
    verifier = train_verifier(reference, seed=0, views=60, epochs=6, progress=seen.append)
    return verifier, seen


@pytest.fixture(scope="module")
def fresh(reference):
    """Candidates from frames the verifier never saw (another seed), by frame kind."""
    out = {"pad": [], "stretched": [], "proportions": [], "lookalike": []}
    for frame in iter_frames(reference, CAMERA, views=24, seed=123):
        for cand, label in label_candidates(frame, reference, max_residual=MAX_SHAPE_RESIDUAL):
            if frame.kind == "pad" and label:
                out["pad"].append(cand)
            elif frame.kind != "pad":
                out[frame.kind].append(cand)
    return out


@pytest.mark.slow
def test_trains_and_reports_progress(trained):
    verifier, seen = trained
    assert seen and seen[-1] == 1.0 and all(0 <= a <= b for a, b in itertools.pairwise(seen))
    assert 0.0 < verifier.threshold < 1.0
    assert verifier.info["positives"] >= 30 and verifier.info["negatives"] >= 20
    assert verifier.info["held_out_detection"] >= 0.9


@pytest.mark.slow
def test_accepts_real_h_candidates(trained, fresh):
    verifier, _ = trained
    assert len(fresh["pad"]) >= 15
    accepted = [verifier.accepts(c.corners, c.contour, CAMERA) for c in fresh["pad"]]
    assert np.mean(accepted) >= 0.9


@pytest.mark.slow
def test_rejects_look_alike_candidates(trained, fresh):
    verifier, _ = trained
    # Candidates that passed the pipeline's own corner check: only the verifier stands
    # between them and a false detection.
    negatives = fresh["stretched"] + fresh["proportions"] + fresh["lookalike"]
    assert len(negatives) >= 8
    rejected = [not verifier.accepts(c.corners, c.contour, CAMERA) for c in negatives]
    assert np.mean(rejected) >= 0.8


@pytest.mark.slow
def test_scores_are_probabilities_and_batch_equals_single(trained, fresh):
    verifier, _ = trained
    cands = fresh["pad"][:3] + fresh["stretched"][:3]
    batch = verifier.scores([(c.corners, c.contour) for c in cands])
    single = [verifier.score(c.corners, c.contour) for c in cands]
    assert np.allclose(batch, single) and np.all((batch >= 0) & (batch <= 1))
    assert verifier.scores([]).shape == (0,)


@pytest.mark.slow
def test_save_load_round_trip(trained, fresh, tmp_path):
    verifier, _ = trained
    folder = verifier.save(tmp_path / "verifier")
    assert sorted(p.name for p in folder.iterdir()) == ["verifier.json", "weights.pt"]
    settings = json.loads((folder / "verifier.json").read_text())
    assert settings["threshold"] == verifier.threshold
    loaded = Verifier.load(folder)
    items = [(c.corners, c.contour) for c in fresh["pad"][:5] + fresh["lookalike"][:5]]
    assert np.array_equal(loaded.scores(items), verifier.scores(items))
    assert loaded.threshold == verifier.threshold and loaded.info == verifier.info


def test_load_refuses_what_is_not_a_verifier(tmp_path):
    with pytest.raises(ValueError, match="no readable verifier"):
        Verifier.load(tmp_path / "missing")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "verifier.json").write_text("{not json")
    (tmp_path / "bad" / "weights.pt").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="no readable verifier"):
        Verifier.load(tmp_path / "bad")


@pytest.mark.slow
def test_load_refuses_a_damaged_verifier(trained, tmp_path):
    verifier, _ = trained
    folder = verifier.save(tmp_path / "v")
    settings = json.loads((folder / "verifier.json").read_text())
    settings["hidden"] = [7, 7]  # weights no longer fit
    (folder / "verifier.json").write_text(json.dumps(settings))
    with pytest.raises(ValueError, match="damaged"):
        Verifier.load(folder)
    settings["format"] = "something else"
    (folder / "verifier.json").write_text(json.dumps(settings))
    with pytest.raises(ValueError, match="no visland-verifier"):
        Verifier.load(folder)


def test_poor_reference_tiny_h(reference):
    # The same H on a pad twelve times as wide: it spans 4 % of the pad.
    tiny = dataclasses.replace(reference, pad_size_m=reference.pad_size_m * 12)
    with pytest.raises(PoorReference, match="spans only 4 %"):
        train_verifier(tiny, views=5)


def test_poor_reference_h_never_found(reference):
    # A 4 cm pad seen from 1-6 m: the H is a few pixels, the corner check never passes.
    small = dataclasses.replace(reference, pad_size_m=0.04, corners_m=reference.corners_m / 13.75)
    with pytest.raises(PoorReference, match="synthetic views of the pad gave an H"):
        train_verifier(small, views=8)


def test_poor_reference_is_a_value_error():
    assert issubclass(PoorReference, ValueError)


def test_bad_arguments(reference):
    with pytest.raises(ValueError, match="reference"):
        train_verifier("pad.png")
    with pytest.raises(ValueError, match="views"):
        train_verifier(reference, views=0)


def test_threshold_keeps_positives_and_leaves_a_margin():
    pos = np.array([0.99, 0.98, 0.97, 0.999, 0.95])
    neg = np.array([0.01, 0.02, 0.001])
    t = choose_threshold(pos, neg, keep=1.0)
    assert 0.02 < t <= 0.5
    # A negative above some positives: the threshold still keeps the positives.
    t2 = choose_threshold(np.array([0.3, 0.9, 0.95]), np.array([0.1, 0.6]), keep=1.0)
    assert 0.1 < t2 <= 0.3


def test_split_holds_out_a_share_of_each_class():
    labels = np.array([1] * 40 + [0] * 20)
    train, held = split(labels, 0)
    assert len(set(train) & set(held)) == 0 and len(train) + len(held) == 60
    assert labels[held].sum() == 10 and (labels[held] == 0).sum() == 5


def test_candidates_follow_the_pipeline(reference):
    frames = iter_frames(reference, CAMERA, views=4, seed=5, kinds=("pad",))
    found = 0
    for frame in frames:
        for cand in frame_candidates(frame.image, reference, max_residual=MAX_SHAPE_RESIDUAL):
            assert cand.corners.shape == (12, 2) and cand.residual <= MAX_SHAPE_RESIDUAL
            found += 1
    assert found >= 3


def test_fit_refuses_too_few_negatives(reference):
    data = collect(reference, views=14, seed=3, kinds=("pad",))
    assert isinstance(data, CandidateSet) and data.positives >= 12
    with pytest.raises(PoorReference, match="negative"):
        fit_verifier(reference, data)
