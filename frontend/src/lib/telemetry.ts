// Reads the Telemetry snapshot (protocol.ts) into the flat view the flight panel shows.
// The reader accepts the small variations a snapshot may have (nested objects or
// arrays, missing groups before the first message of a kind) and never throws.

export interface StatusText {
  t: number | null;
  severity: number | null;
  text: string;
}

export interface FlightView {
  linkState: string;
  armed: boolean | null;
  mode: string | null;
  altitudeM: number | null;
  rollDeg: number | null;
  pitchDeg: number | null;
  yawDeg: number | null;
  headingDeg: number | null;
  climbMps: number | null;
  groundSpeedMps: number | null;
  batteryV: number | null;
  batteryA: number | null;
  batteryPct: number | null;
  gpsFix: number | null;
  gpsSats: number | null;
  gpsHdop: number | null;
  ekfHealthy: boolean | null;
  ekfFlags: number | null;
  prearmOk: boolean | null;
  rangefinderM: number | null;
  heartbeatAgeS: number | null;
  msgsPerS: number | null;
  crcErrors: number | null;
  statustexts: StatusText[];
}

type Obj = Record<string, unknown>;

function get(obj: unknown, path: string): unknown {
  let cur: unknown = obj;
  for (const part of path.split(".")) {
    if (cur === null || cur === undefined) return undefined;
    if (Array.isArray(cur) && /^\d+$/.test(part)) {
      cur = cur[Number(part)];
    } else if (typeof cur === "object") {
      cur = (cur as Obj)[part];
    } else {
      return undefined;
    }
  }
  return cur;
}

/** The first path holding a finite number, or null. */
export function num(obj: unknown, ...paths: string[]): number | null {
  for (const path of paths) {
    const v = get(obj, path);
    if (typeof v === "number" && Number.isFinite(v)) return v;
  }
  return null;
}

function bool(obj: unknown, ...paths: string[]): boolean | null {
  for (const path of paths) {
    const v = get(obj, path);
    if (typeof v === "boolean") return v;
  }
  return null;
}

function str(obj: unknown, ...paths: string[]): string | null {
  for (const path of paths) {
    const v = get(obj, path);
    if (typeof v === "string" && v) return v;
  }
  return null;
}

const RAD = 180 / Math.PI;

function deg(rad: number | null): number | null {
  return rad === null ? null : rad * RAD;
}

function statustextsOf(t: unknown): StatusText[] {
  const raw = get(t, "statustexts");
  if (!Array.isArray(raw)) return [];
  const out: StatusText[] = [];
  for (const item of raw) {
    if (Array.isArray(item)) {
      // (time, severity, text)
      const [time, severity, text] = item;
      out.push({
        t: typeof time === "number" ? time : null,
        severity: typeof severity === "number" ? severity : null,
        text: String(text ?? ""),
      });
    } else if (item && typeof item === "object") {
      const o = item as Obj;
      out.push({
        t: num(o, "t", "time", "time_s"),
        severity: num(o, "severity"),
        text: String(o.text ?? ""),
      });
    } else if (typeof item === "string") {
      out.push({ t: null, severity: null, text: item });
    }
  }
  return out;
}

/** Reads any snapshot-like value (a Telemetry, a partial one, or older shapes). */
export function readTelemetry(t: unknown): FlightView {
  const x: unknown = t ?? {};
  const alt = num(x, "relative_alt_m", "global_position.relative_alt_m", "altitude_m");
  const down = num(x, "position_ned.z", "position_ned.2");
  return {
    linkState: str(x, "state", "link.state") ?? "unknown",
    armed: bool(x, "armed"),
    mode: str(x, "mode"),
    altitudeM: alt ?? (down === null ? null : -down),
    rollDeg: deg(num(x, "attitude.roll", "attitude.0")),
    pitchDeg: deg(num(x, "attitude.pitch", "attitude.1")),
    yawDeg: deg(num(x, "attitude.yaw", "attitude.2")),
    headingDeg: num(x, "heading_deg", "global_position.heading_deg"),
    climbMps: (() => {
      const vd = num(x, "velocity_ned.z", "velocity_ned.vz", "velocity_ned.2");
      return vd === null ? null : -vd;
    })(),
    groundSpeedMps: (() => {
      const vn = num(x, "velocity_ned.x", "velocity_ned.vx", "velocity_ned.0");
      const ve = num(x, "velocity_ned.y", "velocity_ned.vy", "velocity_ned.1");
      return vn === null || ve === null ? null : Math.hypot(vn, ve);
    })(),
    batteryV: num(x, "battery.voltage", "battery.voltage_v"),
    batteryA: num(x, "battery.current", "battery.current_a"),
    batteryPct: num(x, "battery.remaining", "battery.remaining_pct"),
    gpsFix: num(x, "gps.fix_type"),
    gpsSats: num(x, "gps.satellites", "gps.satellites_visible"),
    gpsHdop: num(x, "gps.hdop"),
    ekfHealthy: bool(x, "ekf.healthy"),
    ekfFlags: num(x, "ekf.flags"),
    prearmOk: bool(x, "prearm_ok"),
    rangefinderM: num(x, "rangefinder_m"),
    heartbeatAgeS: num(x, "heartbeat_age_s", "link.heartbeat_age_s"),
    msgsPerS: num(x, "msgs_per_s", "link.msgs_per_s"),
    crcErrors: num(x, "crc_errors", "link.crc_errors"),
    statustexts: statustextsOf(x),
  };
}

const GPS_FIX = ["no GPS", "no fix", "2D fix", "3D fix", "DGPS", "RTK float", "RTK fixed", "static", "PPP"];

export function gpsFixName(fix: number | null): string {
  if (fix === null) return "—";
  return GPS_FIX[fix] ?? `fix ${fix}`;
}

const SEVERITY = ["EMERGENCY", "ALERT", "CRITICAL", "ERROR", "WARNING", "NOTICE", "INFO", "DEBUG"];

export function severityName(severity: number | null): string {
  if (severity === null) return "";
  return SEVERITY[severity] ?? String(severity);
}
