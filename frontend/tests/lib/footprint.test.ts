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
  it("follows the camera's mount", () => {
    const centre = (fp: [number, number][]) => [fp.reduce((s, p) => s + p[0], 0) / 4, fp.reduce((s, p) => s + p[1], 0) / 4];
    // pitched 20 degrees up on its mount, a level vehicle's camera looks ahead
    const ahead = centre(cameraFootprint([0, 0, -2], 0, 0, 0, 60, 4 / 3, [0, 20, 0]) as [number, number][]);
    expect(ahead[0]).toBeGreaterThan(0.5);
    // the same as the vehicle pitched 20 degrees with a downward camera
    const pitched = centre(cameraFootprint([0, 0, -2], 0, (20 * Math.PI) / 180, 0, 60, 4 / 3) as [number, number][]);
    expect(ahead[0]).toBeCloseTo(pitched[0], 9);
    // turned 90 degrees on its mount: the picture's top is the vehicle's right (east)
    const turned = cameraFootprint([0, 0, -2], 0, 0, 0, 90, 2, [0, 0, 90]) as [number, number][];
    expect(turned[0][1]).toBeCloseTo(1, 6);
  });
  it("is null on the ground or when a ray misses the ground", () => {
    expect(cameraFootprint([0, 0, 0], 0, 0, 0, 60, 4 / 3)).toBeNull();
    expect(cameraFootprint([0, 0, -2], 0, 1.4, 0, 60, 4 / 3)).toBeNull();
  });
});
