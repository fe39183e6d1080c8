// Where the camera sees the ground: the four image corners' rays through the vehicle's
// attitude, met with the ground plane (local NED, ground at down = 0). The camera
// looks down, image x along the body's right, image y toward the body's back, unless
// its mount turns it (roll, pitch, yaw in degrees, as the vehicle's: the station's
// camera_mount_deg).

import { asMount } from "./mount";

export type Vec3 = [number, number, number];

function rotNedBody(roll: number, pitch: number, yaw: number): number[][] {
  const [cr, sr, cp, sp, cy, sy] = [Math.cos(roll), Math.sin(roll), Math.cos(pitch), Math.sin(pitch), Math.cos(yaw), Math.sin(yaw)];
  return [
    [cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
    [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
    [-sp, sr * cp, cr * cp],
  ];
}

function mul(m: number[][], v: Vec3): Vec3 {
  return [m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2], m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]];
}

/**
 * The footprint's corners (north, east) on the ground, or null when a corner's ray
 * does not reach the ground (camera tilted to the horizon) or the vehicle is on it.
 */
export function cameraFootprint(
  positionNed: Vec3,
  rollRad: number,
  pitchRad: number,
  yawRad: number,
  hfovDeg: number,
  aspect: number,
  mountDeg: Vec3 = [0, 0, 0],
): [number, number][] | null {
  const height = -positionNed[2];
  if (!(height > 0.05)) return null;
  const tx = Math.tan((hfovDeg * Math.PI) / 360);
  const ty = tx / aspect;
  const R = rotNedBody(rollRad, pitchRad, yawRad);
  const [mr, mp, my] = mountDeg.map((d) => (d * Math.PI) / 180);
  const mount = rotNedBody(mr, mp, my);
  const out: [number, number][] = [];
  // image corners TL, TR, BR, BL: x right, y down; camera z = body down
  for (const [ix, iy] of [[-1, -1], [1, -1], [1, 1], [-1, 1]] as const) {
    // camera (x right, y down in the image, z forward=down) -> body FRD: forward = -y, right = x, down = z
    const body = mul(mount, [-iy * ty, ix * tx, 1]);
    const ned = mul(R, body);
    if (ned[2] <= 1e-6) return null;
    const s = height / ned[2];
    out.push([positionNed[0] + s * ned[0], positionNed[1] + s * ned[1]]);
  }
  return out;
}

/** The camera's mount from the station's settings (straight down when not told). */
export function mountOf(settings: Record<string, unknown>): Vec3 {
  return asMount(settings.camera_mount_deg) ?? [0, 0, 0];
}
