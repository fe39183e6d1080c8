import { describe, expect, it } from "vitest";
import { activeAlerts, type AlertInput, batteryLevel, endedAcks, unacknowledged } from "../../src/lib/alerts";

const quiet: AlertInput = {
  linkState: "up",
  serverConnected: true,
  armed: false,
  batteryV: 12.4,
  batteryPct: 90,
  mahUsed: null,
  thresholds: null,
  ekfHealthy: true,
  ekfWasHealthy: true,
  statustexts: [],
  mission: null,
  now: 1000,
};
const thresholds = { BATT_LOW_VOLT: 11.0, BATT_CRT_VOLT: 10.5, BATT_LOW_MAH: 0, BATT_CRT_MAH: 0, BATT_CAPACITY: 3300 };

describe("activeAlerts", () => {
  it("is quiet when all is well", () => {
    expect(activeAlerts(quiet)).toEqual([]);
  });
  it("alerts on a lost link and a lost server", () => {
    expect(activeAlerts({ ...quiet, linkState: "lost" }).map((a) => a.id)).toEqual(["link"]);
    expect(activeAlerts({ ...quiet, serverConnected: false, linkState: "lost" }).map((a) => a.id)).toEqual(["server"]);
  });
  it("uses the vehicle's BATT_* thresholds when it has them", () => {
    expect(activeAlerts({ ...quiet, thresholds, batteryV: 10.9 }).map((a) => a.id)).toEqual(["battery-low"]);
    expect(activeAlerts({ ...quiet, thresholds, batteryV: 10.4 }).map((a) => a.id)).toEqual(["battery-critical"]);
    // 90 % left but under BATT_LOW_VOLT: the threshold decides
    expect(batteryLevel({ batteryV: 10.9, batteryPct: 90, mahUsed: null, thresholds }).why).toContain("BATT_LOW_VOLT");
    // no thresholds: the percentage
    expect(batteryLevel({ batteryV: 11, batteryPct: 20, mahUsed: null, thresholds: null }).level).toBe("low");
    expect(batteryLevel({ batteryV: 11, batteryPct: 20, mahUsed: 3100, thresholds: { ...thresholds, BATT_CRT_MAH: 300 } }).level).toBe("critical");
  });
  it("alerts on recent failsafe texts, the EKF failing after it was healthy, and aborted missions", () => {
    const texts = [{ t: 990, severity: 2, text: "Battery 1 is low 10.40V used 2900 mAh" }, { t: 500, severity: 2, text: "GCS Failsafe" }];
    expect(activeAlerts({ ...quiet, statustexts: texts }).map((a) => a.title)).toEqual(["Failsafe"]);
    expect(activeAlerts({ ...quiet, ekfHealthy: false }).map((a) => a.id)).toEqual(["ekf"]);
    expect(activeAlerts({ ...quiet, ekfHealthy: false, ekfWasHealthy: false })).toEqual([]);
    const m = activeAlerts({ ...quiet, mission: { run_id: 3, outcome: "aborted", message: "pad not found", kind: "land" } });
    expect(m.map((a) => [a.id, a.title])).toEqual([["mission-3-aborted", "Mission aborted"]]);
    expect(activeAlerts({ ...quiet, mission: { run_id: 4, outcome: "landed", message: "" } })).toEqual([]);
    // down where it was after the pad was lost without GPS: not on the pad
    const inPlace = activeAlerts({ ...quiet, mission: { run_id: 6, outcome: "landed_in_place", message: "landed in place 1.10 m from the pad centre" } });
    expect(inPlace.map((a) => [a.id, a.title])).toEqual([["mission-6-landed_in_place", "Mission landed off the pad"]]);
    // the operator's own abort is no surprise
    const blind = activeAlerts({ ...quiet, mission: { run_id: 7, outcome: "landed_blind", message: "landed blind, not a precision landing" } });
    expect(blind.map((a) => a.title)).toEqual(["Mission landed blind (not a precision landing)"]);
    expect(activeAlerts({ ...quiet, mission: { run_id: 5, outcome: "aborted", message: "stopped by the operator's ABORT" } })).toEqual([]);
  });
  it("leaves acknowledged ones out", () => {
    const all = activeAlerts({ ...quiet, linkState: "lost", thresholds, batteryV: 10.9 });
    expect(unacknowledged(all, new Set(["link"])).map((a) => a.id)).toEqual(["battery-low"]);
  });
  it("forgets an acknowledgement only when its condition has really ended", () => {
    const acked = ["link", "battery-low", "failsafe-1-Battery 1 is low"];
    // the link is back; the battery's reading is missing for a moment: unknown, not charged
    expect(endedAcks(acked, new Set(), null)).toEqual(["link"]);
    expect(endedAcks(acked, new Set(["battery-low"]), "low")).toEqual(["link"]);
    // charged again (or the threshold lowered): a later low battery alarms anew
    expect(endedAcks(acked, new Set(), "ok")).toEqual(["link", "battery-low"]);
    // critical ends when the battery reads only low; a failsafe text stays acknowledged
    expect(endedAcks(["battery-critical"], new Set(["battery-low"]), "low")).toEqual(["battery-critical"]);
    expect(endedAcks(["battery-critical"], new Set(), null)).toEqual([]);
  });
});
