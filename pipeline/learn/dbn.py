"""A Deep Belief Network: two stacked 100-unit RBMs and a classifier on top (seed fig. 5.7).

Greedy layer-wise (Hinton, Osindero and Teh 2006): the first RBM learns the
visible patterns, the second learns the first's hidden probabilities; neither
sees a label. A logistic regression on the top hidden probabilities then reads
out the class, and a short fine-tuning pass trains the whole stack as a sigmoid
network on the labels (the RBMs are its initialisation).

Examples
--------
>>> import torch
>>> g = torch.Generator().manual_seed(0)
>>> x = (torch.rand(200, 16, generator=g) < 0.5).float()
>>> y = (x[:, :8].sum(1) > x[:, 8:].sum(1)).long()
>>> dbn = DBN(16, (20, 20), seed=0)
>>> _ = dbn.fit(x, y, pretrain_epochs=2, classifier_epochs=5, fine_tune_epochs=5)
>>> dbn.predict_proba(x).shape
torch.Size([200])
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import torch
from torch import nn
from torch.nn import functional as F

from pipeline.learn.rbm import RBM, Progress, as_tensor

HIDDEN = (100, 100)


class DBN(nn.Module):
    """Stacked RBMs (``hidden`` units per layer) and a logistic read-out for two classes."""

    def __init__(self, n_visible: int, hidden: Sequence[int] = HIDDEN, *, seed: int = 0) -> None:
        super().__init__()
        hidden = tuple(hidden)
        if not hidden:
            raise ValueError("hidden must name at least one layer size")
        sizes = (n_visible, *hidden)
        self.layers = nn.ModuleList(
            RBM(a, b, seed=seed + i) for i, (a, b) in enumerate(itertools.pairwise(sizes))
        )
        self.head = nn.Linear(hidden[-1], 1)
        with torch.no_grad():
            self.head.weight.zero_()
            self.head.bias.zero_()

    @property
    def hidden(self) -> tuple[int, ...]:
        return tuple(layer.n_hidden for layer in self.layers)

    def features(self, v: torch.Tensor) -> torch.Tensor:
        """The top layer's hidden probabilities (mean-field up pass)."""
        for layer in self.layers:
            v = layer.hidden_probs(v)
        return v

    def logits(self, v: torch.Tensor) -> torch.Tensor:
        """log-odds of class 1 per row."""
        return self.head(self.features(v)).squeeze(1)

    def predict_proba(self, v) -> torch.Tensor:
        """P(class 1 | v) per row."""
        with torch.no_grad():
            return torch.sigmoid(self.logits(as_tensor(v, "v")))

    def fit(
        self,
        data,
        labels,
        *,
        pretrain_epochs: int = 15,
        classifier_epochs: int = 60,
        fine_tune_epochs: int = 20,
        lr: float = 0.1,
        k: int = 1,
        persistent: bool = False,
        batch_size: int = 64,
        seed: int = 0,
        progress: Progress | None = None,
    ) -> dict[str, list[float]]:
        """Greedy pre-training, then the read-out, then fine-tuning; returns the loss curves.

        Parameters
        ----------
        data : (n, n_visible) binary patterns; labels : (n,) 0/1.
        fine_tune_epochs : 0 keeps the RBMs as pre-trained (the read-out alone is learned).
        """
        x = as_tensor(data)
        y = torch.as_tensor(labels, dtype=torch.float32)
        if y.shape != (len(x),) or not torch.all((y == 0) | (y == 1)):
            raise ValueError(f"labels must be {len(x)} values, each 0 or 1")
        stages = len(self.layers) + 2
        done = [0]

        def stage_progress(frac: float) -> None:
            if progress is not None:
                progress((done[0] + frac) / stages)

        curves: dict[str, list[float]] = {}
        v = x
        for i, layer in enumerate(self.layers):
            curves[f"rbm{i + 1}"] = layer.fit(
                v,
                epochs=pretrain_epochs,
                lr=lr,
                k=k,
                persistent=persistent,
                batch_size=batch_size,
                seed=seed + i,
                progress=stage_progress,
            )
            done[0] += 1
            with torch.no_grad():
                v = layer.hidden_probs(v)
        # The read-out on frozen features, then everything together.
        curves["classifier"] = _train(
            self.head.parameters(),
            lambda idx: self.head(v[idx]).squeeze(1),
            y,
            classifier_epochs,
            seed,
            batch_size,
            stage_progress,
        )
        done[0] += 1
        if fine_tune_epochs > 0:
            curves["fine_tune"] = _train(
                self.parameters(),
                lambda idx: self.logits(x[idx]),
                y,
                fine_tune_epochs,
                seed + 100,
                batch_size,
                stage_progress,
                lr=1e-3,
            )
        done[0] += 1
        stage_progress(0.0)
        return curves


def _train(params, logits_of, y, epochs, seed, batch_size, progress, lr=1e-2) -> list[float]:
    """Adam on the binary cross-entropy of ``logits_of(batch indices)``; per-epoch mean loss."""
    opt = torch.optim.Adam(params, lr=lr, weight_decay=1e-5)
    g = torch.Generator().manual_seed(seed)
    n = len(y)
    # Classes are unbalanced (more negatives than H's); weigh them equally.
    pos = float(y.sum())
    pos_weight = torch.tensor((n - pos) / pos if pos > 0 else 1.0)
    history = []
    for epoch in range(epochs):
        order = torch.randperm(n, generator=g)
        total = 0.0
        for start in range(0, n, batch_size):
            idx = order[start : start + batch_size]
            opt.zero_grad()
            loss = F.binary_cross_entropy_with_logits(logits_of(idx), y[idx], pos_weight=pos_weight)
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
        history.append(total / n)
        progress((epoch + 1) / epochs)
    return history
