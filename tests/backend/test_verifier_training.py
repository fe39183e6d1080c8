import dataclasses
import threading
import time

import pytest

from backend.verifier_training import VerifierTrainer
from pipeline import Reference
from pipeline.render import make_pad_image


@pytest.fixture(scope="module")
def reference():
    return Reference.from_image(make_pad_image(800), 0.55)


class _Log:
    def __init__(self) -> None:
        self.items = []
        self.changed = threading.Event()

    def __call__(self, ref_id, status) -> None:
        self.items.append((ref_id, status))
        self.changed.set()


def _wait_state(trainer, ref_id, states, timeout=120.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if trainer.status(ref_id).state in states:
            return trainer.status(ref_id)
        time.sleep(0.1)
    raise AssertionError(f"still {trainer.status(ref_id)} after {timeout} s")


def test_training_off_leaves_the_pipeline_without_a_verifier(tmp_path, reference):
    log = _Log()
    trainer = VerifierTrainer(lambda i: tmp_path / str(i), views=0, on_change=log)
    trainer.request(1, reference)
    assert trainer.status(1).state == "off"
    assert trainer.verifier(1) is None
    assert log.items[-1][1].state == "off"
    trainer.close()


@pytest.mark.slow
def test_trains_saves_and_loads_again(tmp_path, reference):
    log = _Log()
    folder = lambda i: tmp_path / str(i)  # noqa: E731
    trainer = VerifierTrainer(folder, views=40, epochs=4, on_change=log)
    trainer.request(7, reference)
    status = _wait_state(trainer, 7, {"ready", "failed", "unavailable"})
    trainer.close()
    assert status.state == "ready", status.detail
    assert trainer.verifier(7) is not None
    states = [s.state for i, s in log.items if i == 7]
    assert states[0] == "queued" and "training" in states and states[-1] == "ready"
    assert any(0 < s.progress < 1 for i, s in log.items if s.state == "training")
    assert (tmp_path / "7" / "verifier" / "verifier.json").is_file()
    # A new start loads the saved verifier instead of training again.
    again = VerifierTrainer(folder, views=40)
    again.request(7, reference)
    assert again.status(7).state == "ready" and again.status(7).detail == "loaded"
    assert again.verifier(7).threshold == trainer.verifier(7).threshold
    again.close()


def test_a_poor_reference_turns_the_verifier_off_with_a_reason(tmp_path, reference):
    tiny = dataclasses.replace(reference, pad_size_m=reference.pad_size_m * 12)
    trainer = VerifierTrainer(lambda i: tmp_path / str(i), views=5)
    trainer.request(3, tiny)
    status = _wait_state(trainer, 3, {"unavailable", "failed", "ready"}, timeout=30)
    trainer.close()
    assert status.state == "unavailable"
    assert "too small" in status.detail
    assert trainer.verifier(3) is None


def test_close_stops_a_training_run(tmp_path, reference):
    trainer = VerifierTrainer(lambda i: tmp_path / str(i), views=500)
    trainer.request(1, reference)
    _wait_state(trainer, 1, {"training"}, timeout=30)
    trainer.close(timeout=60)  # 500 views would take minutes: close stops them
    assert not any(t.name == "verifier-training" and t.is_alive() for t in threading.enumerate())
