// Number formatting for the panels: a dash for unknown values, fixed decimals, units.

export function fmt(value: number | null | undefined, digits = 1, unit = ""): string {
  if (value === null || value === undefined || !Number.isFinite(value)) return "—";
  const text = value.toFixed(digits);
  // avoid "-0.0"
  const clean = /^-0(\.0+)?$/.test(text) ? text.slice(1) : text;
  return unit ? `${clean} ${unit}` : clean;
}

/** An age in seconds as "0.4 s", "12 s", "3 min". */
export function fmtAge(seconds: number | null | undefined): string {
  if (seconds === null || seconds === undefined || !Number.isFinite(seconds)) return "—";
  if (seconds < 0) return "0.0 s";
  if (seconds < 10) return `${seconds.toFixed(1)} s`;
  if (seconds < 120) return `${Math.round(seconds)} s`;
  return `${Math.round(seconds / 60)} min`;
}

/** A Hu moment as the usual -sign(h) log10|h| (readable across many decades). */
export function huLog(value: number | null | undefined): number | null {
  if (value === null || value === undefined || !Number.isFinite(value)) return null;
  if (value === 0) return 0;
  return -Math.sign(value) * Math.log10(Math.abs(value));
}

export function fmtSci(value: number | null | undefined, digits = 3): string {
  if (value === null || value === undefined || !Number.isFinite(value)) return "—";
  return value === 0 ? "0" : value.toExponential(digits);
}

/** A timestamp (UNIX seconds) as local HH:MM:SS. */
export function fmtClock(t: number | null | undefined): string {
  if (t === null || t === undefined || !Number.isFinite(t)) return "";
  const d = new Date(t * 1000);
  return d.toTimeString().slice(0, 8);
}

/** A creation time from the server: UNIX seconds or an ISO string, as "YYYY-MM-DD HH:MM". */
export function fmtDate(value: string | number | null | undefined): string {
  if (value === null || value === undefined || value === "") return "—";
  const d = typeof value === "number" ? new Date(value * 1000) : new Date(value);
  if (Number.isNaN(d.getTime())) return String(value);
  const pad = (n: number) => String(n).padStart(2, "0");
  return `${d.getFullYear()}-${pad(d.getMonth() + 1)}-${pad(d.getDate())} ${pad(d.getHours())}:${pad(d.getMinutes())}`;
}

/** A count and its noun: "1 other mark", "3 other marks"; "—" for an unknown count. */
export function plural(count: number | null | undefined, noun: string, nouns = `${noun}s`): string {
  if (count === null || count === undefined || !Number.isFinite(count)) return `— ${nouns}`;
  return `${count} ${count === 1 ? noun : nouns}`;
}
