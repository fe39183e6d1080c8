import { describe, expect, it } from "vitest";
import { fmt, fmtAge, fmtDate, fmtSci, huLog, plural } from "../../src/lib/format";

describe("format", () => {
  it("formats numbers with units and dashes for unknowns", () => {
    expect(fmt(2.345, 2, "m")).toBe("2.35 m");
    expect(fmt(-0.01, 1)).toBe("0.0");
    expect(fmt(null)).toBe("—");
    expect(fmt(Number.NaN)).toBe("—");
  });

  it("formats ages", () => {
    expect(fmtAge(0.42)).toBe("0.4 s");
    expect(fmtAge(42.4)).toBe("42 s");
    expect(fmtAge(600)).toBe("10 min");
    expect(fmtAge(-1)).toBe("0.0 s");
    expect(fmtAge(null)).toBe("—");
  });

  it("puts Hu moments on the log scale with their sign", () => {
    expect(huLog(0.001)).toBeCloseTo(3, 12);
    expect(huLog(-0.001)).toBeCloseTo(-3, 12);
    expect(huLog(0)).toBe(0);
    expect(huLog(null)).toBeNull();
    expect(fmtSci(0.000123, 2)).toBe("1.23e-4");
    expect(fmtSci(undefined)).toBe("—");
  });

  it("formats creation times from UNIX seconds or ISO strings", () => {
    const t = new Date(2026, 10, 22, 9, 5).getTime() / 1000;
    expect(fmtDate(t)).toBe("2026-11-22 09:05");
    expect(fmtDate(new Date(2026, 0, 2, 3, 4).toISOString())).toBe("2026-01-02 03:04");
    expect(fmtDate("not a date")).toBe("not a date");
    expect(fmtDate(null)).toBe("—");
  });

  it("counts nouns", () => {
    expect(plural(1, "other mark")).toBe("1 other mark");
    expect(plural(0, "other mark")).toBe("0 other marks");
    expect(plural(2, "smaller H", "smaller H's")).toBe("2 smaller H's");
    expect(plural(3, "other mark")).toBe("3 other marks");
    expect(plural(undefined, "other mark")).toBe("— other marks");
  });
});
