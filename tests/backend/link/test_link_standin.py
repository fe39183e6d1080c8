"""The link against the ArduCopter stand-in (sim/vehicle) over real TCP sockets."""

from __future__ import annotations

import contextlib
import math
import os
import select
import socket
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from pymavlink import mavutil

from backend.link import LinkEvent, LinkState, Telemetry, VehicleLink
from sim.vehicle import SimConfig, SimVehicle, VehicleServer
from tests.backend.link.udp import wait_udp_bound

SPEEDUP = 4.0  # flights run at four times real time to keep the tests short


@pytest.fixture
def standin() -> Iterator[Callable[..., VehicleServer]]:
    """Start stand-in vehicles (``SimConfig`` keywords, plus url/speedup); always stopped."""
    servers: list[VehicleServer] = []

    def start(
        *, url: str = "tcp:127.0.0.1:0", speedup: float = SPEEDUP, **config: Any
    ) -> VehicleServer:
        config.setdefault("seed", 1)
        config.setdefault("ready_after_scale", 0.05)
        server = VehicleServer(SimVehicle(SimConfig(**config)), url, speedup=speedup)
        servers.append(server)
        server.start()
        return server

    yield start
    for server in servers:
        server.stop()


def _up(link: VehicleLink, timeout: float = 5.0) -> bool:
    return link.wait_until(lambda t: t.state == LinkState.UP, timeout)


def _arm_when_ready(link: VehicleLink, timeout: float = 10.0) -> None:
    """Arm as soon as the vehicle lets us (readiness takes time, as on SITL)."""
    deadline = time.monotonic() + timeout
    result = link.arm()
    while not result.ok and time.monotonic() < deadline:
        time.sleep(0.1)
        result = link.arm()
    assert result.ok, result


def _sim_wait(server: VehicleServer, seconds: float, timeout: float = 60.0) -> None:
    """Let ``seconds`` of the stand-in's own (simulated) time pass."""
    end = server.sim.time_s + seconds
    deadline = time.monotonic() + timeout
    while server.sim.time_s < end:
        assert time.monotonic() < deadline, "the stand-in's clock stood still"
        time.sleep(0.01)


def _take_off(link: VehicleLink, altitude: float) -> None:
    assert link.set_mode("GUIDED").ok
    assert link.wait_until(lambda t: t.ekf is not None and t.ekf.pos_horiz_ok, 10.0)
    _arm_when_ready(link)
    result = link.takeoff(altitude)
    assert result.ok, result
    assert link.wait_until(
        lambda t: t.relative_alt_m is not None and t.relative_alt_m > altitude - 0.3, 20.0
    ), link.telemetry.relative_alt_m


def test_telemetry_arrives_and_refused_arm_has_reasons(standin, make_link) -> None:
    # readiness at SITL pace: nothing is ready during this test
    server = standin(ready_after_scale=1.0, speedup=1.0)
    link = make_link(server.address)
    assert _up(link)
    assert link.wait_until(
        lambda t: (
            t.attitude is not None
            and t.gps is not None
            and t.battery is not None
            and t.msgs_per_s > 20
        ),
        5.0,
    ), link.telemetry
    t = link.telemetry
    assert t.mode == "STABILIZE" and not t.armed and t.vehicle_sysid == 1
    assert t.position_ned is None  # like ArduPilot: no LOCAL_POSITION_NED before the origin
    assert abs(t.attitude.roll) < 0.1 and t.attitude_rx_monotonic <= time.monotonic()
    result = link.arm()
    assert not result.ok and result.result_name == "FAILED"
    assert result.reasons, result
    assert all(r.startswith(("Arm:", "PreArm:")) for r in result.reasons), result.reasons
    texts = {s.text for s in link.telemetry.statustexts}
    assert set(result.reasons) <= texts  # verbatim, as the vehicle sent them
    refused = link.set_mode("FOLLOW")  # needs a position estimate that does not exist yet
    assert not refused.ok
    assert refused.reasons and "FOLLOW" in refused.reasons[0], refused


@pytest.mark.slow
def test_arm_take_off_hover_velocity_and_land(standin, make_link) -> None:
    server = standin()
    link = make_link(server.address, command_timeout_s=2.0)
    events: list[LinkEvent] = []
    link.subscribe(events.append)
    assert _up(link)
    _take_off(link, 3.0)
    # hover: holds the altitude within a few decimetres (4 s of sim time)
    _sim_wait(server, 4.0)
    assert abs(link.telemetry.relative_alt_m - 3.0) < 0.3
    # GUIDED velocity north at 1 m/s, re-sent as ArduCopter needs
    start = link.telemetry.position_ned
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and link.telemetry.position_ned.x < start.x + 2.0:
        assert link.set_velocity_ned(1.0, 0.0, 0.0).ok
        time.sleep(0.05)
    assert link.telemetry.position_ned.x > start.x + 2.0, link.telemetry.position_ned
    assert abs(link.telemetry.position_ned.y - start.y) < 0.5
    assert abs(link.telemetry.relative_alt_m - 3.0) < 0.5
    # position target: back over home
    assert link.goto_local_ned(0.0, 0.0, -3.0).ok
    assert link.wait_until(lambda t: abs(t.position_ned.x) < 0.5, 10.0)
    assert link.land().ok
    assert link.wait_until(lambda t: t.mode == "LAND", 20.0)
    assert link.wait_until(lambda t: not t.armed, 30.0)  # touches down, disarms by itself
    assert link.telemetry.relative_alt_m < 0.3
    deadline = time.monotonic() + 2.0  # events arrive on their own thread
    while time.monotonic() < deadline and "disarmed" not in [e.kind for e in events]:
        time.sleep(0.01)
    kinds = [e.kind for e in events]
    assert "armed" in kinds, kinds
    assert "disarmed" in kinds, kinds
    assert "mode_changed" in kinds, kinds


@pytest.mark.slow
def test_rc_override_in_loiter(standin, make_link) -> None:
    server = standin()
    link = make_link(server.address, command_timeout_s=2.0)
    assert _up(link)
    _take_off(link, 3.0)
    assert link.set_mode("LOITER").ok
    start = link.telemetry.position_ned
    # pitch stick forward (low PWM = nose down), throttle at mid-stick to hold altitude
    deadline = time.monotonic() + 8.0
    while time.monotonic() < deadline and link.telemetry.position_ned.x < start.x + 2.0:
        assert link.rc_override({1: 1500, 2: 1300, 3: 1500, 4: 1500}).ok
        time.sleep(0.05)
    t = link.telemetry
    assert t.position_ned.x > start.x + 2.0, t.position_ned  # flew forward (north: yaw ~ 0)
    assert abs(t.relative_alt_m - 3.0) < 0.5
    assert link.rc_override({1: 0, 2: 0, 3: 0, 4: 0}).ok  # give the sticks back


@pytest.mark.slow
def test_precision_landing_moves_the_vehicle_to_the_target(standin, make_link) -> None:
    pad = (3.0, -2.0)
    server = standin(pad_north=pad[0], pad_east=pad[1])
    link = make_link(server.address, command_timeout_s=2.0)
    assert _up(link)
    assert link.set_param("PLND_ENABLED", 1).ok
    assert link.set_param("PLND_TYPE", 1).ok
    assert link.get_param("PLND_TYPE") == 1.0
    assert link.reboot().ok  # PLND_TYPE is read at boot
    _sim_wait(server, 1.2)  # the reboot is under way (the stand-in's clock)
    assert _up(link)
    _take_off(link, 5.0)
    assert link.land().ok

    def target_in_body(t: Telemetry) -> tuple[float, float, float]:
        # what a downward camera would measure: the pad in body FRD, from the pose
        dn, de = pad[0] - t.position_ned.x, pad[1] - t.position_ned.y
        yaw = t.attitude.yaw
        fwd = math.cos(yaw) * dn + math.sin(yaw) * de
        right = -math.sin(yaw) * dn + math.cos(yaw) * de
        return fwd, right, max(0.05, -t.position_ned.z)

    deadline = time.monotonic() + 40.0
    while time.monotonic() < deadline and link.telemetry.armed:
        t = link.telemetry
        x, y, z = target_in_body(t)
        # stamped with the vehicle's clock at the pose it was computed from
        assert link.send_landing_target(x, y, z, time_usec=t.attitude_time_boot_ms * 1000).ok
        time.sleep(0.1 / SPEEDUP)
    t = link.telemetry
    assert not t.armed
    landed = server.sim.truth.landed_at
    assert landed is not None
    miss = math.hypot(landed[0] - pad[0], landed[1] - pad[1])
    assert miss < 0.5, (landed, pad)  # home is 3.6 m away: the target moved the vehicle
    texts = [s.text for s in t.statustexts]
    assert "PrecLand: Target Found" in texts
    assert t.landing_targets_sent > 20


def test_link_loss_and_recovery(standin, make_link) -> None:
    server = standin()
    link = make_link(server.address, heartbeat_timeout_s=1.0)
    events: list[LinkEvent] = []
    link.subscribe(events.append)
    assert _up(link)
    port = int(server.address.rsplit(":", 1)[1])
    server.stop()  # the vehicle goes away
    assert link.wait_until(lambda t: t.state == LinkState.LOST, 20.0)
    assert link.arm().result_name == "LINK_DOWN"
    # a reconnect refused while nobody listens
    assert link.wait_until(lambda t: "cannot open" in (t.last_error or ""), 20.0)
    standin(url=f"tcp:127.0.0.1:{port}")  # and comes back on the same address
    assert _up(link, 20.0)
    assert link.wait_until(lambda t: t.attitude is not None and t.msgs_per_s > 0, 20.0)
    assert link.telemetry.reconnects >= 1
    deadline = time.monotonic() + 2.0  # events come on their own thread
    while time.monotonic() < deadline and events[-1].kind != "link_up":
        time.sleep(0.01)
    kinds = [e.kind for e in events if e.kind.startswith("link_")]
    assert kinds[-2:] == ["link_lost", "link_up"], kinds
    lost = next(e for e in events if e.kind == "link_lost")
    assert lost.data["reason"]


def test_tlog_replays_with_pymavlink(standin, make_link) -> None:
    server = standin(ready_after_scale=1.0, speedup=1.0)
    link = make_link(server.address)
    assert _up(link)
    assert not link.arm().ok
    # what the tlog must hold has come (closing the link writes it all out)
    assert link.wait_until(lambda t: t.attitude is not None and t.statustexts, 20.0)
    path = link.tlog_path
    link.close()
    log = mavutil.mavlink_connection(str(path))
    seen: dict[tuple[int, str], int] = {}
    stamps = []
    while (msg := log.recv_match()) is not None:
        key = (msg.get_srcSystem(), msg.get_type())
        seen[key] = seen.get(key, 0) + 1
        stamps.append(msg._timestamp)
    assert (255, "HEARTBEAT") in seen and (1, "HEARTBEAT") in seen
    assert (255, "COMMAND_LONG") in seen and (1, "COMMAND_ACK") in seen
    assert (1, "ATTITUDE") in seen and (1, "STATUSTEXT") in seen
    assert "BAD_DATA" not in {k[1] for k in seen}
    assert stamps == sorted(stamps) and abs(stamps[-1] - time.time()) < 60


def test_signed_link_with_the_standin_cli(make_link, tmp_path) -> None:
    key = os.urandom(32)
    port = _free_tcp_port()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sim.vehicle",
            "--mavlink",
            f"tcp:127.0.0.1:{port}",
            "--ready-after",
            "1",
            "--signing-key",
            key.hex(),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        assert "listening on" in line, line
        wrong = make_link(f"tcp:127.0.0.1:{port}", signing_key=bytes(32))
        link = make_link(f"tcp:127.0.0.1:{port}", signing_key=key)
        assert _up(link)
        result = link.arm()
        assert result.result_name == "FAILED" and result.reasons  # signed both ways
        assert wrong.state != LinkState.UP and wrong.telemetry.crc_errors > 0
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
        proc.stdout.close()


def _free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_standin_over_udp(standin, make_link) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    link = make_link(f"udpin:127.0.0.1:{port}")
    assert wait_udp_bound(port)  # bound before the vehicle starts sending
    standin(url=f"udp:127.0.0.1:{port}", ready_after_scale=1.0, speedup=1.0)
    assert _up(link)
    assert link.wait_until(lambda t: t.attitude is not None and t.msgs_per_s > 0, 20.0)
    result = link.arm()  # the vehicle answers to where our packets came from
    assert result.result_name == "FAILED" and result.reasons


class _PtyBridge:
    """Two pseudo-terminals joined like a pair of telemetry radios: bytes written to one
    device come out of the other. The stand-in opens one, the link the other."""

    def __init__(self) -> None:
        self.masters: list[int] = []
        self.paths: list[str] = []
        for _ in range(2):
            master, slave = os.openpty()
            tty.setraw(slave)
            self.masters.append(master)
            self.paths.append(os.ttyname(slave))
            self._slaves = [*getattr(self, "_slaves", []), slave]
        self.carried = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        a, b = self.masters
        while not self._stop.is_set():
            ready, _, _ = select.select([a, b], [], [], 0.05)
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                    os.write(b if fd == a else a, data)
                    self.carried += len(data)
                except OSError:
                    pass

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for fd in self.masters + self._slaves:
            with contextlib.suppress(OSError):
                os.close(fd)


def test_standin_over_a_serial_radio_pair(standin, make_link) -> None:
    bridge = _PtyBridge()
    try:
        standin(url=f"{bridge.paths[0]},57600", ready_after_scale=1.0, speedup=1.0)
        link = make_link(f"{bridge.paths[1]},57600")
        assert _up(link)
        assert link.wait_until(lambda t: t.attitude is not None, 20.0)
        result = link.arm()
        assert result.result_name == "FAILED" and result.reasons
        assert link.get_param("SYSID_MYGCS") == 255.0
        assert bridge.carried > 1000
    finally:
        bridge.close()
