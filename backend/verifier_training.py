"""Per-reference training of the corner-pattern verifier, in the background.

Each reference gets its own RBM/DBN verifier (``pipeline.learn``): trained on
synthetic views of that pad after it is uploaded, saved in the reference's
folder, loaded again at the next start. Training takes a minute or two of CPU,
so it runs on one low-priority thread, one reference at a time, newest request
first; until a verifier is ready (or when the reference is too poor to train
on) the pipeline runs without it, and detection keeps working.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from pipeline import Reference
from pipeline.learn import PoorReference, Verifier, train_verifier

log = logging.getLogger(__name__)

VERIFIER_FOLDER = "verifier"


@dataclass(frozen=True)
class VerifierStatus:
    """Where a reference's verifier stands.

    ``state``: "off" (training disabled), "queued", "training", "ready",
    "unavailable" (the reference is too poor to train on) or "failed".
    """

    state: str
    progress: float = 0.0
    detail: str = ""

    def to_dict(self) -> dict:
        return {"state": self.state, "progress": round(self.progress, 3), "detail": self.detail}


class _Cancelled(Exception):
    """Raised from the progress callback to stop a training run at shutdown."""


class VerifierTrainer:
    """Loads or trains one verifier per reference; ``verifier(id)`` is the hot path.

    ``views``: synthetic views per training (0 turns training off: references
    with a saved verifier still load). ``on_change`` is called with
    ``(ref_id, VerifierStatus)`` whenever a status changes (progress in steps
    of 5 %).
    """

    def __init__(
        self,
        folder_of: Callable[[int], Path],
        *,
        views: int,
        epochs: int = 15,
        on_change: Callable[[int, VerifierStatus], None] | None = None,
    ) -> None:
        self._folder_of = folder_of
        self._views = views
        self._epochs = epochs
        self._on_change = on_change
        self._verifiers: dict[int, Verifier] = {}
        self._status: dict[int, VerifierStatus] = {}
        self._pending: list[tuple[int, Reference]] = []
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._closing = False
        self._thread: threading.Thread | None = None

    # --- what the station asks -------------------------------------------------------------
    def verifier(self, ref_id: int | None) -> Verifier | None:
        """The ready verifier of a reference, or None (the pipeline then runs without)."""
        return None if ref_id is None else self._verifiers.get(ref_id)

    def status(self, ref_id: int) -> VerifierStatus:
        with self._lock:
            return self._status.get(ref_id, VerifierStatus("off" if not self._views else "queued"))

    def request(self, ref_id: int, reference: Reference) -> None:
        """Make a verifier for ``reference`` available: load the saved one, or train one."""
        saved = self._folder_of(ref_id) / VERIFIER_FOLDER
        if ref_id in self._verifiers:
            return
        if (saved / "verifier.json").is_file():
            try:
                self._verifiers[ref_id] = Verifier.load(saved)
                self._set(ref_id, VerifierStatus("ready", 1.0, "loaded"))
                return
            except (OSError, ValueError, KeyError, RuntimeError) as exc:
                log.warning(
                    "reference %s: saved verifier unreadable (%s); training again", ref_id, exc
                )
        if not self._views:
            self._set(ref_id, VerifierStatus("off", 0.0, "verifier training is turned off"))
            return
        with self._lock:
            if self._closing or any(r == ref_id for r, _ in self._pending):
                return
            current = self._status.get(ref_id)
            if current is not None and current.state in (
                "queued",
                "training",
                "unavailable",
                "failed",
            ):
                return
            self._status[ref_id] = VerifierStatus("queued")
        # "queued" is told before the training thread can see the request and move it on
        # (listeners hear the states in the order they happen, on a loaded machine too).
        self._emit(ref_id)
        with self._lock:
            if self._closing:
                return
            self._pending.append((ref_id, reference))
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._run, name="verifier-training", daemon=True
                )
                self._thread.start()
            self._wake.notify()

    def close(self, timeout: float = 5.0) -> None:
        """Stop training (the run in progress is abandoned at its next progress step)."""
        with self._lock:
            self._closing = True
            self._pending.clear()
            self._wake.notify_all()
            thread = self._thread
        if thread is not None:
            thread.join(timeout)

    # --- the training thread ---------------------------------------------------------------
    def _run(self) -> None:
        # On Linux a thread's nice value is its own: the vision worker and the
        # link keep their priority.
        with contextlib.suppress(OSError):
            os.nice(5)
        while True:
            with self._lock:
                while not self._pending and not self._closing:
                    self._wake.wait()
                if self._closing:
                    return
                ref_id, reference = self._pending.pop()  # the newest request first
            self._train(ref_id, reference)

    def _train(self, ref_id: int, reference: Reference) -> None:
        self._set(ref_id, VerifierStatus("training", 0.0, f"learning from {self._views} views"))
        last = [0.0]

        def progress(fraction: float) -> None:
            if self._closing:
                raise _Cancelled
            if fraction - last[0] >= 0.05:
                last[0] = fraction
                self._set(ref_id, replace(self.status(ref_id), progress=fraction))

        try:
            verifier = train_verifier(
                reference, views=self._views, epochs=self._epochs, progress=progress
            )
        except _Cancelled:
            return
        except PoorReference as exc:
            self._set(ref_id, VerifierStatus("unavailable", 0.0, f"verifier off: {exc}"))
            return
        except Exception as exc:  # one bad run must not take the station down
            log.exception("reference %s: verifier training failed", ref_id)
            self._set(ref_id, VerifierStatus("failed", 0.0, f"training failed: {exc}"))
            return
        try:
            verifier.save(self._folder_of(ref_id) / VERIFIER_FOLDER)
        except OSError as exc:
            log.warning("reference %s: verifier not saved: %s", ref_id, exc)
        self._verifiers[ref_id] = verifier
        info = verifier.info
        detail = (
            f"ready: held-out detection {info.get('held_out_detection', float('nan')):.3f}, "
            f"false positives {info.get('held_out_fp', float('nan')):.3f}"
        )
        self._set(ref_id, VerifierStatus("ready", 1.0, detail))

    def _set(self, ref_id: int, status: VerifierStatus) -> None:
        with self._lock:
            self._status[ref_id] = status
        self._emit(ref_id)

    def _emit(self, ref_id: int) -> None:
        if self._on_change is None:
            return
        try:
            self._on_change(ref_id, self.status(ref_id))
        except Exception:
            log.exception("verifier status listener failed")
