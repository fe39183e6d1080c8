"""``python -m pipeline.learn bench --json``: one JSON object with exactly the agreed keys."""

import json
import subprocess
import sys

import pytest

from pipeline.learn.__main__ import main

KEYS = {"rbm_error", "dbn_error", "knn_hu_error", "train_s", "verifier"}
VERIFIER_KEYS = {"detection_with", "detection_without", "fp_with", "fp_without"}


def _run(*args, timeout=240):
    return subprocess.run(
        [sys.executable, "-m", "pipeline.learn", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


@pytest.mark.slow
def test_bench_prints_the_exact_keys():
    proc = _run("bench", "--json", "--quick", "--seed", "3")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert set(result) == KEYS
    assert set(result["verifier"]) == VERIFIER_KEYS
    for key in ("rbm_error", "dbn_error", "knn_hu_error"):
        assert 0.0 <= result[key] <= 1.0
    assert result["train_s"] > 0
    assert all(0.0 <= v <= 1.0 for v in result["verifier"].values())
    # The verifier only ever removes candidates.
    assert result["verifier"]["fp_with"] <= result["verifier"]["fp_without"]
    assert result["verifier"]["detection_with"] <= result["verifier"]["detection_without"]
    # Not a terminal: no progress bar on stderr.
    assert "it/s" not in proc.stderr and "%|" not in proc.stderr


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["nonsense"], "invalid choice"), (["bench", "--seed", "x"], "--seed"), ([], "command")],
)
def test_bad_command_line(capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err
