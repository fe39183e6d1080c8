"""Shared test setup."""

import os

# Training a reference's pattern verifier takes minutes of CPU: the tests that are
# about it ask for it; the others, and the servers they start as subprocesses
# (which inherit this environment), go without.
os.environ.setdefault("VISLAND_VERIFIER_VIEWS", "0")
