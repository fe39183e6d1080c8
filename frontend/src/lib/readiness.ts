// What the vehicle itself says about arming now: its pre-arm flag, the EKF's position
// estimate (modes that navigate need one), and its latest "PreArm:"/"Arm:" texts.
// EKF flags are named, never shown as raw hex.

import type { StatusText } from "./telemetry";

/** ArduCopter modes that need a position estimate to arm or fly. */
export const NEEDS_POSITION = new Set(["GUIDED", "LOITER", "POSHOLD", "AUTO", "RTL", "BRAKE", "CIRCLE", "DRIFT", "SMART_RTL", "FOLLOW", "ZIGZAG", "AUTO_RTL"]);

export const EKF_FLAGS: [number, string][] = [
  [1, "attitude"],
  [2, "horizontal velocity"],
  [4, "vertical velocity"],
  [8, "relative horizontal position"],
  [16, "absolute horizontal position"],
  [32, "absolute vertical position"],
  [64, "height above ground"],
  [128, "constant position mode"],
  [256, "predicted relative position"],
  [512, "predicted absolute position"],
  [1024, "uninitialised"],
];

/** The estimates the EKF reports as good, by name. */
export function ekfGood(flags: number | null): string[] {
  if (flags === null) return [];
  return EKF_FLAGS.filter(([bit, name]) => (flags & bit) !== 0 && bit < 128 && name).map(([, n]) => n);
}

export interface EkfView {
  text: string;
  level: "ok" | "warn" | "bad" | "";
}

/** The EKF in words: "position OK", "no position estimate yet", "unhealthy (...)". */
export function describeEkf(healthy: boolean | null, flags: number | null, posOk: boolean | null): EkfView {
  if (healthy === null && flags === null) return { text: "—", level: "" };
  const f = flags ?? 0;
  if ((f & 1024) !== 0 || (f & 1) === 0) return { text: "initialising", level: "warn" };
  if (healthy === false) {
    const missing = EKF_FLAGS.filter(([bit]) => bit <= 32 && (f & bit) === 0).map(([, n]) => n);
    return { text: `unhealthy${missing.length ? ` (no ${missing.join(", ")})` : ""}`, level: "bad" };
  }
  if (posOk === false || (f & 16) === 0 || (f & 128) !== 0) return { text: "no position estimate yet", level: "warn" };
  return { text: "position OK", level: "ok" };
}

export interface Readiness {
  ready: boolean | null;
  text: string;
}

export interface ReadinessInput {
  mode: string | null;
  armed: boolean | null;
  prearmOk: boolean | null;
  ekfPosOk: boolean | null;
  statustexts: StatusText[];
  /** UNIX seconds now (texts older than 30 s no longer explain the state). */
  now: number;
}

const RECENT_S = 30;

/** "ready to arm in GUIDED" or "not ready to arm in GUIDED: <the vehicle's reason>". */
export function readiness(x: ReadinessInput): Readiness {
  const mode = x.mode ?? "this mode";
  if (x.armed) return { ready: true, text: `armed in ${mode}` };
  if (x.prearmOk === null) return { ready: null, text: "waiting for the vehicle's pre-arm state" };
  const recent = x.statustexts.filter((s) => s.t !== null && x.now - s.t <= RECENT_S && /^(PreArm|Arm):/.test(s.text));
  const last = recent.length ? recent[recent.length - 1].text : null;
  if (!x.prearmOk) {
    return { ready: false, text: `not ready to arm in ${mode}${last ? `: ${last}` : ": pre-arm checks failing"}` };
  }
  if (x.mode !== null && NEEDS_POSITION.has(x.mode) && x.ekfPosOk === false) {
    return { ready: false, text: `not ready to arm in ${mode}: no position estimate yet` };
  }
  return { ready: true, text: `ready to arm in ${mode}` };
}
