// The camera's mount (roll, pitch, yaw in degrees: how the camera is turned from
// looking straight down, its picture's top to the nose) as the operator types it, and
// the mount check's suggestion while it still holds among the station's events.

export type Mount = [roll: number, pitch: number, yaw: number];

/** The station's bounds (PUT /api/settings refuses anything else). */
export const TILT_LIMIT_DEG = 45;
export const YAW_LIMIT_DEG = 180;

const AXES = [
  ["Roll", TILT_LIMIT_DEG],
  ["Pitch", TILT_LIMIT_DEG],
  ["Yaw", YAW_LIMIT_DEG],
] as const;

/** Three finite numbers, or null. */
export function asMount(value: unknown): Mount | null {
  return Array.isArray(value) && value.length === 3 && value.every((v) => typeof v === "number" && Number.isFinite(v))
    ? [value[0], value[1], value[2]]
    : null;
}

/** The three inputs' texts as a mount, or the first problem in one sentence. */
export function parseMount(texts: readonly [string, string, string]): { ok: true; mount: Mount } | { ok: false; error: string } {
  const out: number[] = [];
  for (const [i, [name, limit]] of AXES.entries()) {
    const text = texts[i].trim();
    // Number("") is 0: an empty field is no number
    const v = text === "" ? NaN : Number(text);
    if (!Number.isFinite(v)) return { ok: false, error: `${name} must be a number of degrees.` };
    if (Math.abs(v) > limit) return { ok: false, error: `${name} must be between -${limit} and ${limit} degrees; ${text} is outside.` };
    out.push(v);
  }
  return { ok: true, mount: [out[0], out[1], out[2]] };
}

/** An angle to a tenth of a degree, without "-0" or a trailing ".0". */
function deg(v: number): string {
  return `${Math.round(v * 10) / 10 + 0}°`;
}

/** "roll 0.1°, pitch 8°, yaw 0°". */
export function describeMount(m: Mount): string {
  return `roll ${deg(m[0])}, pitch ${deg(m[1])}, yaw ${deg(m[2])}`;
}

export interface MountSuggestion {
  mount: Mount;
  /** The median lean of the pad's pixels from the attitude's level (degrees). */
  leanDeg: number;
}

interface EventLike {
  kind: string;
  [key: string]: unknown;
}

/**
 * The mount the latest mount-check warning suggests (events oldest first), or null when
 * none did, or a later all-clear (a "vision" event with `lean_deg` and no suggestion) or
 * a change of the camera's mount made it stale.
 */
export function liveSuggestion(events: readonly EventLike[]): MountSuggestion | null {
  for (let i = events.length - 1; i >= 0; i -= 1) {
    const e = events[i];
    if (e.kind === "settings") {
      const changes = e.changes;
      if (typeof changes === "object" && changes !== null && "camera_mount_deg" in changes) return null;
    } else if (e.kind === "vision" && typeof e.lean_deg === "number") {
      const mount = asMount(e.suggested_mount_deg);
      return mount ? { mount, leanDeg: e.lean_deg } : null;
    }
  }
  return null;
}
