"""`VehicleServer`: the simulated vehicle on a real transport, speaking MAVLink 2.

Threads: an I/O thread reads and parses bytes (one parser per peer) into a queue; the
sim thread (or, in lockstep, the owner calling `advance`) handles queued messages,
steps the physics and sends the telemetry that is due by sim time. Every message is
handled in isolation: a handler that fails is counted and the link goes on.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim.vehicle.autopilot import (
    ACCEPTED,
    DENIED,
    FAILED,
    FORCE_ARM_MAGIC,
    GUIDED,
    LAND,
    RTL,
    UNSUPPORTED,
    SimVehicle,
    VehicleTruth,
)
from sim.vehicle.params import ParamInfo
from sim.vehicle.precland import LandingTargetMsg
from sim.vehicle.telemetry import STREAM_GROUPS, TelemetryBuilder
from sim.vehicle.transport import Transport, make_transport

log = logging.getLogger(__name__)

JOIN_TIMEOUT_S = 5.0
#: How long the autopilot is silent while it reboots (sim seconds; ArduCopter on a
#: flight controller takes a few).
REBOOT_SILENCE_S = 3.0
MIN_INTERVAL_S = 0.0025  # 400 Hz: no message faster than the main loop
SIGNING_EPOCH = 1420070400  # 2015-01-01, MAVLink signing timestamps count from here


class _Writer:
    """File-like sink for pymavlink's encoder: counts and forwards bytes."""

    def __init__(self, server: VehicleServer) -> None:
        self._server = server

    def write(self, data: bytes) -> None:
        self._server._write(bytes(data))


class VehicleServer:
    """Serve a `SimVehicle` over ``tcp:``, ``udp:`` or a serial device, like SITL.

    Parameters
    ----------
    sim : SimVehicle
        The vehicle (physics + autopilot).
    url : str
        ``tcp:127.0.0.1:5760`` (listen; port 0 picks one), ``udp:HOST:PORT`` (send
        there, reply to the last sender) or ``/dev/pts/N[,baud]``.
    speedup : float
        Sim seconds per wall second when free-running; may be changed while it runs.
    lockstep : bool
        When True the clock stands still until the owner calls `advance`.
    """

    def __init__(
        self, sim: SimVehicle, url: str, *, speedup: float = 1.0, lockstep: bool = False
    ) -> None:
        if not (isinstance(speedup, (int, float)) and math.isfinite(speedup) and speedup > 0):
            raise ValueError(f"speedup must be a positive finite number, got {speedup!r}")
        self.sim = sim
        self.url = url
        self.speedup = float(speedup)
        self.lockstep = lockstep
        self._transport: Transport = make_transport(url)
        self._sysid = int(sim.params.get("SYSID_THISMAV"))
        self._compid = mavlink.MAV_COMP_ID_AUTOPILOT1
        self._mav = mavlink.MAVLink(_Writer(self), self._sysid, self._compid)
        self._mav.robust_parsing = True
        key = sim.config.signing_key
        if key is not None:
            self._mav.signing.secret_key = key
            self._mav.signing.sign_outgoing = True
            self._mav.signing.link_id = 0
            self._mav.signing.timestamp = int((time.time() - SIGNING_EPOCH) * 100_000)
        self._telemetry = TelemetryBuilder(sim, self._mav, sim.config.seed)
        self._intervals: dict[str, float] = {"HEARTBEAT": 1.0}
        self._next_due: dict[str, float] = {"HEARTBEAT": 0.0}
        self._parsers: dict[object, mavlink.MAVLink] = {}
        self._inbox: deque[mavlink.MAVLink_message] = deque(maxlen=10000)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._lock = threading.RLock()  # one thread at a time steps the sim and sends
        self._home_sent: tuple[float, float, float] | None = None  # home last announced
        self._silent_until = -math.inf
        self._param_queue: deque[int] = deque()
        self._started = False
        self.address = ""
        self.gcs_sysid: int | None = None
        self.last_gcs_heartbeat: float | None = None
        # Counters: what arrived, what was garbage, what failed, what went out.
        self.messages_received = 0
        self.bad_packets = 0
        self.handler_errors = 0
        self.messages_sent = 0
        self.bytes_sent = 0
        self.inbox_dropped = 0
        self._handlers: dict[str, Callable[[mavlink.MAVLink_message], None]] = {
            "HEARTBEAT": self._on_heartbeat,
            "COMMAND_LONG": self._on_command_long,
            "COMMAND_INT": self._on_command_int,
            "SET_MODE": self._on_set_mode,
            "REQUEST_DATA_STREAM": self._on_request_data_stream,
            "PARAM_REQUEST_LIST": self._on_param_request_list,
            "PARAM_REQUEST_READ": self._on_param_request_read,
            "PARAM_SET": self._on_param_set,
            "RC_CHANNELS_OVERRIDE": self._on_rc_override,
            "SET_POSITION_TARGET_LOCAL_NED": self._on_position_target_local,
            "SET_POSITION_TARGET_GLOBAL_INT": self._on_position_target_global,
            "LANDING_TARGET": self._on_landing_target,
            "VISION_POSITION_ESTIMATE": self._on_vision_position,
            "VISION_SPEED_ESTIMATE": self._on_vision_speed,
            "TIMESYNC": self._on_timesync,
        }

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Open the transport and start the threads; returns once it listens."""
        if self._started:
            raise RuntimeError("VehicleServer already started")
        self.address = self._transport.open()
        self._started = True
        io = threading.Thread(target=self._io_loop, name="sim-vehicle-io", daemon=True)
        self._threads = [io]
        if not self.lockstep:
            self._threads.append(
                threading.Thread(target=self._sim_loop, name="sim-vehicle-clock", daemon=True)
            )
        for t in self._threads:
            t.start()

    def stop(self, timeout: float = JOIN_TIMEOUT_S) -> None:
        """Stop the threads (joined within ``timeout`` s) and close the transport."""
        self._stop.set()
        for t in self._threads:
            t.join(timeout)
        self._transport.close()
        self._threads = []

    def __enter__(self) -> VehicleServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        """The threads are alive."""
        return any(t.is_alive() for t in self._threads)

    @property
    def peers(self) -> int:
        """Connected GCS peers (TCP clients)."""
        return self._transport.peers

    def truth(self) -> VehicleTruth:
        """Ground truth, consistent between fields (taken between two physics steps)."""
        with self._lock:
            return self.sim.truth

    # ------------------------------------------------------------------ clock
    @property
    def rebooting(self) -> bool:
        """Between a reboot's ACK and the boot: the vehicle hears and says nothing."""
        return self.sim.time_s < self._silent_until

    def advance(self, dt: float) -> None:
        """Lockstep: handle what has arrived, step ``dt`` sim seconds, send what is due."""
        if not self.lockstep:
            raise RuntimeError("advance() is for lockstep servers; this one runs by itself")
        if not (math.isfinite(dt) and dt >= 0):
            raise ValueError(f"dt must be a finite number >= 0, got {dt}")
        step = 1.0 / self.sim.config.physics_hz
        n = round(dt / step)
        with self._lock:
            self._handle_inbox()
            for i in range(n):
                self._tick(step)
                if i % 40 == 39:
                    self._handle_inbox()

    def wait_inbound(self, count: int, timeout: float = 2.0) -> bool:
        """Lockstep helper: wait until ``messages_received`` reaches ``count``."""
        deadline = time.monotonic() + timeout
        while self.messages_received < count:
            if time.monotonic() > deadline:
                return False
            time.sleep(0.001)
        return True

    def _sim_loop(self) -> None:
        step = 1.0 / self.sim.config.physics_hz
        wall0, sim0 = time.monotonic(), self.sim.time_s
        speed = self.speedup
        while not self._stop.is_set():
            if self.speedup != speed:  # changed while running (as SITL's SIM_SPEEDUP)
                speed = self.speedup
                wall0, sim0 = time.monotonic(), self.sim.time_s
            target = sim0 + speed * (time.monotonic() - wall0)
            with self._lock:
                self._handle_inbox()
                n = 0
                while self.sim.time_s + step / 2 <= target and n < 400:
                    self._tick(step)
                    n += 1
                    if n % 40 == 0:
                        self._handle_inbox()
            behind = target - self.sim.time_s
            if behind > max(1.0, speed):
                # Cannot keep up (slow machine, huge speedup): run as fast as we can
                # instead of piling up debt.
                wall0, sim0 = time.monotonic(), self.sim.time_s
            elif behind < step:
                self._stop.wait(min(0.004, max(0.0005, (step - behind) / speed)))

    def _tick(self, dt: float) -> None:
        try:
            self.sim.step(dt)
        except Exception:  # a bug in the sim must not kill the link silently
            self.handler_errors += 1
            log.exception("sim step failed")
        self._emit_due()

    # ------------------------------------------------------------------ output
    def _write(self, data: bytes) -> None:
        self.bytes_sent += len(data)
        self._transport.send(data)

    def _send(self, msg: mavlink.MAVLink_message | None) -> None:
        if msg is None:
            return
        with self._lock:
            try:
                self._mav.send(msg)
                self.messages_sent += 1
            except Exception:
                self.handler_errors += 1
                log.exception("send failed")

    def _emit_due(self) -> None:
        now = self.sim.time_s
        if now < self._silent_until:  # rebooting: nothing comes out
            self.sim.drain_texts()
            return
        for severity, text in self.sim.drain_texts():
            self._send(self._mav.statustext_encode(severity, text.encode()[:50]))
        if self.sim.home_set and self._home_sent != self.sim.home_ned:
            # announced once known, and again whenever arming moves it
            self._home_sent = self.sim.home_ned
            self._send(self._telemetry.home_position())
        for name, interval in self._intervals.items():
            due = self._next_due.get(name, now)
            if now + 1e-9 >= due:
                # Keep the phase, but never build a backlog after a pause.
                self._next_due[name] = max(due + interval, now + interval * 0.5)
                self._send(self._telemetry.build(name))
        for _ in range(min(len(self._param_queue), 20)):
            info = self.sim.params.info_by_index(self._param_queue.popleft())
            if info is not None:
                self._send_param(info)

    def set_interval(self, name: str, interval_s: float | None) -> None:
        """Stream ``name`` every ``interval_s`` sim seconds (None stops it)."""
        if name not in self._telemetry.names:
            raise ValueError(f"name must be a message the vehicle sends, got {name!r}")
        with self._lock:
            if interval_s is None:
                self._intervals.pop(name, None)
                self._next_due.pop(name, None)
                return
            interval_s = max(MIN_INTERVAL_S, interval_s)
            self._intervals[name] = interval_s
            self._next_due[name] = self.sim.time_s

    # ------------------------------------------------------------------ input
    def _io_loop(self) -> None:
        while not self._stop.is_set():
            try:
                chunks = self._transport.poll(0.02)
            except Exception:
                log.exception("transport poll failed")
                self._stop.wait(0.05)
                continue
            for peer, data in chunks:
                if not data:
                    self._parsers.pop(peer, None)
                    continue
                self._parse(peer, data)

    def _new_parser(self) -> mavlink.MAVLink:
        parser = mavlink.MAVLink(None, self._sysid, self._compid)
        parser.robust_parsing = True
        key = self.sim.config.signing_key
        if key is not None:
            parser.signing.secret_key = key
            # Like ArduPilot with signing on: unsigned messages are dropped, except
            # RADIO_STATUS from a telemetry radio.
            parser.signing.allow_unsigned_callback = lambda _mav, msg_id: (
                msg_id == mavlink.MAVLINK_MSG_ID_RADIO_STATUS
            )
        return parser

    def _parse(self, peer: object, data: bytes) -> None:
        parser = self._parsers.get(peer)
        if parser is None:
            parser = self._parsers[peer] = self._new_parser()
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:
            # pymavlink gave up mid-buffer: count it, start a fresh parser.
            self.bad_packets += 1
            self._parsers[peer] = self._new_parser()
            return
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                self.bad_packets += 1
                continue
            if len(self._inbox) == self._inbox.maxlen:
                self.inbox_dropped += 1  # the oldest goes: a flood must not grow memory
            self._inbox.append(msg)
            self.messages_received += 1

    def _handle_inbox(self) -> None:
        while self._inbox:
            msg = self._inbox.popleft()
            if self.sim.time_s < self._silent_until:
                continue  # rebooting: nothing is heard
            handler = self._handlers.get(msg.get_type())
            if handler is None:
                continue
            try:
                handler(msg)
            except Exception:
                self.handler_errors += 1
                log.exception("handling %s failed", msg.get_type())

    def _for_us(self, target_system: int, target_component: int | None = None) -> bool:
        if target_system not in (0, self._sysid):
            return False
        return target_component is None or target_component in (0, self._compid)

    # ------------------------------------------------------------------ handlers
    def _on_heartbeat(self, msg: mavlink.MAVLink_message) -> None:
        if msg.type == mavlink.MAV_TYPE_GCS:
            self.gcs_sysid = msg.get_srcSystem()
            self.last_gcs_heartbeat = self.sim.time_s

    def _ack(self, msg: mavlink.MAVLink_message, command: int, result: int) -> None:
        self._send(
            self._mav.command_ack_encode(
                command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
            )
        )

    def _on_set_mode(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        result = self._set_mode_common(msg.base_mode, msg.custom_mode)
        # ArduPilot acks SET_MODE with a COMMAND_ACK whose command is the message id.
        self._ack(msg, mavlink.MAVLINK_MSG_ID_SET_MODE, result)

    def _set_mode_common(self, base_mode: float, custom_mode: float) -> int:
        if not int(base_mode) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return UNSUPPORTED
        if not math.isfinite(custom_mode) or custom_mode < 0:
            return FAILED
        return self.sim.set_mode(int(custom_mode))

    def _on_command_long(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system, msg.target_component):
            return
        params = (
            msg.param1,
            msg.param2,
            msg.param3,
            msg.param4,
            msg.param5,
            msg.param6,
            msg.param7,
        )
        result = self._command(msg, msg.command, params, None)
        if result is not None:
            self._ack(msg, msg.command, result)

    def _on_command_int(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z)
        result = self._command(msg, msg.command, params, msg.frame)
        if result is not None:
            self._ack(msg, msg.command, result)

    def _command(
        self,
        msg: mavlink.MAVLink_message,
        command: int,
        p: tuple[float, ...],
        frame: int | None,
    ) -> int | None:
        """Run one MAV_CMD; returns the MAV_RESULT (None: no ACK to send)."""
        sim = self.sim
        if command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            force = round(p[1]) == FORCE_ARM_MAGIC
            if p[0] == 1:
                return sim.arm(force)
            if p[0] == 0:
                return sim.disarm(force)
            return FAILED
        if command == mavlink.MAV_CMD_DO_SET_MODE:
            return self._set_mode_common(p[0], p[1])
        if command == mavlink.MAV_CMD_NAV_TAKEOFF:
            return sim.takeoff(p[6], must_navigate=p[2] == 0)
        if command == mavlink.MAV_CMD_NAV_LAND:
            return sim.set_mode(LAND)
        if command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return sim.set_mode(RTL)
        if command == mavlink.MAV_CMD_DO_CHANGE_SPEED:
            return sim.change_speed(p[1])
        if command == mavlink.MAV_CMD_CONDITION_YAW:
            return sim.condition_yaw(p[0], p[1], int(p[2]) if math.isfinite(p[2]) else 1, p[3] != 0)
        if command == mavlink.MAV_CMD_DO_REPOSITION:
            return self._reposition(p, frame)
        if command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            return self._set_message_interval(p[0], p[1])
        if command == mavlink.MAV_CMD_GET_MESSAGE_INTERVAL:
            return self._get_message_interval(p[0])
        if command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            return self._request_message(p[0])
        if command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            self._send(self._telemetry.autopilot_version())
            return ACCEPTED
        if command == mavlink.MAV_CMD_GET_HOME_POSITION:
            home = self._telemetry.home_position()
            self._send(home)
            return ACCEPTED if home is not None else FAILED
        if command == mavlink.MAV_CMD_SET_EKF_SOURCE_SET:
            return sim.set_ekf_source_set(p[0])
        if command == mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN:
            if round(p[0]) != 1:
                return UNSUPPORTED
            if sim.armed:
                return FAILED
            # Ack first: a real autopilot acks, then goes quiet while it reboots.
            self._ack(msg, command, ACCEPTED)
            sim.reboot(REBOOT_SILENCE_S)
            self._home_sent = None
            self._param_queue.clear()  # a list it was sending is forgotten
            self._silent_until = sim.time_s + REBOOT_SILENCE_S
            return None
        return UNSUPPORTED

    def _reposition(self, p: tuple[float, ...], frame: int | None) -> int:
        sim = self.sim
        if frame is None:
            return UNSUPPORTED  # ArduCopter takes DO_REPOSITION as COMMAND_INT only
        if sim.mode != GUIDED:
            if not int(p[1]) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE:
                return DENIED
            if sim.set_mode(GUIDED) != ACCEPTED:
                return FAILED
        lat, lon = p[4] / 1e7, p[5] / 1e7
        if not (-90 <= lat <= 90 and -180 <= lon <= 180 and math.isfinite(p[6])):
            return FAILED
        n, e = sim.global_to_ned(lat, lon)
        down = self._down_from_frame(frame, p[6])
        if down is None:
            return FAILED
        return ACCEPTED if sim.guided_position(n, e, down) else FAILED

    def _down_from_frame(self, frame: int, alt: float) -> float | None:
        if frame in (
            mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
            mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        ):
            return -alt
        if frame in (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT):
            return -(alt - self.sim.config.home_alt)
        return None

    def _message_name(self, msg_id: float) -> str | None:
        if not math.isfinite(msg_id):
            return None
        cls = mavlink.mavlink_map.get(int(msg_id))
        if cls is None:
            return None
        name = cls.msgname
        return name if name in self._telemetry.names else None

    def _set_message_interval(self, msg_id: float, interval_us: float) -> int:
        name = self._message_name(msg_id)
        if name is None or not math.isfinite(interval_us):
            return FAILED
        if interval_us < 0:
            self.set_interval(name, None)
        elif interval_us == 0:
            self.set_interval(name, 1.0 if name == "HEARTBEAT" else None)
        else:
            self.set_interval(name, interval_us / 1e6)
        return ACCEPTED

    def _get_message_interval(self, msg_id: float) -> int:
        name = self._message_name(msg_id)
        if name is None:
            return FAILED
        interval = self._intervals.get(name)
        us = -1 if interval is None else round(interval * 1e6)
        self._send(self._mav.message_interval_encode(int(msg_id), us))
        return ACCEPTED

    def _request_message(self, msg_id: float) -> int:
        name = self._message_name(msg_id)
        if name is None:
            return FAILED
        built = self._telemetry.build(name)
        if built is None:
            return FAILED
        self._send(built)
        return ACCEPTED

    def _on_request_data_stream(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        rate = msg.req_message_rate if msg.start_stop else 0
        if msg.req_stream_id == mavlink.MAV_DATA_STREAM_ALL:
            groups = list(STREAM_GROUPS.values())
        else:
            groups = [STREAM_GROUPS.get(msg.req_stream_id, ())]
        for names in groups:
            for name in names:
                self.set_interval(name, 1.0 / rate if rate > 0 else None)

    def _send_param(self, info: ParamInfo) -> None:
        self._send(
            self._mav.param_value_encode(
                info.name.encode(), info.value, info.param_type, info.count, info.index
            )
        )

    def _on_param_request_list(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        # Streamed over the next ticks, as ArduPilot trickles its parameter list; a
        # request while it streams starts it again (ArduPilot restarts its send), so
        # repeated requests never queue a parameter twice.
        self._param_queue.clear()
        self._param_queue.extend(range(len(self.sim.params)))

    def _on_param_request_read(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        params = self.sim.params
        if msg.param_index >= 0:
            info = params.info_by_index(msg.param_index)
        else:
            info = params.info(_param_name(msg.param_id))
        if info is not None:
            self._send_param(info)

    def _on_param_set(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        info = self.sim.param_set(_param_name(msg.param_id), msg.param_value)
        if info is not None:
            self._send_param(info)

    def _on_rc_override(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        channels = [getattr(msg, f"chan{i}_raw", 0) for i in range(1, 19)]
        self.sim.rc_override(msg.get_srcSystem(), channels)

    def _on_position_target_local(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        sim = self.sim
        if sim.mode != GUIDED:
            return
        mask = msg.type_mask
        frame = msg.coordinate_frame
        if frame not in (
            mavlink.MAV_FRAME_LOCAL_NED,
            mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
            mavlink.MAV_FRAME_BODY_NED,
            mavlink.MAV_FRAME_BODY_OFFSET_NED,
        ):
            return
        pos_ignore = mask & 0b111 == 0b111
        vel_ignore = mask & 0b111000 == 0b111000
        yaw_ignore = bool(mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE)
        rate_ignore = bool(mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE)
        est = sim.estimate
        body = frame in (mavlink.MAV_FRAME_BODY_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED)
        cy, sy = math.cos(est.yaw), math.sin(est.yaw)

        def rot(x: float, y: float) -> tuple[float, float]:
            return (x * cy - y * sy, x * sy + y * cy) if body else (x, y)

        if not pos_ignore:
            n, e = rot(msg.x, msg.y)
            d = msg.z
            if frame != mavlink.MAV_FRAME_LOCAL_NED:
                n += est.position_ned[0]
                e += est.position_ned[1]
                d += est.position_ned[2]
            sim.guided_position(n, e, d)
        elif not vel_ignore:
            vn, ve = rot(msg.vx, msg.vy)
            sim.guided_velocity(vn, ve, msg.vz)
        if not yaw_ignore:
            sim.guided_yaw(msg.yaw + (est.yaw if body else 0.0), None)
        elif not rate_ignore:
            sim.guided_yaw(None, msg.yaw_rate)

    def _on_position_target_global(self, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg.target_system):
            return
        sim = self.sim
        if sim.mode != GUIDED:
            return
        mask = msg.type_mask
        if mask & 0b111 != 0b111:
            down = self._down_from_frame(msg.coordinate_frame, msg.alt)
            if down is None:
                return
            n, e = sim.global_to_ned(msg.lat_int / 1e7, msg.lon_int / 1e7)
            sim.guided_position(n, e, down)
        elif mask & 0b111000 != 0b111000:
            sim.guided_velocity(msg.vx, msg.vy, msg.vz)
        if not mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE:
            sim.guided_yaw(msg.yaw, None)

    def _on_landing_target(self, msg: mavlink.MAVLink_message) -> None:
        self.sim.landing_target(
            LandingTargetMsg(
                time_usec=msg.time_usec,
                frame=msg.frame,
                angle_x=msg.angle_x,
                angle_y=msg.angle_y,
                distance=msg.distance,
                x=getattr(msg, "x", 0.0),
                y=getattr(msg, "y", 0.0),
                z=getattr(msg, "z", 0.0),
                position_valid=getattr(msg, "position_valid", 0),
            )
        )

    def _on_vision_position(self, msg: mavlink.MAVLink_message) -> None:
        # Any sender, no target fields: GCS_MAVLINK::handle_vision_position_estimate.
        self.sim.vision_position(msg.x, msg.y, msg.z, msg.usec)

    def _on_vision_speed(self, msg: mavlink.MAVLink_message) -> None:
        self.sim.vision_speed()

    def _on_timesync(self, msg: mavlink.MAVLink_message) -> None:
        if msg.tc1 == 0:
            now_ns = round(self.sim.time_s * 1e9)
            self._send(self._mav.timesync_encode(now_ns, msg.ts1))


def _param_name(raw: object) -> str:
    """PARAM_* ids arrive as str (or bytes) padded with NULs."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", errors="replace")
    return str(raw).split("\x00", 1)[0]
