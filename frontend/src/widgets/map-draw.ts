// Drawing the local frame (metres from home, north up): a top-down map and a simple
// perspective view of the same scene, for the live map and the replay.

import { cameraFootprint, mountOf } from "../lib/footprint";
import type { Store } from "../lib/store";
import { COLORS } from "./dom";

export interface LocalScene {
  pad: { n: number; e: number; size: number; headingDeg: number };
  vehicle: { n: number; e: number; d: number; yaw: number } | null;
  track: [number, number, number][];
  footprint: [number, number][] | null;
}

/** The live scene: the pad from the settings, the vehicle and its camera's footprint
 * from the latest telemetry, and the given track. */
export function liveScene(store: Store, track: [number, number, number][]): LocalScene {
  const s = store.settings;
  const p = store.telemetry?.position_ned;
  const a = store.telemetry?.attitude;
  const vehicle = p && p.x !== null && p.y !== null && p.z !== null ? { n: p.x, e: p.y, d: p.z, yaw: a?.yaw ?? 0 } : null;
  const footprint =
    vehicle && a && a.roll !== null && a.pitch !== null && a.yaw !== null
      ? cameraFootprint([vehicle.n, vehicle.e, vehicle.d], a.roll, a.pitch, a.yaw, Number(s.camera_hfov_deg ?? 60), Number(s.camera_aspect ?? 4 / 3), mountOf(s))
      : null;
  const pad = { n: Number(s.pad_north_m ?? 0), e: Number(s.pad_east_m ?? 0), size: Number(s.pad_size_m ?? 0.55), headingDeg: Number(s.pad_heading_deg ?? 0) };
  return { pad, vehicle, track, footprint };
}

function padCorners(pad: LocalScene["pad"]): [number, number][] {
  const h = (pad.headingDeg * Math.PI) / 180;
  const s = pad.size / 2;
  // pad +y (picture top) along the heading, +x 90 degrees clockwise from it
  const fwd: [number, number] = [Math.cos(h), Math.sin(h)];
  const right: [number, number] = [-Math.sin(h), Math.cos(h)];
  return [
    [-1, 1],
    [1, 1],
    [1, -1],
    [-1, -1],
  ].map(([x, y]) => [pad.n + s * (x * right[0] + y * fwd[0]), pad.e + s * (x * right[1] + y * fwd[1])]);
}

/** Top-down map, north up, fitted to what there is (at least 8 m across). */
export function drawTopDown(g: CanvasRenderingContext2D, w: number, hgt: number, scene: LocalScene): void {
  g.fillStyle = COLORS.bg;
  g.fillRect(0, 0, w, hgt);
  const pts: [number, number][] = [[0, 0], [scene.pad.n, scene.pad.e], ...scene.track.map(([n, e]) => [n, e] as [number, number])];
  if (scene.vehicle) pts.push([scene.vehicle.n, scene.vehicle.e]);
  if (scene.footprint) pts.push(...scene.footprint);
  const ns = pts.map((p) => p[0]);
  const es = pts.map((p) => p[1]);
  const cn = (Math.min(...ns) + Math.max(...ns)) / 2;
  const ce = (Math.min(...es) + Math.max(...es)) / 2;
  const span = Math.max(8, Math.max(...ns) - Math.min(...ns), Math.max(...es) - Math.min(...es)) * 1.25;
  const scale = Math.min(w, hgt) / span;
  const X = (e: number) => w / 2 + (e - ce) * scale;
  const Y = (n: number) => hgt / 2 - (n - cn) * scale;
  // grid every metre (every 5 bolder)
  g.lineWidth = 1;
  const m0 = Math.floor(ce - w / 2 / scale);
  const m1 = Math.ceil(ce + w / 2 / scale);
  for (let e = m0; e <= m1; e += 1) {
    g.strokeStyle = e % 5 === 0 ? "#2a3a4a" : COLORS.grid;
    g.beginPath();
    g.moveTo(X(e), 0);
    g.lineTo(X(e), hgt);
    g.stroke();
  }
  for (let n = Math.floor(cn - hgt / 2 / scale); n <= Math.ceil(cn + hgt / 2 / scale); n += 1) {
    g.strokeStyle = n % 5 === 0 ? "#2a3a4a" : COLORS.grid;
    g.beginPath();
    g.moveTo(0, Y(n));
    g.lineTo(w, Y(n));
    g.stroke();
  }
  // camera footprint
  if (scene.footprint) {
    g.fillStyle = "rgba(56,189,248,0.12)";
    g.strokeStyle = COLORS.accent;
    g.beginPath();
    scene.footprint.forEach(([n, e], i) => (i ? g.lineTo(X(e), Y(n)) : g.moveTo(X(e), Y(n))));
    g.closePath();
    g.fill();
    g.stroke();
  }
  // pad
  g.fillStyle = "rgba(250,204,21,0.25)";
  g.strokeStyle = COLORS.corners;
  g.lineWidth = 2;
  g.beginPath();
  padCorners(scene.pad).forEach(([n, e], i) => (i ? g.lineTo(X(e), Y(n)) : g.moveTo(X(e), Y(n))));
  g.closePath();
  g.fill();
  g.stroke();
  // home
  g.strokeStyle = COLORS.ok;
  g.beginPath();
  g.arc(X(0), Y(0), 6, 0, 2 * Math.PI);
  g.stroke();
  // track
  if (scene.track.length > 1) {
    g.strokeStyle = COLORS.reference;
    g.lineWidth = 1.5;
    g.beginPath();
    scene.track.forEach(([n, e], i) => (i ? g.lineTo(X(e), Y(n)) : g.moveTo(X(e), Y(n))));
    g.stroke();
  }
  // vehicle: a triangle pointing along its heading
  if (scene.vehicle) {
    const { n, e, yaw } = scene.vehicle;
    const x = X(e);
    const y = Y(n);
    g.save();
    g.translate(x, y);
    g.rotate(yaw);
    g.fillStyle = COLORS.target;
    g.beginPath();
    g.moveTo(0, -11);
    g.lineTo(7, 8);
    g.lineTo(-7, 8);
    g.closePath();
    g.fill();
    g.restore();
  }
  // scale bar and north
  g.fillStyle = COLORS.text;
  g.font = "11px ui-monospace, monospace";
  const bar = span > 30 ? 10 : span > 12 ? 5 : 1;
  g.fillRect(10, hgt - 14, bar * scale, 2);
  g.fillText(`${bar} m`, 12 + bar * scale, hgt - 10);
  g.fillText("N ↑", w - 32, 16);
}

/** A perspective view of the same scene from an orbiting eye (azimuth, elevation). */
export function drawPerspective(
  g: CanvasRenderingContext2D,
  w: number,
  hgt: number,
  scene: LocalScene,
  azimuthDeg: number,
  elevationDeg: number,
): void {
  g.fillStyle = COLORS.bg;
  g.fillRect(0, 0, w, hgt);
  const target: [number, number, number] = [scene.pad.n, scene.pad.e, 0];
  const dist = 14;
  const az = (azimuthDeg * Math.PI) / 180;
  const el = (elevationDeg * Math.PI) / 180;
  // eye in NED: behind (south-west by default) and above
  const eye: [number, number, number] = [target[0] - dist * Math.cos(el) * Math.cos(az), target[1] - dist * Math.cos(el) * Math.sin(az), -dist * Math.sin(el)];
  const fwd = norm(sub(target, eye));
  const right = norm(cross(fwd, [0, 0, -1]));
  const up = cross(right, fwd);
  const f = Math.min(w, hgt) * 1.1;
  const P = (p: [number, number, number]): [number, number] | null => {
    const v = sub(p, eye);
    const z = dot(v, fwd);
    if (z <= 0.1) return null;
    return [w / 2 + (f * dot(v, right)) / z, hgt / 2 - (f * dot(v, up)) / z];
  };
  const line = (a: [number, number, number], b: [number, number, number]) => {
    const pa = P(a);
    const pb = P(b);
    if (!pa || !pb) return;
    g.beginPath();
    g.moveTo(pa[0], pa[1]);
    g.lineTo(pb[0], pb[1]);
    g.stroke();
  };
  g.strokeStyle = COLORS.grid;
  g.lineWidth = 1;
  for (let k = -10; k <= 10; k += 1) {
    line([target[0] + k, target[1] - 10, 0], [target[0] + k, target[1] + 10, 0]);
    line([target[0] - 10, target[1] + k, 0], [target[0] + 10, target[1] + k, 0]);
  }
  g.strokeStyle = COLORS.corners;
  g.lineWidth = 2;
  const pc = padCorners(scene.pad);
  for (let i = 0; i < 4; i += 1) line([pc[i][0], pc[i][1], 0], [pc[(i + 1) % 4][0], pc[(i + 1) % 4][1], 0]);
  g.strokeStyle = COLORS.ok;
  line([-0.3, 0, 0], [0.3, 0, 0]);
  line([0, -0.3, 0], [0, 0.3, 0]);
  if (scene.track.length > 1) {
    g.strokeStyle = COLORS.reference;
    g.lineWidth = 1.5;
    for (let i = 1; i < scene.track.length; i += 1) line(scene.track[i - 1], scene.track[i]);
  }
  const v = scene.vehicle;
  if (v) {
    const c: [number, number, number] = [v.n, v.e, v.d];
    if (scene.footprint) {
      g.strokeStyle = COLORS.accent;
      g.lineWidth = 1;
      for (let i = 0; i < 4; i += 1) {
        const a = scene.footprint[i];
        const b = scene.footprint[(i + 1) % 4];
        line(c, [a[0], a[1], 0]);
        line([a[0], a[1], 0], [b[0], b[1], 0]);
      }
    }
    g.strokeStyle = COLORS.target;
    g.lineWidth = 3;
    line(c, [v.n + 0.5 * Math.cos(v.yaw), v.e + 0.5 * Math.sin(v.yaw), v.d]);
    g.strokeStyle = COLORS.muted;
    g.lineWidth = 1;
    line(c, [v.n, v.e, 0]);
  }
}

type V3 = [number, number, number];
function sub(a: V3, b: V3): V3 {
  return [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
}
function dot(a: V3, b: V3): number {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
function cross(a: V3, b: V3): V3 {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}
function norm(a: V3): V3 {
  const n = Math.hypot(...a) || 1;
  return [a[0] / n, a[1] / n, a[2] / n];
}
