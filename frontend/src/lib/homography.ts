// Plane-to-plane homography by the normalised DLT (Hartley & Zisserman, alg. 4.2),
// solved in least squares with h33 = 1. The corner map uses it to bring the
// detected pixel corners into the reference pad's metres, so they can be drawn
// against the reference pattern whatever the camera's tilt.

import type { Point } from "./protocol";

export type Matrix3 = [number, number, number, number, number, number, number, number, number];

function checkPoints(name: string, pts: readonly Point[]): void {
  for (const p of pts) {
    if (!Array.isArray(p) || p.length < 2 || !Number.isFinite(p[0]) || !Number.isFinite(p[1])) {
      throw new RangeError(`${name} must hold finite [x, y] points`);
    }
  }
}

/** Translate to the centroid and scale to mean distance sqrt(2) (conditioning). */
function normaliser(pts: readonly Point[]): Matrix3 {
  let cx = 0;
  let cy = 0;
  for (const [x, y] of pts) {
    cx += x;
    cy += y;
  }
  cx /= pts.length;
  cy /= pts.length;
  let d = 0;
  for (const [x, y] of pts) d += Math.hypot(x - cx, y - cy);
  d /= pts.length;
  if (!(d > 0)) throw new RangeError("points are all the same: no homography");
  const s = Math.SQRT2 / d;
  return [s, 0, -s * cx, 0, s, -s * cy, 0, 0, 1];
}

export function applyHomography(h: Matrix3, p: Point): Point {
  const w = h[6] * p[0] + h[7] * p[1] + h[8];
  return [(h[0] * p[0] + h[1] * p[1] + h[2]) / w, (h[3] * p[0] + h[4] * p[1] + h[5]) / w];
}

export function multiply(a: Matrix3, b: Matrix3): Matrix3 {
  const out = new Array<number>(9).fill(0);
  for (let r = 0; r < 3; r += 1) {
    for (let c = 0; c < 3; c += 1) {
      for (let k = 0; k < 3; k += 1) out[r * 3 + c] += a[r * 3 + k] * b[k * 3 + c];
    }
  }
  return out as Matrix3;
}

export function invert(m: Matrix3): Matrix3 {
  const [a, b, c, d, e, f, g, h, i] = m;
  const A = e * i - f * h;
  const B = -(d * i - f * g);
  const C = d * h - e * g;
  const det = a * A + b * B + c * C;
  if (!Number.isFinite(det) || Math.abs(det) < 1e-15) throw new RangeError("matrix is singular");
  return [
    A / det,
    -(b * i - c * h) / det,
    (b * f - c * e) / det,
    B / det,
    (a * i - c * g) / det,
    -(a * f - c * d) / det,
    C / det,
    -(a * h - b * g) / det,
    (a * e - b * d) / det,
  ];
}

/** Solve A x = b (n x n) by Gaussian elimination with partial pivoting. */
export function solve(a: number[][], b: number[]): number[] {
  const n = b.length;
  const m = a.map((row, i) => [...row, b[i]]);
  for (let col = 0; col < n; col += 1) {
    let pivot = col;
    for (let r = col + 1; r < n; r += 1) if (Math.abs(m[r][col]) > Math.abs(m[pivot][col])) pivot = r;
    if (Math.abs(m[pivot][col]) < 1e-12) throw new RangeError("points are degenerate (collinear)");
    [m[col], m[pivot]] = [m[pivot], m[col]];
    for (let r = col + 1; r < n; r += 1) {
      const f = m[r][col] / m[col][col];
      for (let c = col; c <= n; c += 1) m[r][c] -= f * m[col][c];
    }
  }
  const x = new Array<number>(n).fill(0);
  for (let r = n - 1; r >= 0; r -= 1) {
    let s = m[r][n];
    for (let c = r + 1; c < n; c += 1) s -= m[r][c] * x[c];
    x[r] = s / m[r][r];
  }
  return x;
}

/**
 * The homography mapping each src[i] to dst[i] (at least 4 pairs, least squares
 * beyond). Throws RangeError naming the problem for mismatched or degenerate input.
 */
export function fitHomography(src: readonly Point[], dst: readonly Point[]): Matrix3 {
  if (src.length !== dst.length) {
    throw new RangeError(`src and dst differ in length (${src.length} vs ${dst.length})`);
  }
  if (src.length < 4) throw new RangeError(`need at least 4 point pairs, got ${src.length}`);
  checkPoints("src", src);
  checkPoints("dst", dst);
  const ts = normaliser(src);
  const td = normaliser(dst);
  const s = src.map((p) => applyHomography(ts, p));
  const d = dst.map((p) => applyHomography(td, p));
  // Normal equations of the 2n x 8 DLT system with h33 = 1.
  const ata = Array.from({ length: 8 }, () => new Array<number>(8).fill(0));
  const atb = new Array<number>(8).fill(0);
  const addRow = (row: number[], rhs: number) => {
    for (let i = 0; i < 8; i += 1) {
      atb[i] += row[i] * rhs;
      for (let j = 0; j < 8; j += 1) ata[i][j] += row[i] * row[j];
    }
  };
  for (let k = 0; k < s.length; k += 1) {
    const [x, y] = s[k];
    const [u, v] = d[k];
    addRow([x, y, 1, 0, 0, 0, -u * x, -u * y], u);
    addRow([0, 0, 0, x, y, 1, -v * x, -v * y], v);
  }
  const h = solve(ata, atb);
  const hn: Matrix3 = [h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1];
  const full = multiply(invert(td), multiply(hn, ts));
  const scale = full[8];
  if (!Number.isFinite(scale) || Math.abs(scale) < 1e-15) throw new RangeError("degenerate homography");
  return full.map((v) => v / scale) as Matrix3;
}

/** Root-mean-square distance between H(src) and dst. */
export function rmsError(h: Matrix3, src: readonly Point[], dst: readonly Point[]): number {
  let sum = 0;
  for (let i = 0; i < src.length; i += 1) {
    const [x, y] = applyHomography(h, src[i]);
    sum += (x - dst[i][0]) ** 2 + (y - dst[i][1]) ** 2;
  }
  return Math.sqrt(sum / Math.max(src.length, 1));
}
