import { describe, expect, it } from "vitest";
import { at, clock, indexAt, missionStateAt } from "../../src/lib/timeline";

describe("timeline", () => {
  const items = [{ t: 1 }, { t: 2 }, { t: 2 }, { t: 5 }];
  it("finds the last entry at or before a time", () => {
    expect(indexAt(items, 0.5)).toBe(-1);
    expect(indexAt(items, 1)).toBe(0);
    expect(indexAt(items, 2.5)).toBe(2);
    expect(indexAt(items, 99)).toBe(3);
    expect(at([], 3)).toBeNull();
  });
  it("gives the mission state at a time", () => {
    const missions = [
      { id: 1, kind: "hover", strategy: null, states: [{ t: 10, state: "takeoff", reason: "" }, { t: 20, state: "hold", reason: "" }] },
      { id: 2, kind: "land", strategy: "plnd", states: [{ t: 30, state: "approach", reason: "looking" }] },
    ];
    expect(missionStateAt(missions, 5)).toBeNull();
    expect(missionStateAt(missions, 25)).toMatchObject({ run: 1, state: "hold" });
    expect(missionStateAt(missions, 31)).toMatchObject({ run: 2, state: "approach", strategy: "plnd" });
  });
  it("formats offsets", () => {
    expect(clock(75.9)).toBe("1:15");
    expect(clock(-3)).toBe("0:00");
  });
});
