import { describe, expect, it } from "vitest";
import { describeEkf, readiness } from "../../src/lib/readiness";

const base = { mode: "GUIDED", armed: false, prearmOk: true, ekfPosOk: true, statustexts: [], now: 1000 };

describe("readiness", () => {
  it("is ready only when the vehicle says so for this mode", () => {
    expect(readiness(base)).toEqual({ ready: true, text: "ready to arm in GUIDED" });
  });
  it("is not ready in GUIDED without a position estimate, though pre-arm checks pass", () => {
    expect(readiness({ ...base, ekfPosOk: false })).toEqual({ ready: false, text: "not ready to arm in GUIDED: no position estimate yet" });
    // STABILIZE needs no position
    expect(readiness({ ...base, mode: "STABILIZE", ekfPosOk: false }).ready).toBe(true);
  });
  it("gives the vehicle's own latest reason, if recent", () => {
    const texts = [
      { t: 990, severity: 2, text: "PreArm: GPS 1: Bad fix" },
      { t: 995, severity: 2, text: "Arm: Need Position Estimate" },
    ];
    expect(readiness({ ...base, prearmOk: false, statustexts: texts }).text).toBe("not ready to arm in GUIDED: Arm: Need Position Estimate");
    expect(readiness({ ...base, prearmOk: false, statustexts: texts, now: 2000 }).text).toBe("not ready to arm in GUIDED: pre-arm checks failing");
  });
  it("says armed, and waits before the first report", () => {
    expect(readiness({ ...base, armed: true }).text).toBe("armed in GUIDED");
    expect(readiness({ ...base, prearmOk: null }).ready).toBeNull();
  });
});

describe("describeEkf", () => {
  it("names the state, never raw flags", () => {
    expect(describeEkf(true, 0x3ff & ~128, true)).toEqual({ text: "position OK", level: "ok" });
    expect(describeEkf(true, 1 | 4 | 32, false).text).toBe("no position estimate yet");
    expect(describeEkf(false, 1 | 4, false).text).toBe("unhealthy (no horizontal velocity, relative horizontal position, absolute horizontal position, absolute vertical position)");
    expect(describeEkf(null, null, null).text).toBe("—");
    expect(describeEkf(false, 1024, false).text).toBe("initialising");
  });
});
