"""Shared test setup."""

import pytest


@pytest.fixture(autouse=True)
def _no_verifier_training_by_default(monkeypatch):
    # Training a reference's pattern verifier takes minutes of CPU; the tests that
    # are about it ask for it, the others (and the servers they start) go without.
    monkeypatch.setenv("VISLAND_VERIFIER_VIEWS", "0")
