"""The Bernoulli RBM: conditionals, CD-k and persistent CD, free energy, sampling."""

import numpy as np
import pytest
import torch

from pipeline.learn.rbm import RBM, RBMClassifier, single_thread


def _prototypes(n=400, dims=36, flip=0.03, seed=0):
    """Noisy copies of four random binary prototypes, and which prototype each is."""
    g = torch.Generator().manual_seed(seed)
    protos = (torch.rand(4, dims, generator=g) < 0.5).float()
    which = torch.randint(0, 4, (n,), generator=g)
    noise = (torch.rand(n, dims, generator=g) < flip).float()
    return (protos[which] + noise) % 2, which, protos


@pytest.fixture(autouse=True)
def _one_thread():
    with single_thread():
        yield


def test_conditionals_are_the_standard_ones():
    rbm = RBM(5, 3, seed=1)
    with torch.no_grad():
        rbm.b.copy_(torch.tensor([0.1, -0.2, 0.3, 0.0, 0.5]))
        rbm.c.copy_(torch.tensor([-0.1, 0.2, 0.05]))
    v = torch.tensor([[1.0, 0.0, 1.0, 1.0, 0.0]])
    h = torch.tensor([[0.0, 1.0, 1.0]])
    W, b, c = rbm.W.detach(), rbm.b.detach(), rbm.c.detach()
    assert torch.allclose(rbm.hidden_probs(v), torch.sigmoid(c + v @ W))
    assert torch.allclose(rbm.visible_probs(h), torch.sigmoid(b + h @ W.T))
    # F(v) = -log sum_h exp(-E(v, h)), by brute force over the 8 hidden states.
    hs = torch.tensor([[(i >> k) & 1 for k in range(3)] for i in range(8)], dtype=torch.float32)
    energies = -(v @ b) - hs @ c - (v @ W @ hs.T).squeeze(0)
    assert torch.allclose(rbm.free_energy(v), -torch.logsumexp(-energies, dim=0), atol=1e-5)


@pytest.mark.parametrize("k", [1, 3])
def test_cd_k_reduces_reconstruction_error(k):
    data, _, _ = _prototypes()
    rbm = RBM(36, 16, seed=0)
    before = rbm.reconstruction_error(data)
    history = rbm.fit(data, epochs=15, k=k, lr=0.1, seed=0)
    assert len(history) == 15
    assert history[-1] < 0.5 * before
    assert history[-1] < history[0]


def test_free_energy_lower_for_training_patterns_than_noise():
    data, _, _ = _prototypes()
    rbm = RBM(36, 16, seed=0)
    rbm.fit(data, epochs=15, lr=0.1, seed=0)
    noise = (torch.rand(400, 36, generator=torch.Generator().manual_seed(9)) < 0.5).float()
    with torch.no_grad():
        assert rbm.free_energy(data).mean() < rbm.free_energy(noise).mean() - 5.0
        # Nearly every training pattern is more probable than nearly every noise pattern.
        assert rbm.free_energy(data).quantile(0.95) < rbm.free_energy(noise).quantile(0.05)


def test_persistent_cd_learns_and_samples_resemble_the_data():
    data, _, protos = _prototypes()
    rbm = RBM(36, 16, seed=0)
    history = rbm.fit(data, epochs=20, lr=0.05, persistent=True, seed=0)
    assert np.isfinite(history).all() and history[-1] < history[0]
    samples = rbm.sample(50, steps=300, seed=3)
    assert samples.shape == (50, 36) and torch.all((samples == 0) | (samples == 1))
    # Samples lie near a prototype (a few bits off), noise would be ~18 bits off.
    dist = torch.cdist(samples, protos, p=1).min(dim=1).values
    assert dist.median() <= 6


def test_training_is_reproducible():
    data, _, _ = _prototypes(n=100)
    a, b = RBM(36, 8, seed=2), RBM(36, 8, seed=2)
    a.fit(data, epochs=3, seed=5)
    b.fit(data, epochs=3, seed=5)
    assert torch.equal(a.W, b.W)


def test_progress_is_reported():
    data, _, _ = _prototypes(n=64)
    seen = []
    RBM(36, 4).fit(data, epochs=4, progress=seen.append)
    assert seen == [0.25, 0.5, 0.75, 1.0]


def test_classifier_by_free_energy():
    data, which, _ = _prototypes(n=600, flip=0.08)
    labels = (which >= 2).long()  # two prototypes per class
    clf = RBMClassifier(36, 16, seed=0)
    losses = clf.fit(data[:400], labels[:400], epochs=15, seed=0)
    assert losses[-1] < losses[0]
    pred = (clf.log_odds(data[400:]) > 0).long()
    assert (pred != labels[400:]).float().mean() < 0.05


def test_generative_only_classifier_also_works():
    data, which, _ = _prototypes(n=600, flip=0.05)
    labels = (which >= 2).long()
    clf = RBMClassifier(36, 16, seed=0)
    clf.fit(data[:400], labels[:400], epochs=20, discriminative=0.0, lr=0.1, seed=0)
    pred = (clf.log_odds(data[400:]) > 0).long()
    assert (pred != labels[400:]).float().mean() < 0.1


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"epochs": 0}, "epochs"),
        ({"k": 0}, "k"),
        ({"batch_size": -1}, "batch_size"),
        ({"lr": 0.0}, "lr"),
    ],
)
def test_bad_training_options(kwargs, name):
    data, _, _ = _prototypes(n=10)
    with pytest.raises(ValueError, match=name):
        RBM(36, 4).fit(data, **kwargs)


def test_bad_data():
    rbm = RBM(36, 4)
    with pytest.raises(ValueError, match="columns"):
        rbm.fit(torch.zeros(10, 35))
    with pytest.raises(ValueError, match="data"):
        rbm.fit(torch.full((10, 36), 2.0))
    with pytest.raises(ValueError, match="data"):
        rbm.fit(torch.zeros(0, 36))
    with pytest.raises(ValueError, match="n_hidden"):
        RBM(36, 0)
    clf = RBMClassifier(36, 4)
    with pytest.raises(ValueError, match="labels"):
        clf.fit(torch.zeros(10, 36), torch.zeros(9))
    with pytest.raises(ValueError, match="labels"):
        clf.fit(torch.zeros(10, 36), torch.full((10,), 3))
    with pytest.raises(ValueError, match="n_classes"):
        RBMClassifier(36, 4, n_classes=1)
