"""The station trains the active reference's pattern verifier and uses it once ready."""

from __future__ import annotations

import time

import numpy as np
import pytest

from backend.settings import Settings
from backend.station import build_station
from pipeline import Camera
from pipeline.render import camera_rotation, make_scene, render


def _wait(predicate, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.1)
    raise AssertionError("condition not met in time")


def _settings(tmp_path, views: int) -> Settings:
    return Settings(
        data_dir=tmp_path,
        token="station-test-token",
        viser_port=0,
        sim_ready_after=0.1,
        verifier_views=views,
    )


def test_verifier_training_is_off_when_asked(tmp_path):
    station = build_station(_settings(tmp_path, 0))
    station.start()
    try:
        verifier = station.references.active_summary()["verifier"]
        assert verifier["state"] == "off"
        assert station.references.trainer.verifier(station.references.active.id) is None
    finally:
        station.stop()


@pytest.mark.slow
def test_the_default_pad_gets_a_verifier_that_is_used_and_kept(tmp_path):
    station = build_station(_settings(tmp_path, 40))
    station.start()
    try:
        ref_id = station.references.active.id
        _wait(lambda: station.references.active_summary()["verifier"]["state"] == "ready", 180)
        assert (tmp_path / "references" / str(ref_id) / "verifier" / "verifier.json").is_file()
        assert station.references.trainer.verifier(ref_id) is not None
        # the event follows the state (the trainer's listener tells it just after)
        _wait(
            lambda: any(
                f"reference {ref_id}: ready" in e["text"] for e in station.events.recent(50)
            ),
            30,
        )
        # Frames now go through the verifier before the pose.
        reference = station.references.active.reference
        camera = Camera.from_fov(640, 480, 60.0)
        scene = make_scene(reference.image, reference.pad_size_m, rng=np.random.default_rng(0))
        frame = render(scene, camera, np.array([0.1, 0.0, 2.5]), camera_rotation(20.0))
        result = station.references.process(frame, reference, camera, yaw_hint=20.0)
        assert result.detected and "verify" in result.timings_ms
    finally:
        station.stop()
    # The next start loads it instead of training again.
    again = build_station(_settings(tmp_path, 40))
    again.start()
    try:
        verifier = again.references.active_summary()["verifier"]
        assert verifier["state"] == "ready" and verifier["detail"] == "loaded"
    finally:
        again.stop()
