"""``python -m bench.scenarios land --vehicle sitl``: genuine ArduCopter SITL of its own
per run, from a fresh boot, the camera and the touchdown from the simulator's truth."""

from __future__ import annotations

import json

import pytest

from bench.scenarios.__main__ import main
from tests.sitl.support import requires_sitl

pytestmark = [pytest.mark.sitl, requires_sitl]


@pytest.mark.parametrize("strategy", ["plnd", "guided"])
def test_one_run_from_a_fresh_boot_lands_on_the_pad(strategy: str, capsys) -> None:
    argv = ["land", "--vehicle", "sitl", "--runs", "1", "--seed", "4", "--strategy", strategy]
    assert main([*argv, "--json"]) == 0, capsys.readouterr().err
    summary = json.loads(capsys.readouterr().out)
    assert summary["runs"] == 1 and summary["success_rate"] == 1.0
    run = summary["per_run"][0]
    assert run["outcome"] == "landed" and run["touchdown_source"] == "truth"
    assert run["touchdown_error_m"] < 0.10 and run["heading_error_deg"] < 2.0
    if strategy == "plnd":
        assert run["precland"] == "accepted" and summary["precland_accepted"] == 1
        assert run["precland_texts"][0] == "PrecLand: Target Found"
    else:
        assert run["precland"] is None
