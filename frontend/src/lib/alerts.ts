// Alerts the operator cannot miss: link lost, battery low/critical (from the vehicle's
// BATT_* thresholds when it has them), failsafes, the EKF failing, a mission that
// aborted or failed. Pure: fed the state, it says which alerts are active; the widget
// shows them with a sound until the operator acknowledges each one.

import type { StatusText } from "./telemetry";

export type AlertLevel = "critical" | "warning";

export interface Alert {
  /** Stable id: the same condition keeps its id (and its acknowledgement). */
  id: string;
  level: AlertLevel;
  title: string;
  detail: string;
}

export interface BatteryThresholds {
  BATT_LOW_VOLT: number | null;
  BATT_CRT_VOLT: number | null;
  BATT_LOW_MAH: number | null;
  BATT_CRT_MAH: number | null;
  BATT_CAPACITY: number | null;
}

export interface AlertInput {
  linkState: string;
  serverConnected: boolean;
  armed: boolean | null;
  batteryV: number | null;
  batteryPct: number | null;
  mahUsed: number | null;
  thresholds: BatteryThresholds | null;
  ekfHealthy: boolean | null;
  /** The EKF was healthy since the link came up (failing only counts after that). */
  ekfWasHealthy: boolean;
  statustexts: StatusText[];
  mission: { run_id?: number | null; outcome?: string | null; message?: string; kind?: string } | null;
  /** UNIX seconds now. */
  now: number;
}

const FAILSAFE = /failsafe|battery \d+ is (low|critical)/i;
/** Failsafe texts older than this are history, not an alert. */
const TEXT_WINDOW_S = 120;

function positive(v: number | null | undefined): v is number {
  return typeof v === "number" && Number.isFinite(v) && v > 0;
}

/** The battery's level against the thresholds (percent fallbacks when none are set). */
export function batteryLevel(x: Pick<AlertInput, "batteryV" | "batteryPct" | "mahUsed" | "thresholds">): {
  level: "critical" | "low" | "ok" | null;
  why: string;
} {
  const t = x.thresholds;
  const v = x.batteryV;
  const left = t && positive(t.BATT_CAPACITY) && x.mahUsed !== null ? t.BATT_CAPACITY - x.mahUsed : null;
  if (t && v !== null) {
    if (positive(t.BATT_CRT_VOLT) && v < t.BATT_CRT_VOLT) return { level: "critical", why: `${v.toFixed(2)} V, below BATT_CRT_VOLT ${t.BATT_CRT_VOLT} V` };
    if (positive(t.BATT_CRT_MAH) && left !== null && left < t.BATT_CRT_MAH) return { level: "critical", why: `${Math.round(left)} mAh left, below BATT_CRT_MAH ${t.BATT_CRT_MAH}` };
    if (positive(t.BATT_LOW_VOLT) && v < t.BATT_LOW_VOLT) return { level: "low", why: `${v.toFixed(2)} V, below BATT_LOW_VOLT ${t.BATT_LOW_VOLT} V` };
    if (positive(t.BATT_LOW_MAH) && left !== null && left < t.BATT_LOW_MAH) return { level: "low", why: `${Math.round(left)} mAh left, below BATT_LOW_MAH ${t.BATT_LOW_MAH}` };
    if (positive(t.BATT_LOW_VOLT) || positive(t.BATT_CRT_VOLT)) return { level: "ok", why: "" };
  }
  const pct = x.batteryPct;
  if (pct === null) return { level: null, why: "" };
  if (pct < 10) return { level: "critical", why: `${pct} % left (no BATT_* thresholds read)` };
  if (pct < 25) return { level: "low", why: `${pct} % left (no BATT_* thresholds read)` };
  return { level: "ok", why: "" };
}

/** Every alert active now. */
export function activeAlerts(x: AlertInput): Alert[] {
  const out: Alert[] = [];
  if (!x.serverConnected) {
    out.push({ id: "server", level: "critical", title: "Server connection lost", detail: "Values shown are stale; reconnecting." });
  } else if (x.linkState === "lost" || x.linkState === "closed") {
    out.push({ id: "link", level: "critical", title: "Vehicle link lost", detail: "No heartbeat: commands cannot reach the vehicle; its own failsafe decides." });
  }
  const battery = batteryLevel(x);
  if (battery.level === "critical") out.push({ id: "battery-critical", level: "critical", title: "Battery critical", detail: battery.why });
  else if (battery.level === "low") out.push({ id: "battery-low", level: "warning", title: "Battery low", detail: battery.why });
  for (const s of x.statustexts) {
    if (s.t === null || x.now - s.t > TEXT_WINDOW_S || !FAILSAFE.test(s.text)) continue;
    out.push({ id: `failsafe-${s.t}-${s.text}`, level: "critical", title: "Failsafe", detail: `The vehicle says: ${s.text}` });
  }
  if (x.ekfHealthy === false && (x.ekfWasHealthy || x.armed)) {
    out.push({ id: "ekf", level: "critical", title: "EKF failing", detail: "The position estimate is no longer trusted: land or take manual control." });
  }
  const m = x.mission;
  // an abort the operator asked for is no surprise: the ABORT answer already says so
  const byOperator = /operator/i.test(m?.message ?? "");
  if (m && !byOperator && (m.outcome === "aborted" || m.outcome === "failed" || m.outcome === "link_lost" || m.outcome === "landed_in_place" || m.outcome === "landed_blind")) {
    out.push({
      id: `mission-${m.run_id ?? "?"}-${m.outcome}`,
      level: "warning",
      title: `Mission ${m.outcome === "link_lost" ? "lost its link" : m.outcome === "landed_in_place" ? "landed off the pad" : m.outcome === "landed_blind" ? "landed blind (not a precision landing)" : m.outcome}`,
      detail: m.message ?? "",
    });
  }
  return out;
}

/** Acknowledgements to forget: a condition that ended may alarm again when it comes
 * back. A battery alert ends only when the battery reads better, never when its reading
 * is missing for a moment (a telemetry gap is not a charged battery). */
export function endedAcks(
  acked: Iterable<string>,
  activeIds: Set<string>,
  battery: ReturnType<typeof batteryLevel>["level"],
): string[] {
  const out: string[] = [];
  for (const id of acked) {
    if (activeIds.has(id)) continue;
    if (id === "link" || id === "server" || id === "ekf") out.push(id);
    else if (id === "battery-low" && battery === "ok") out.push(id);
    else if (id === "battery-critical" && (battery === "ok" || battery === "low")) out.push(id);
  }
  return out;
}

/** Alerts not yet acknowledged (acknowledgements are by id). */
export function unacknowledged(alerts: Alert[], acked: Set<string>): Alert[] {
  return alerts.filter((a) => !acked.has(a.id));
}
