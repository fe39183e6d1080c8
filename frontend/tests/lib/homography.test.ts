import { describe, expect, it } from "vitest";
import {
  applyHomography,
  fitHomography,
  invert,
  type Matrix3,
  multiply,
  rmsError,
} from "../../src/lib/homography";
import type { Point } from "../../src/lib/protocol";

// The H pad's 12 corners (metres), like the reference's corners_m.
const H: Point[] = [
  [-0.25, 0.25], [-0.15, 0.25], [-0.15, 0.05], [0.15, 0.05], [0.15, 0.25], [0.25, 0.25],
  [0.25, -0.25], [0.15, -0.25], [0.15, -0.05], [-0.15, -0.05], [-0.15, -0.25], [-0.25, -0.25],
];

// A camera's view: perspective, rotation, scale, offset (metres -> pixels).
const TRUE: Matrix3 = [620, -90, 320, 110, 580, 240, 0.3, -0.2, 1];

describe("fitHomography", () => {
  it("recovers a known perspective map from the 12 corners", () => {
    const px = H.map((p) => applyHomography(TRUE, p));
    const back = fitHomography(px, H);
    for (let i = 0; i < H.length; i += 1) {
      const [x, y] = applyHomography(back, px[i]);
      expect(x).toBeCloseTo(H[i][0], 9);
      expect(y).toBeCloseTo(H[i][1], 9);
    }
    expect(rmsError(back, px, H)).toBeLessThan(1e-9);
    const product = multiply(back, TRUE);
    const k = product[8];
    expect(product.map((v) => v / k).map((v) => Number(v.toFixed(9)) + 0)).toEqual([1, 0, 0, 0, 1, 0, 0, 0, 1]);
  });

  it("fits in least squares when the corners are noisy", () => {
    let seed = 1;
    const rand = () => {
      seed = (seed * 16807) % 2147483647;
      return seed / 2147483647 - 0.5;
    };
    const px = H.map((p) => applyHomography(TRUE, p)).map(([x, y]) => [x + rand(), y + rand()] as Point);
    const back = fitHomography(px, H);
    // one pixel of noise on a ~300 px pad: millimetres of error
    expect(rmsError(back, px, H)).toBeLessThan(0.003);
    expect(rmsError(back, px, H)).toBeGreaterThan(0);
  });

  it("refuses mismatched, too few, non-finite and degenerate input", () => {
    expect(() => fitHomography(H.slice(0, 5), H.slice(0, 4))).toThrowError("differ in length");
    expect(() => fitHomography(H.slice(0, 3), H.slice(0, 3))).toThrowError("at least 4");
    const bad = H.slice(0, 4).map((p, i) => (i === 2 ? ([Number.NaN, 0] as Point) : p));
    expect(() => fitHomography(bad, H.slice(0, 4))).toThrowError("src must hold finite");
    const same: Point[] = [[1, 1], [1, 1], [1, 1], [1, 1]];
    expect(() => fitHomography(same, H.slice(0, 4))).toThrowError(RangeError);
    const line: Point[] = [[0, 0], [1, 1], [2, 2], [3, 3]];
    expect(() => fitHomography(line, H.slice(0, 4))).toThrowError(RangeError);
  });

  it("inverts a matrix and refuses a singular one", () => {
    const inv = invert(TRUE);
    const p = applyHomography(inv, applyHomography(TRUE, [0.1, -0.2]));
    expect(p[0]).toBeCloseTo(0.1, 12);
    expect(p[1]).toBeCloseTo(-0.2, 12);
    expect(() => invert([1, 2, 3, 2, 4, 6, 0, 0, 1])).toThrowError("singular");
  });
});
