"""The fuzz and abuse program, short: a few hundred inputs of each kind, every bar held.

The full run (``python -m bench.fuzz``, 10,000 of each) is reported in the README.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from bench.fuzz import KINDS, fuzz

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("kind", KINDS)
def test_a_short_fuzz_finds_nothing(kind):
    out = fuzz(300, kinds=[kind], seed=1)
    result = out[kind]
    assert result["inputs"] == 300
    assert result["unhandled_exceptions"] == 0, result["samples"]
    assert result.get("status_5xx", 0) == 0, result
    assert out["bars_met"]
    if kind == "mavlink":
        assert result["still_parsing"] and result["impossible_values_shown"] == 0
        assert result["implausible_dropped"] > 0
    if kind in ("uploads", "bodies", "websocket"):
        assert result["server_alive"]
    if kind == "uploads":
        bombs = result["bombs"]
        assert bombs["all_4xx"] and set(bombs["cases"]) >= {"png_100000", "tiff_100000"}


def test_the_program_prints_json():
    out = subprocess.run(
        [sys.executable, "-m", "bench.fuzz", "--n", "50", "--kinds", "mavlink"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["bars_met"] and result["mavlink"]["inputs"] == 50
