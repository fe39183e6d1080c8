"""A stand-in for the vision's pose: the vehicle's true position as ExternalNav input.

On each SIM_STATE the observer receives (genuine SITL or the stand-in), it sends
VISION_POSITION_ESTIMATE (and, optionally, VISION_SPEED_ESTIMATE) with the true
position in the EKF origin's NED frame plus Gaussian noise, stamped with the
vehicle's own clock: what the station will send from the pad's pose once vision
replaces it (phase 2 of issue 12). The rate follows simulated time (SIM_STATE's),
whatever the speed-up.
"""

from __future__ import annotations

import math
import threading

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from sim.sitl import SitlObserver

_NAN_COV21 = [math.nan] + [0.0] * 20
_NAN_COV9 = [math.nan] + [0.0] * 8


class VisionStandIn:
    """Sends the vehicle's true position as VISION_POSITION_ESTIMATE (+ speed) on each
    SIM_STATE the observer receives; ``offset_ne`` shifts the frame (metres), ``on``
    pauses it (the pad out of view)."""

    def __init__(
        self,
        observer: SitlObserver,
        origin: tuple[float, float, float],
        *,
        noise_m: float = 0.0,
        speed: bool = True,
        seed: int = 0,
        offset_ne: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        self.observer = observer
        self.origin = origin
        self.noise_m = noise_m
        self.speed = speed
        self.offset_ne = offset_ne
        self.sent = 0
        self.on = threading.Event()
        self.on.set()
        self._rng = np.random.default_rng(seed)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="vision-stand-in", daemon=True)

    def start(self) -> VisionStandIn:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._thread.join(3.0)

    def _run(self) -> None:
        obs = self.observer
        while not self._stop.is_set():
            if obs.wait_message("SIM_STATE", 0.5) is None or not self.on.is_set():
                continue
            truth = obs.truth(self.origin)
            boot = obs.boot_s
            if truth is None or boot is None:
                continue
            usec = int(boot * 1e6)  # the vehicle's clock: the frame's capture time
            n, e, d = np.asarray(truth.position_ned) + self._rng.normal(0, self.noise_m, 3)
            n, e = n - self.offset_ne[0], e - self.offset_ne[1]
            obs.send(
                mavlink2.MAVLink_vision_position_estimate_message(
                    usec, n, e, d, truth.roll, truth.pitch, truth.yaw, _NAN_COV21, 0
                )
            )
            if self.speed:
                obs.send(
                    mavlink2.MAVLink_vision_speed_estimate_message(
                        usec, *truth.velocity_ned, _NAN_COV9, 0
                    )
                )
            self.sent += 1
