import { describe, expect, it } from "vitest";
import { gpsFixName, num, readTelemetry, severityName } from "../../src/lib/telemetry";

describe("readTelemetry", () => {
  it("reads a full nested snapshot", () => {
    const v = readTelemetry({
      state: "up",
      armed: true,
      mode: "GUIDED",
      relative_alt_m: 2.5,
      attitude: { roll: Math.PI / 18, pitch: -Math.PI / 36, yaw: Math.PI / 2 },
      velocity_ned: { x: 3, y: 4, z: -0.5 },
      heading_deg: 90,
      battery: { voltage: 12.4, current: 8.1, remaining: 77 },
      gps: { fix_type: 3, satellites: 10, hdop: 0.9 },
      ekf: { flags: 831, healthy: true, pos_horiz_ok: true },
      prearm_ok: true,
      rangefinder_m: 2.4,
      heartbeat_age_s: 0.3,
      msgs_per_s: 55,
      crc_errors: 2,
      statustexts: [[1.5, 6, "EKF3 IMU0 is using GPS"], { t: 2, severity: 4, text: "PreArm: x" }, "plain"],
    });
    expect(v).toMatchObject({
      linkState: "up",
      armed: true,
      mode: "GUIDED",
      altitudeM: 2.5,
      headingDeg: 90,
      climbMps: 0.5,
      groundSpeedMps: 5,
      batteryV: 12.4,
      batteryPct: 77,
      gpsFix: 3,
      gpsSats: 10,
      ekfHealthy: true,
      prearmOk: true,
      heartbeatAgeS: 0.3,
      crcErrors: 2,
    });
    expect(v.rollDeg).toBeCloseTo(10, 6);
    expect(v.pitchDeg).toBeCloseTo(-5, 6);
    expect(v.yawDeg).toBeCloseTo(90, 6);
    expect(v.statustexts).toEqual([
      { t: 1.5, severity: 6, text: "EKF3 IMU0 is using GPS" },
      { t: 2, severity: 4, text: "PreArm: x" },
      { t: null, severity: null, text: "plain" },
    ]);
  });

  it("falls back to -down for altitude and reads array forms", () => {
    const v = readTelemetry({ position_ned: [1, 2, -3.5], attitude: [0, 0, Math.PI], velocity_ned: [0, 0, 1] });
    expect(v.altitudeM).toBe(3.5);
    expect(v.yawDeg).toBeCloseTo(180, 6);
    expect(v.climbMps).toBe(-1);
  });

  it("gives nulls, not errors, for an empty or odd snapshot", () => {
    for (const t of [null, undefined, {}, { attitude: null, battery: "x", gps: 5, statustexts: "no" }]) {
      const v = readTelemetry(t as never);
      expect(v.altitudeM).toBeNull();
      expect(v.rollDeg).toBeNull();
      expect(v.armed).toBeNull();
      expect(v.batteryV).toBeNull();
      expect(v.statustexts).toEqual([]);
      expect(v.linkState).toBe("unknown");
    }
  });

  it("ignores non-finite numbers", () => {
    expect(num({ a: Number.NaN, b: 2 }, "a", "b")).toBe(2);
    expect(num({ a: "3" }, "a")).toBeNull();
  });

  it("names GPS fixes and severities", () => {
    expect(gpsFixName(3)).toBe("3D fix");
    expect(gpsFixName(null)).toBe("—");
    expect(gpsFixName(42)).toBe("fix 42");
    expect(severityName(2)).toBe("CRITICAL");
    expect(severityName(null)).toBe("");
  });
});
