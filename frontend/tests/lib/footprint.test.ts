import { describe, expect, it } from "vitest";
import { cameraFootprint } from "../../src/lib/footprint";

describe("cameraFootprint", () => {
  it("is a rectangle under a level vehicle, as wide as the field of view", () => {
    const fp = cameraFootprint([0, 0, -2], 0, 0, 0, 90, 2);
    expect(fp).not.toBeNull();
    const [tl, tr, br, bl] = fp as [number, number][];
    // 90 degrees across at 2 m: 4 m wide (east), 2 m deep (north); image top = forward
    expect(tr[1] - tl[1]).toBeCloseTo(4, 6);
    expect(tl[0] - bl[0]).toBeCloseTo(2, 6);
    expect(tl[0]).toBeCloseTo(1, 6);
    expect(br[1]).toBeCloseTo(2, 6);
  });
  it("turns with the heading and slides with a pitch", () => {
    const east = cameraFootprint([0, 0, -2], 0, 0, Math.PI / 2, 90, 2) as [number, number][];
    // facing east, the image top is east of the vehicle
    expect(east[0][1]).toBeCloseTo(1, 6);
    const nose = cameraFootprint([0, 0, -2], 0, 0.2, 0, 60, 4 / 3) as [number, number][];
    const centreN = nose.reduce((s, p) => s + p[0], 0) / 4;
    expect(centreN).toBeGreaterThan(0.3); // nose up: the camera looks forward
  });
  it("is null on the ground or when a ray misses the ground", () => {
    expect(cameraFootprint([0, 0, 0], 0, 0, 0, 60, 4 / 3)).toBeNull();
    expect(cameraFootprint([0, 0, -2], 0, 1.4, 0, 60, 4 / 3)).toBeNull();
  });
});
