"""The scenario runner: its JSON, its draws, its command line, and a short real scenario."""

from __future__ import annotations

import json
import math

import pytest

from bench.scenarios.__main__ import main
from bench.scenarios.land import ON_PAD_M, PAD_NE, RunResult, RunSpec, summarize
from bench.scenarios.lockstep import LockstepLink

KEYS = {
    "strategy",
    "runs",
    "success_rate",
    "touchdown_error_m",
    "heading_error_deg",
    "time_to_land_s",
    "frames",
    "detections",
}


def result(error, outcome="landed", heading=0.5, t=20.0) -> RunResult:
    spec = RunSpec.draw(1, 0, "plnd", 3.0)
    return RunResult(spec, outcome, "", error, heading, t, 100, 80, 1.0)


def test_summary_has_exactly_the_keys_and_the_statistics():
    errors = [0.01 * i for i in range(1, 11)]  # 1..10 cm
    runs = [result(e, heading=i * 0.1, t=10.0 + i) for i, e in enumerate(errors)]
    runs.append(result(None, outcome="aborted", heading=None, t=None))
    s = summarize("plnd", runs)
    assert set(s) == KEYS
    assert set(s["touchdown_error_m"]) == {"median", "p95", "max"}
    assert set(s["heading_error_deg"]) == {"median", "max"}
    assert set(s["time_to_land_s"]) == {"median", "max"}
    assert s["runs"] == 11 and s["strategy"] == "plnd"
    assert s["success_rate"] == round(10 / 11, 4)
    assert s["touchdown_error_m"]["median"] == pytest.approx(0.055)
    assert s["touchdown_error_m"]["p95"] == pytest.approx(0.0955)
    assert s["touchdown_error_m"]["max"] == pytest.approx(0.10)
    assert s["heading_error_deg"]["max"] == pytest.approx(0.9)
    assert s["time_to_land_s"]["median"] == pytest.approx(14.5)
    assert s["frames"] == 1100 and s["detections"] == 880
    json.dumps(s)  # plain JSON


def test_a_landing_off_the_pad_is_not_a_success():
    assert result(ON_PAD_M * 0.99).success
    assert not result(ON_PAD_M * 1.01).success
    assert not result(None, outcome="aborted").success
    s = summarize("guided", [result(None, outcome="failed")])
    assert s["success_rate"] == 0.0 and s["touchdown_error_m"]["median"] is None


def test_draws_are_in_range_and_repeatable():
    specs = [RunSpec.draw(7, i, "guided", 3.0) for i in range(200)]
    assert specs[3] == RunSpec.draw(7, 3, "guided", 3.0)
    assert specs[3] != RunSpec.draw(8, 3, "guided", 3.0)
    for s in specs:
        off = math.hypot(s.start_north_m - PAD_NE[0], s.start_east_m - PAD_NE[1])
        assert 1.0 <= off <= 3.0
        assert 4.0 <= s.start_alt_m <= 8.0
        assert 0.0 <= s.wind_mps <= 3.0 and 0.0 <= s.gust_mps <= 0.3 * s.wind_mps + 1e-12
        assert 15.0 <= s.snr_db <= 30.0
        assert 0.0 <= s.pad_heading_deg < 360.0


@pytest.mark.parametrize(
    "argv",
    [
        ["land", "--runs", "0"],
        ["land", "--wind", "-1"],
        ["land", "--wind", "40"],
        ["land", "--camera-hz", "0.1"],
    ],
)
def test_command_line_refuses_bad_numbers(argv, capsys):
    assert main(argv) == 2
    assert "must be within" in capsys.readouterr().err


def test_command_line_refuses_an_unknown_strategy():
    with pytest.raises(SystemExit) as exc:
        main(["land", "--strategy", "autoland"])
    assert exc.value.code == 2


def test_lockstep_link_wants_a_lockstep_server():
    class FreeRunning:
        lockstep = False

    with pytest.raises(ValueError, match="lockstep"):
        LockstepLink(object(), FreeRunning())


@pytest.mark.slow
def test_short_scenario_prints_the_json_and_is_the_same_twice(capsys):
    argv = ["land", "--runs", "1", "--seed", "3", "--strategy", "guided", "--wind", "1", "--json"]
    assert main(argv) == 0
    first = capsys.readouterr().out
    summary = json.loads(first)
    assert set(summary) == KEYS
    assert summary["runs"] == 1 and summary["success_rate"] == 1.0
    assert summary["touchdown_error_m"]["max"] < 0.10
    assert summary["heading_error_deg"]["max"] < 2.0
    assert 0 < summary["detections"] <= summary["frames"]
    # Lockstep: the same seed flies the same flight.
    assert main(argv) == 0
    assert capsys.readouterr().out == first


@pytest.mark.slow
def test_mavlink_url_flies_any_vehicle_in_real_time():
    """``--mavlink``: the same mission against a vehicle that runs by itself (here the
    stand-in, free-running in real time, as ArduCopter SITL would), the camera rendered
    from telemetry, the touchdown measured from telemetry."""
    from bench.scenarios.land import run_one
    from sim.vehicle import SimConfig, SimVehicle, VehicleServer

    spec = RunSpec(0, 5, "guided", 20.0, PAD_NE[0] + 1.0, 0.5, 3.5, 30.0, 1.0, 90.0, 0.2, 25.0)
    sim = SimVehicle(
        SimConfig(
            seed=5,
            ready_after_scale=0.02,
            pad_north=PAD_NE[0],
            pad_east=PAD_NE[1],
            pad_heading_deg=spec.pad_heading_deg,
            wind_mps=1.0,
        )
    )
    with VehicleServer(sim, "tcp:127.0.0.1:0") as server:
        result = run_one(spec, url=server.address)
    assert result.outcome == "landed", result.message
    assert "(telemetry)" in result.message
    assert result.touchdown_error_m < 0.10
    assert sim.landed_at is not None
    assert math.dist(sim.landed_at, PAD_NE) < 0.15  # the truth agrees


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--vehicle", "sitl", "--mavlink", "tcp:127.0.0.1:5760"], "no --mavlink"),
        (["--vehicle", "sitl", "--flight-speedup", "0"], "--flight-speedup must be within"),
        (["--setup-speedup", "99"], "--setup-speedup must be within"),
    ],
)
def test_bad_vehicle_options_are_refused_before_anything_starts(extra, says, capsys):
    assert main(["land", "--runs", "1", *extra]) == 2
    assert says in capsys.readouterr().err
