import { describe, expect, it } from "vitest";
import { asMount, describeMount, liveSuggestion, parseMount } from "../../src/lib/mount";

const warning = (suggested: number[], lean = 8) => ({ kind: "vision", text: "The pad's pixels lean it…", lean_deg: lean, detections: 30, suggested_mount_deg: suggested });
const allClear = { kind: "vision", text: "The pad's pixels lie level…", lean_deg: 0.9, detections: 40 };
const mountChanged = { kind: "settings", text: "settings changed", changes: { camera_mount_deg: [0, 8, 0] } };

describe("parseMount", () => {
  it("takes three numbers within the station's bounds", () => {
    expect(parseMount(["0.1", " 8 ", "-180"])).toEqual({ ok: true, mount: [0.1, 8, -180] });
    expect(parseMount(["-45", "45", "180"])).toEqual({ ok: true, mount: [-45, 45, 180] });
    expect(parseMount(["0", "1e1", "-0"])).toEqual({ ok: true, mount: [0, 10, -0] });
  });
  it("refuses an empty field or one that is no number, naming it", () => {
    expect(parseMount(["", "0", "0"])).toEqual({ ok: false, error: "Roll must be a number of degrees." });
    expect(parseMount(["0", "abc", "0"])).toEqual({ ok: false, error: "Pitch must be a number of degrees." });
    expect(parseMount(["0", "0", "Infinity"])).toEqual({ ok: false, error: "Yaw must be a number of degrees." });
    expect(parseMount(["0", "0", "NaN"])).toEqual({ ok: false, error: "Yaw must be a number of degrees." });
  });
  it("refuses an angle out of bounds with the bounds and the value", () => {
    expect(parseMount(["0", "60", "0"])).toEqual({ ok: false, error: "Pitch must be between -45 and 45 degrees; 60 is outside." });
    expect(parseMount(["-45.1", "0", "0"])).toEqual({ ok: false, error: "Roll must be between -45 and 45 degrees; -45.1 is outside." });
    expect(parseMount(["0", "0", "181"])).toEqual({ ok: false, error: "Yaw must be between -180 and 180 degrees; 181 is outside." });
  });
  it("names the first problem", () => {
    expect(parseMount(["90", "", "200"])).toEqual({ ok: false, error: "Roll must be between -45 and 45 degrees; 90 is outside." });
  });
});

describe("asMount and describeMount", () => {
  it("takes only three finite numbers", () => {
    expect(asMount([0.1, 8, 0])).toEqual([0.1, 8, 0]);
    for (const bad of [undefined, null, [1, 2], [1, 2, 3, 4], [1, "2", 3], [1, NaN, 3], { 0: 1, 1: 2, 2: 3, length: 3 }]) {
      expect(asMount(bad)).toBeNull();
    }
  });
  it("says a mount to a tenth of a degree, never -0", () => {
    expect(describeMount([0.1, 8, 0])).toBe("roll 0.1°, pitch 8°, yaw 0°");
    expect(describeMount([-0.04, 12.25, -90])).toBe("roll 0°, pitch 12.3°, yaw -90°");
  });
});

describe("liveSuggestion", () => {
  it("is the latest warning's suggested mount", () => {
    expect(liveSuggestion([warning([1, 2, 0], 4), { kind: "link_up", text: "link up" }, warning([0.1, 8, 0])])).toEqual({ mount: [0.1, 8, 0], leanDeg: 8 });
  });
  it("is none without a warning, or once the lean cleared", () => {
    expect(liveSuggestion([])).toBeNull();
    expect(liveSuggestion([{ kind: "vision", text: "pad found" }])).toBeNull();
    expect(liveSuggestion([warning([0.1, 8, 0]), allClear])).toBeNull();
    expect(liveSuggestion([allClear, warning([0.1, 8, 0])])?.mount).toEqual([0.1, 8, 0]);
  });
  it("is stale once the camera's mount changed, not when other settings did", () => {
    expect(liveSuggestion([warning([0.1, 8, 0]), mountChanged])).toBeNull();
    expect(liveSuggestion([warning([0.1, 8, 0]), { kind: "settings", text: "settings changed", changes: { record_frames: false } }])?.mount).toEqual([0.1, 8, 0]);
    expect(liveSuggestion([mountChanged, warning([0.2, 7, 0])])?.mount).toEqual([0.2, 7, 0]);
  });
  it("skips vision events that are not the mount check's, and a malformed suggestion", () => {
    expect(liveSuggestion([warning([0.1, 8, 0]), { kind: "vision", text: "reference verified" }])?.mount).toEqual([0.1, 8, 0]);
    expect(liveSuggestion([warning([0.1, 8])])).toBeNull();
  });
});
