// A recorded flight's timeline (GET /api/flights/{id}/replay): the entry shown at a
// given time is the last one at or before it (binary search, no interpolation).

export function indexAt<T extends { t: number }>(items: readonly T[], t: number): number {
  let lo = 0;
  let hi = items.length - 1;
  if (hi < 0 || t < items[0].t) return -1;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (items[mid].t <= t) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}

export function at<T extends { t: number }>(items: readonly T[], t: number): T | null {
  const i = indexAt(items, t);
  return i < 0 ? null : items[i];
}

/** The mission state at t: the last state change at or before it, with its run. */
export function missionStateAt(
  missions: readonly { id: number; kind: string; strategy: string | null; states: { t: number; state: string; reason: string }[] }[],
  t: number,
): { run: number; kind: string; strategy: string | null; state: string; reason: string } | null {
  let best: { run: number; kind: string; strategy: string | null; state: string; reason: string; t: number } | null = null;
  for (const m of missions) {
    const s = at(m.states, t);
    if (s && (best === null || s.t >= best.t)) {
      best = { run: m.id, kind: m.kind, strategy: m.strategy, state: s.state, reason: s.reason, t: s.t };
    }
  }
  if (!best) return null;
  const { t: _t, ...rest } = best;
  return rest;
}

/** "m:ss" for a time offset in seconds. */
export function clock(seconds: number): string {
  const s = Math.max(0, Math.floor(seconds));
  return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
}
