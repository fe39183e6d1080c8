"""A Bernoulli-Bernoulli Restricted Boltzmann Machine, trained by CD-k or persistent CD.

Energy E(v, h) = -b.v - c.h - v.W.h with binary v (visible) and h (hidden); the
conditionals are the standard ones (the seed's eq. D.6 is wrong):
P(h=1 | v) = sigmoid(c + W^T v), P(v=1 | h) = sigmoid(b + W h).
Free energy F(v) = -b.v - sum_j softplus(c_j + (W^T v)_j), so P(v) ~ exp(-F(v)).

`RBMClassifier` is the same machine with the class label as extra (one-hot)
visible units, trained on the joint (pattern, label) and read out exactly by
free energy: P(y | v) = softmax_y(-F(v, y)).

Examples
--------
>>> import torch
>>> g = torch.Generator().manual_seed(0)
>>> data = (torch.rand(64, 6, generator=g) < 0.5).float()
>>> rbm = RBM(6, 4, seed=0)
>>> history = rbm.fit(data, epochs=3, seed=0)
>>> len(history), rbm.free_energy(data).shape
(3, torch.Size([64]))
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import contextmanager

import torch
from torch import nn
from torch.nn import functional as F

Progress = Callable[[float], None]


@contextmanager
def single_thread():
    """Run torch on one thread (reproducible sums, a usable 2-core machine), then restore."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def as_tensor(data, name: str = "data") -> torch.Tensor:
    """A finite float32 2-D tensor with values in [0, 1], or ValueError naming ``name``."""
    t = torch.as_tensor(data, dtype=torch.float32)
    if t.ndim != 2 or t.shape[0] == 0 or t.shape[1] == 0:
        raise ValueError(f"{name} must be a non-empty 2-D array, got shape {tuple(t.shape)}")
    if not torch.isfinite(t).all() or t.min() < 0 or t.max() > 1:
        raise ValueError(f"{name} must hold probabilities in [0, 1]")
    return t


def _check_positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return value


class RBM(nn.Module):
    """Bernoulli RBM with ``n_visible`` and ``n_hidden`` binary units."""

    def __init__(self, n_visible: int, n_hidden: int, *, seed: int = 0) -> None:
        super().__init__()
        _check_positive_int(n_visible, "n_visible")
        _check_positive_int(n_hidden, "n_hidden")
        g = torch.Generator().manual_seed(seed)
        self.W = nn.Parameter(0.01 * torch.randn(n_visible, n_hidden, generator=g))
        self.b = nn.Parameter(torch.zeros(n_visible))
        self.c = nn.Parameter(torch.zeros(n_hidden))

    @property
    def n_visible(self) -> int:
        return self.W.shape[0]

    @property
    def n_hidden(self) -> int:
        return self.W.shape[1]

    def hidden_probs(self, v: torch.Tensor) -> torch.Tensor:
        """P(h=1 | v) = sigmoid(c + W^T v), row-wise."""
        return torch.sigmoid(self.c + v @ self.W)

    def visible_probs(self, h: torch.Tensor) -> torch.Tensor:
        """P(v=1 | h) = sigmoid(b + W h), row-wise."""
        return torch.sigmoid(self.b + h @ self.W.T)

    def free_energy(self, v: torch.Tensor) -> torch.Tensor:
        """F(v) per row; lower means more probable under the model."""
        return -(v @ self.b) - F.softplus(self.c + v @ self.W).sum(dim=1)

    def gibbs(self, v: torch.Tensor, k: int, generator: torch.Generator) -> torch.Tensor:
        """``k`` steps of block Gibbs sampling v -> h -> v, starting from ``v``."""
        for _ in range(k):
            h = torch.bernoulli(self.hidden_probs(v), generator=generator)
            v = torch.bernoulli(self.visible_probs(h), generator=generator)
        return v

    @torch.no_grad()
    def sample(self, n: int, *, steps: int = 200, seed: int = 0) -> torch.Tensor:
        """``n`` visible samples from ``steps`` Gibbs steps started at uniform noise."""
        g = torch.Generator().manual_seed(seed)
        v = torch.bernoulli(torch.full((n, self.n_visible), 0.5), generator=g)
        return self.gibbs(v, steps, g)

    @torch.no_grad()
    def reconstruction_error(self, v: torch.Tensor) -> float:
        """Mean squared error of the mean-field reconstruction v -> P(h|v) -> P(v|h)."""
        v = as_tensor(v)
        return float(((self.visible_probs(self.hidden_probs(v)) - v) ** 2).mean())

    def fit(
        self,
        data,
        *,
        epochs: int = 20,
        lr: float = 0.1,
        k: int = 1,
        persistent: bool = False,
        batch_size: int = 64,
        momentum: float = 0.5,
        weight_decay: float = 1e-4,
        seed: int = 0,
        progress: Progress | None = None,
    ) -> list[float]:
        """Train by contrastive divergence (CD-k) or persistent CD; return per-epoch recon. error.

        Parameters
        ----------
        data : (n, n_visible) binary (or [0, 1]) patterns.
        persistent : keep the negative chains between updates (PCD, Tieleman 2008)
            instead of restarting them at the data (CD).
        progress : called with the fraction done after each epoch.
        """
        v_all = as_tensor(data)
        if v_all.shape[1] != self.n_visible:
            raise ValueError(f"data must have {self.n_visible} columns, got {v_all.shape[1]}")
        _check_positive_int(epochs, "epochs")
        _check_positive_int(k, "k")
        _check_positive_int(batch_size, "batch_size")
        if not (math.isfinite(lr) and lr > 0):
            raise ValueError(f"lr must be a positive number, got {lr!r}")
        g = torch.Generator().manual_seed(seed)
        # Start the visible biases at the data's log-odds (Hinton's practical guide).
        with torch.no_grad():
            p = v_all.mean(dim=0).clamp(1e-3, 1 - 1e-3)
            self.b.copy_(torch.log(p / (1 - p)))
        opt = torch.optim.SGD(self.parameters(), lr=lr, momentum=momentum)
        chains = None
        history = []
        for epoch in range(epochs):
            order = torch.randperm(len(v_all), generator=g)
            for start in range(0, len(v_all), batch_size):
                v0 = v_all[order[start : start + batch_size]]
                if persistent:
                    chains = self._negative(v0 if chains is None else chains, k, g)
                    vk = chains
                else:
                    vk = self._negative(v0, k, g)
                opt.zero_grad()
                self.set_cd_gradient(v0, vk, weight_decay)
                opt.step()
            history.append(self.reconstruction_error(v_all))
            if progress is not None:
                progress((epoch + 1) / epochs)
        return history

    @torch.no_grad()
    def _negative(self, v: torch.Tensor, k: int, g: torch.Generator) -> torch.Tensor:
        if not torch.all((v == 0) | (v == 1)):
            v = torch.bernoulli(v, generator=g)
        return self.gibbs(v, k, g)

    @torch.no_grad()
    def set_cd_gradient(self, v0: torch.Tensor, vk: torch.Tensor, weight_decay: float) -> None:
        """Put minus the CD estimate of d log-likelihood into .grad (added to any there)."""
        h0 = self.hidden_probs(v0)
        hk = self.hidden_probs(vk)
        n0, nk = len(v0), len(vk)
        grads = {
            self.W: -(v0.T @ h0 / n0 - vk.T @ hk / nk) + weight_decay * self.W,
            self.b: -(v0.mean(0) - vk.mean(0)),
            self.c: -(h0.mean(0) - hk.mean(0)),
        }
        for param, grad in grads.items():
            param.grad = grad if param.grad is None else param.grad + grad


class RBMClassifier(nn.Module):
    """An RBM over (pattern, one-hot label), classified by free energy.

    Trained on the joint distribution by CD-k (generative) plus, with weight
    ``discriminative``, the exact gradient of log P(y | v) (Larochelle and
    Bengio's hybrid RBM); both use the same free energy.
    """

    def __init__(self, n_visible: int, n_hidden: int = 100, *, n_classes: int = 2, seed: int = 0):
        super().__init__()
        _check_positive_int(n_classes, "n_classes")
        if n_classes < 2:
            raise ValueError(f"n_classes must be at least 2, got {n_classes}")
        self.n_classes = n_classes
        self.rbm = RBM(n_visible + n_classes, n_hidden, seed=seed)

    def class_free_energies(self, v: torch.Tensor) -> torch.Tensor:
        """(n, n_classes): F(v, y) for every label y."""
        nv = self.rbm.n_visible - self.n_classes
        W_v, W_y = self.rbm.W[:nv], self.rbm.W[nv:]
        b_v, b_y = self.rbm.b[:nv], self.rbm.b[nv:]
        pre = self.rbm.c + v @ W_v  # (n, hidden)
        act = pre[:, None, :] + W_y[None, :, :]  # (n, classes, hidden)
        return -(v @ b_v)[:, None] - b_y[None, :] - F.softplus(act).sum(dim=2)

    def log_odds(self, v) -> torch.Tensor:
        """log P(y=1|v) - log P(y=0|v) = F(v, 0) - F(v, 1) (two classes)."""
        with torch.no_grad():
            fe = self.class_free_energies(as_tensor(v, "v"))
        return fe[:, 0] - fe[:, 1]

    def fit(
        self,
        data,
        labels,
        *,
        epochs: int = 30,
        lr: float = 0.05,
        k: int = 1,
        persistent: bool = False,
        discriminative: float = 1.0,
        batch_size: int = 64,
        weight_decay: float = 1e-4,
        seed: int = 0,
        progress: Progress | None = None,
    ) -> list[float]:
        """Train on ``data`` (n, n_visible) and integer ``labels`` (n,); return per-epoch loss."""
        v_all = as_tensor(data)
        y_all = torch.as_tensor(labels, dtype=torch.int64)
        if y_all.shape != (len(v_all),):
            raise ValueError(f"labels must have shape ({len(v_all)},), got {tuple(y_all.shape)}")
        if y_all.min() < 0 or y_all.max() >= self.n_classes:
            raise ValueError(f"labels must be in 0..{self.n_classes - 1}")
        _check_positive_int(epochs, "epochs")
        _check_positive_int(batch_size, "batch_size")
        g = torch.Generator().manual_seed(seed)
        joint = torch.cat([v_all, F.one_hot(y_all, self.n_classes).float()], dim=1)
        rbm = self.rbm
        with torch.no_grad():
            p = joint.mean(dim=0).clamp(1e-3, 1 - 1e-3)
            rbm.b.copy_(torch.log(p / (1 - p)))
        opt = torch.optim.SGD(rbm.parameters(), lr=lr, momentum=0.5)
        chains = None
        history = []
        for epoch in range(epochs):
            order = torch.randperm(len(joint), generator=g)
            total = 0.0
            for start in range(0, len(joint), batch_size):
                idx = order[start : start + batch_size]
                v0 = joint[idx]
                if persistent:
                    chains = rbm._negative(v0 if chains is None else chains, k, g)
                    vk = chains
                else:
                    vk = rbm._negative(v0, k, g)
                opt.zero_grad()
                loss = F.cross_entropy(-self.class_free_energies(v_all[idx]), y_all[idx])
                if discriminative > 0:
                    (discriminative * loss).backward()
                rbm.set_cd_gradient(v0, vk, weight_decay)
                opt.step()
                total += float(loss.detach()) * len(idx)
            history.append(total / len(joint))
            if progress is not None:
                progress((epoch + 1) / epochs)
        return history
