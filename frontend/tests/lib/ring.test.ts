import { describe, expect, it } from "vitest";
import { RateMeter, Ring } from "../../src/lib/ring";

describe("Ring", () => {
  it("keeps the newest items, oldest first", () => {
    const r = new Ring<number>(3);
    expect(r.toArray()).toEqual([]);
    expect(r.last()).toBeUndefined();
    for (let i = 1; i <= 7; i += 1) r.push(i);
    expect(r.length).toBe(3);
    expect(r.toArray()).toEqual([5, 6, 7]);
    expect(r.last()).toBe(7);
    r.clear();
    expect(r.length).toBe(0);
    r.push(9);
    expect(r.toArray()).toEqual([9]);
  });

  it("refuses a bad capacity", () => {
    for (const c of [0, -1, 1.5, Number.NaN]) expect(() => new Ring(c)).toThrowError("capacity");
  });
});

describe("RateMeter", () => {
  it("measures events per second in its window", () => {
    const m = new RateMeter(1000);
    expect(m.rate(0)).toBe(0);
    for (let t = 0; t <= 2000; t += 50) m.tick(t); // 20 Hz
    expect(m.rate(2000)).toBeCloseTo(20, 6);
    // long silence: the rate falls to zero instead of freezing at the last value
    expect(m.rate(5000)).toBe(0);
  });

  it("refuses a bad window", () => {
    expect(() => new RateMeter(0)).toThrowError("windowMs");
  });
});
