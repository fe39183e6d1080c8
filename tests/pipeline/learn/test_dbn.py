"""The DBN: two stacked RBMs trained greedily, a read-out, fine-tuning."""

import pytest
import torch

from pipeline.learn.dbn import DBN
from pipeline.learn.rbm import single_thread


def _toy(n=600, dims=40, seed=0):
    """Two classes, each a pair of noisy binary prototypes (not linearly trivial)."""
    g = torch.Generator().manual_seed(seed)
    protos = (torch.rand(4, dims, generator=g) < 0.5).float()
    which = torch.randint(0, 4, (n,), generator=g)
    noise = (torch.rand(n, dims, generator=g) < 0.1).float()
    return (protos[which] + noise) % 2, (which % 2).long()


def test_default_shape_is_the_seeds():
    assert DBN(256).hidden == (100, 100)


def test_trains_and_classifies_a_toy_problem():
    x, y = _toy()
    dbn = DBN(40, (100, 100), seed=0)
    seen = []
    with single_thread():
        curves = dbn.fit(
            x[:400],
            y[:400],
            pretrain_epochs=15,
            classifier_epochs=20,
            fine_tune_epochs=5,
            progress=seen.append,
        )
    assert set(curves) == {"rbm1", "rbm2", "classifier", "fine_tune"}
    assert curves["rbm1"][-1] < curves["rbm1"][0]
    assert curves["classifier"][-1] < curves["classifier"][0]
    assert seen[-1] == pytest.approx(1.0) and all(0 <= s <= 1 for s in seen)
    p = dbn.predict_proba(x[400:])
    assert ((p > 0.5).long() != y[400:]).float().mean() < 0.05


def test_greedy_features_alone_classify():
    # Without fine-tuning the read-out sits on the unsupervised features.
    x, y = _toy()
    dbn = DBN(40, (100, 100), seed=1)
    before = [layer.W.detach().clone() for layer in dbn.layers]
    with single_thread():
        dbn.fit(x[:400], y[:400], pretrain_epochs=15, classifier_epochs=30, fine_tune_epochs=0)
    assert not torch.equal(before[0], dbn.layers[0].W)
    p = dbn.predict_proba(x[400:])
    assert ((p > 0.5).long() != y[400:]).float().mean() < 0.1


def test_bad_input():
    dbn = DBN(40, (10, 10))
    with pytest.raises(ValueError, match="labels"):
        dbn.fit(torch.zeros(10, 40), torch.full((10,), 2))
    with pytest.raises(ValueError, match="labels"):
        dbn.fit(torch.zeros(10, 40), torch.zeros(8))
    with pytest.raises(ValueError, match="hidden"):
        DBN(40, ())
    with pytest.raises(ValueError, match="v"):
        dbn.predict_proba(torch.full((2, 40), -1.0))
