"""The link benchmark program runs and reports what it measured (no timing asserted)."""

from __future__ import annotations

import json

from bench import link as bench


def test_bench_reports_json(capsys) -> None:
    assert bench.main(["--messages", "300", "--commands", "5", "--latency-samples", "20"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["receive"]["messages"] == 300 and out["receive"]["msgs_per_s"] > 0
    assert out["command_round_trip_ms"]["samples"] == 5
    assert out["telemetry_latency_ms"]["samples"] == 20
    assert out["crc_errors"] == 0
