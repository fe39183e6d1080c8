"""The simulated ArduCopter without I/O: physics, autopilot, precision landing, inputs."""

from __future__ import annotations

import math

import pytest

from sim.vehicle import LandingTargetMsg, ParamStore, SimConfig, SimVehicle
from sim.vehicle.control import mix, sqrt_controller
from sim.vehicle.physics import Airframe, euler_from_quat, ned_to_body, quat_from_euler

GUIDED, LOITER, LAND = 4, 5, 9


def _ready(**config: object) -> SimVehicle:
    config.setdefault("ready_after_scale", 0.01)
    v = SimVehicle(SimConfig(**config))  # type: ignore[arg-type]
    v.step(1.0)
    assert v.position_ok
    return v


def _airborne(alt: float = 5.0, **config: object) -> SimVehicle:
    v = _ready(**config)
    assert v.set_mode(GUIDED) == 0 and v.arm() == 0 and v.takeoff(alt) == 0
    v.step(12.0)
    return v


def _target_msg(v: SimVehicle, pad: tuple[float, float], **kw: object) -> LandingTargetMsg:
    t = v.truth
    rel = (pad[0] - t.position_ned[0], pad[1] - t.position_ned[1], -t.position_ned[2])
    x, y, z = ned_to_body(v.body.quat, rel)
    fields: dict[str, object] = {
        "time_usec": round(v.time_s * 1e6),
        "frame": 12,
        "angle_x": 0.0,
        "angle_y": 0.0,
        "distance": math.sqrt(x * x + y * y + z * z),
        "x": x,
        "y": y,
        "z": z,
        "position_valid": 1,
    }
    fields.update(kw)
    return LandingTargetMsg(**fields)  # type: ignore[arg-type]


def _precision_land(v: SimVehicle, pad: tuple[float, float], use_angles: bool = False) -> None:
    assert v.set_mode(LAND) == 0
    while v.armed and v.time_s < 200:
        if v.truth.position_ned[2] < -0.3:
            msg = _target_msg(v, pad)
            if use_angles:
                # Angles from the camera axis: angle_x to the right, angle_y forward.
                msg = _target_msg(
                    v,
                    pad,
                    position_valid=0,
                    angle_x=math.atan2(msg.y, msg.z),
                    angle_y=math.atan2(-msg.x, msg.z),
                )
            v.landing_target(msg)
        v.step(0.1)


def _with_precland(est_type: int = 1, **config: object) -> SimVehicle:
    v = _ready(**config)
    for name, value in (("PLND_ENABLED", 1), ("PLND_TYPE", 1), ("PLND_EST_TYPE", est_type)):
        assert v.param_set(name, value) is not None
    assert not v.precland.enabled  # PLND_TYPE needs a reboot, as in ArduPilot
    assert v.reboot() == 0
    assert v.precland.enabled
    v.step(1.0)
    return v


# ---------------------------------------------------------------------- physics
def test_vehicle_rests_on_the_ground_without_sinking() -> None:
    v = _ready()
    v.step(5.0)
    t = v.truth
    assert t.on_ground and t.position_ned[2] == 0.0 and t.velocity_ned == (0.0, 0.0, 0.0)
    assert (t.roll, t.pitch) == (0.0, 0.0)


def test_hover_holds_position_in_calm_air_and_is_pushed_by_wind() -> None:
    calm = _airborne(5.0)
    windy = _airborne(5.0, wind_mps=6.0, wind_dir_deg=90.0, gust_mps=2.0)
    calm_err, windy_err = [], []
    for _ in range(100):
        calm.step(0.1)
        windy.step(0.1)
        calm_err.append(math.dist(calm.truth.position_ned, (0, 0, -5)))
        windy_err.append(math.dist(windy.truth.position_ned, (0, 0, -5)))
    assert max(calm_err) < 0.1
    assert 0.05 < max(windy_err) < 2.0
    # Leaning into a wind from the east: roll to the east side (positive roll).
    rolls = []
    for _ in range(50):
        windy.step(0.1)
        rolls.append(windy.truth.roll)
    assert sum(rolls) / len(rolls) > math.radians(2)


def test_sensor_noise_is_small_but_present() -> None:
    v = _airborne(4.0)
    diffs = []
    for _ in range(50):
        v.step(0.2)
        est, t = v.estimate, v.truth
        diffs.append(math.dist(est.position_ned, t.position_ned))
    assert 0.0 < max(diffs) < 0.2
    assert v.rangefinder_m() is None  # SITL's default: no rangefinder (RNGFND1_TYPE 0)
    assert v.param_set("RNGFND1_TYPE", 100) is not None  # a configured one reads the height
    rf = v.rangefinder_m()
    assert rf is not None and abs(rf - 4.0) < 0.15


def test_same_seed_same_flight_and_different_seed_differs() -> None:
    def fly(seed: int) -> tuple[object, ...]:
        v = _airborne(3.0, seed=seed, wind_mps=4.0, gust_mps=2.0)
        v.guided_velocity(1.0, -0.5, 0.0)
        v.step(3.0)
        return v.truth.position_ned, v.truth.attitude, v.estimate.position_ned

    assert fly(11) == fly(11)
    assert fly(11) != fly(12)


def test_battery_drains_faster_in_flight() -> None:
    v = _ready()
    used0 = v.battery_mah_used
    v.step(10.0)
    ground = v.battery_mah_used - used0
    assert v.set_mode(GUIDED) == 0 and v.arm() == 0 and v.takeoff(3.0) == 0
    used1 = v.battery_mah_used
    v.step(10.0)
    assert v.battery_mah_used - used1 > 10 * ground
    assert v.battery_remaining < 100 and v.battery_voltage < 12.6


def test_stabilize_throttle_lifts_off_and_force_disarm_drops_it() -> None:
    v = _ready()
    assert v.arm() == 0
    assert v.rc_override(255, [1500, 1500, 1600, 1500])
    v.step(2.0)
    assert v.truth.position_ned[2] < -1.0
    assert v.disarm() == 4  # a GCS may not disarm a flying vehicle...
    assert v.disarm(force=True) == 0  # ...unless it forces it
    v.drain_texts()
    v.step(5.0)
    texts = [t for _, t in v.drain_texts()]
    assert any(t.startswith("SIM Hit ground at ") for t in texts)
    assert v.truth.on_ground


def test_disarm_in_guided_flight_needs_force_and_reboot_needs_disarmed() -> None:
    v = _airborne(3.0)
    assert v.disarm() == 4
    assert v.reboot() == 4
    assert v.armed
    assert v.disarm(force=True) == 0
    assert not v.armed


def test_alt_hold_climbs_with_throttle_above_the_deadzone() -> None:
    v = _airborne(3.0)
    assert v.set_mode(2) == 0
    v.rc_override(255, [1500, 1500, 1500, 1500])
    v.step(2.0)
    assert abs(-v.truth.position_ned[2] - 3.0) < 0.15
    v.rc_override(255, [1500, 1500, 1900, 1500])
    v.step(2.0)
    assert -v.truth.position_ned[2] > 4.0


# ---------------------------------------------------------------------- precision landing
@pytest.mark.parametrize("est_type", [0, 1])
def test_precision_landing_in_calm_air_lands_within_centimetres(est_type: int) -> None:
    pad = (3.0, -2.0)
    v = _with_precland(est_type)
    assert v.set_mode(GUIDED) == 0 and v.arm() == 0 and v.takeoff(6.0) == 0
    v.step(12.0)
    _precision_land(v, pad)
    assert not v.armed
    assert v.truth.landed_at is not None
    assert math.dist(v.truth.landed_at, pad) < 0.05


def test_precision_landing_from_angles_and_wind_makes_it_harder() -> None:
    # One gusty flight is luck; five (seeds) give the spread.
    pad = (2.0, 1.0)
    flights = [_with_precland(1)] + [
        _with_precland(1, wind_mps=7.0, wind_dir_deg=30.0, gust_mps=2.5, seed=seed)
        for seed in range(5)
    ]
    errors = []
    for v in flights:
        assert v.set_mode(GUIDED) == 0 and v.arm() == 0 and v.takeoff(5.0) == 0
        v.step(12.0)
        _precision_land(v, pad, use_angles=True)
        assert v.truth.landed_at is not None and not v.armed
        errors.append(math.dist(v.truth.landed_at, pad))
    calm, windy = errors[0], errors[1:]
    assert calm < 0.05
    assert min(windy) > calm
    assert sorted(windy)[2] < 0.5 and max(windy) < 1.0


def test_plain_land_without_target_drifts_nowhere_near_an_offset_pad() -> None:
    v = _with_precland(1)
    assert v.set_mode(GUIDED) == 0 and v.arm() == 0 and v.takeoff(3.0) == 0
    v.step(10.0)
    assert v.set_mode(LAND) == 0
    v.step(20.0)
    assert not v.armed
    assert v.truth.landed_at is not None and math.hypot(*v.truth.landed_at) < 0.2


def test_landing_target_rules() -> None:
    v = _with_precland(0)
    # Distance must be > 0 for position_valid = 1.
    v.landing_target(_target_msg(v, (1.0, 0.0), distance=0.0))
    v.landing_target(_target_msg(v, (1.0, 0.0), distance=float("nan")))
    v.step(0.1)
    assert v.precland.measurements == 0 and not v.precland.acquired
    # A stale measurement (stamped 1.5 s ago) is not used.
    v.step(3.0)
    v.landing_target(_target_msg(v, (1.0, 0.0), time_usec=round((v.time_s - 1.5) * 1e6)))
    v.step(0.1)
    assert not v.precland.acquired
    texts = [t for _, t in v.drain_texts()]
    assert "PrecLand: Target Found" not in texts


def test_reboot_keeps_parameters_and_restarts_readiness() -> None:
    v = SimVehicle(SimConfig(ready_after_scale=0.1))
    v.step(5.0)
    assert v.gps_fix
    v.param_set("DISARM_DELAY", 5)
    assert v.reboot() == 0
    assert v.params.get("DISARM_DELAY") == 5
    assert v.boot_s == 0.0 and not v.gps_fix
    assert v.mode == 0 and not v.armed


# ---------------------------------------------------------------------- small parts
def test_param_store_types_and_unknown_names() -> None:
    p = ParamStore()
    assert p.set("DISARM_DELAY", 7.6).value == 8.0  # integer types round
    assert p.set("DISARM_DELAY", 1e6).value == 127.0  # and clamp to INT8
    assert p.set("PLND_LAG", 0.05).value == pytest.approx(0.05)
    assert p.set("NO_SUCH", 1.0) is None
    assert p.set("PLND_LAG", float("nan")) is None
    assert p.info_by_index(len(p)) is None and p.info_by_index(-1) is None
    assert [i.index for i in p.all()] == list(range(len(p)))
    with pytest.raises(ValueError, match="overrides"):
        ParamStore({"NOPE": 1})


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"ready_after_scale": -1}, "ready_after_scale"),
        ({"home_lat": 91}, "home_lat"),
        ({"home_lon": -181}, "home_lon"),
        ({"pad_north": float("inf")}, "pad_north"),
        ({"wind_mps": -1}, "wind_mps"),
        ({"gust_mps": 20}, "gust_mps"),
        ({"physics_hz": 10}, "physics_hz"),
        ({"signing_key": b"short"}, "signing_key"),
        ({"battery_mah": 0}, "battery_mah"),
    ],
)
def test_sim_config_rejects_bad_values(kwargs: dict[str, object], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        SimConfig(**kwargs)  # type: ignore[arg-type]


def test_step_rejects_bad_dt_and_bad_commands_are_refused() -> None:
    v = _ready()
    for dt in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="dt"):
            v.step(dt)
    assert v.set_mode(GUIDED) == 0 and v.arm() == 0
    assert v.takeoff(float("nan")) == 4
    assert v.takeoff(-1.0) == 4
    assert v.change_speed(0.0) == 4
    assert not v.guided_velocity(float("inf"), 0, 0)  # landed and not finite


def test_controller_helpers() -> None:
    assert sqrt_controller(0.1, 1.0, 1.0) == pytest.approx(0.1)
    assert sqrt_controller(10.0, 1.0, 1.0) == pytest.approx(math.sqrt(2 * 9.5))
    assert sqrt_controller(-10.0, 1.0, 1.0) == pytest.approx(-math.sqrt(2 * 9.5))
    af = Airframe()
    hover = af.mass * 9.80665
    cmds = mix(af, hover, (0.0, 0.0, 0.0), 0.0)
    assert cmds == pytest.approx([af.hover_throttle] * 4)
    rolled = mix(af, hover, (0.2, 0.0, 0.0), 0.0)
    assert rolled[1] > rolled[0]  # left motors (negative y) push harder to roll right
    q = quat_from_euler(0.1, -0.2, 0.3)
    assert euler_from_quat(q) == pytest.approx((0.1, -0.2, 0.3))


def test_guided_yaw_by_condition_yaw_and_by_target() -> None:
    v = _airborne(3.0)
    assert v.condition_yaw(90.0, 45.0, 1, False) == 0
    v.step(1.0)
    assert 0.5 < math.degrees(v.truth.yaw) < 60.0  # turning at 45 deg/s
    v.step(3.0)
    assert abs(math.degrees(v.truth.yaw) - 90.0) < 2.0
    v.guided_yaw(math.radians(-30.0), None)
    v.step(4.0)
    assert abs(math.degrees(v.truth.yaw) + 30.0) < 2.0
    assert math.dist(v.truth.position_ned, (0, 0, -3)) < 0.15  # turning in place
    assert v.set_mode(LOITER) == 0
    assert v.condition_yaw(10.0, 0.0, 1, False) == 4  # GUIDED only


def test_plnd_enabled_acts_live_but_plnd_type_needs_a_reboot() -> None:
    v = _with_precland(0)
    assert v.precland.enabled
    v.param_set("PLND_ENABLED", 0)
    assert not v.precland.enabled
    v.landing_target(_target_msg(v, (0.0, 0.0)))
    assert v.precland.measurements == 0
    v.param_set("PLND_ENABLED", 1)
    assert v.precland.enabled
    v.param_set("PLND_TYPE", 0)
    assert v.precland.enabled  # the backend made at boot stays until the next reboot
    assert v.reboot() == 0
    assert not v.precland.enabled


def test_loiter_sticks_fly_the_vehicle_and_centred_sticks_brake() -> None:
    v = _airborne(4.0)
    assert v.set_mode(LOITER) == 0
    yaw = v.truth.yaw
    v.rc_override(255, [1500, 1300, 1500, 1500])  # pitch forward
    v.step(3.0)
    t = v.truth
    fwd = t.velocity_ned[0] * math.cos(yaw) + t.velocity_ned[1] * math.sin(yaw)
    assert fwd > 2.0
    assert abs(-t.position_ned[2] - 4.0) < 0.3
    v.rc_override(255, [1500, 1500, 1500, 1500])
    v.step(5.0)
    assert math.hypot(*v.truth.velocity_ned[:2]) < 0.1


@pytest.mark.parametrize(("declared_ms", "worst_m"), [(150, 0.03), (10, None)])
def test_vision_is_fused_at_its_stamped_time_less_the_declared_delay(
    declared_ms: int, worst_m: float | None
) -> None:
    # AP_VisualOdom: the steady capture -> arrival lag is taken for clock offset, so only
    # VISO_DELAY_MS says how old a pose is; a pose 150 ms old declared as 10 ms pulls the
    # estimate back along the track by speed x 0.14 s
    v = _ready()
    v.param_set("VISO_TYPE", 1)
    v.param_set("VISO_DELAY_MS", declared_ms)
    v.param_set("ARMING_CHECK", 1835006)  # all but vision: arms on GPS
    assert v.reboot() == 0
    v.step(1.0)
    assert v.set_mode(GUIDED) == 0 and v.arm() == 0 and v.takeoff(5.0) == 0
    v.step(10.0)
    assert v.nav.set_source_set(1)
    v.param_set("EK3_SRC1_POSXY", 6)  # vision as the position source
    history: list[tuple[float, tuple[float, float, float]]] = []
    errors = []
    for i in range(120):
        history.append((v.boot_s, v.truth.position_ned))
        if len(history) > 3:  # the pose of 3 frames ago (0.15 s), stamped with its time
            t, pos = history[-4]
            assert v.vision_position(*pos, round(t * 1e6))
        v.guided_velocity(2.0, 0.0, 0.0)
        v.step(0.05)
        if i > 60:
            errors.append(v.estimate.position_ned[0] - v.truth.position_ned[0])
    worst = max(abs(e) for e in errors)
    if worst_m is not None:
        assert worst < worst_m
    else:
        assert min(errors) < -0.2  # lags behind the truth: 2 m/s x 0.14 s
