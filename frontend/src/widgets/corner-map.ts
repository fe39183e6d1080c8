// Corner map: the reference H pattern (metres, pad frame) with the detected corners
// brought into the same frame by a homography fitted to them, so the operator sees
// at a glance how well the detection matches the pad, whatever the camera's tilt.

import { fmt } from "../lib/format";
import { applyHomography, fitHomography, rmsError } from "../lib/homography";
import type { Point } from "../lib/protocol";
import { COLORS, type Ctx, fitCanvas, h, panel, rafThrottle, setText } from "./dom";

export function mountCornerMap(root: HTMLElement, ctx: Ctx): void {
  const { store } = ctx;
  const canvas = h("canvas", { class: "corner-canvas", "data-testid": "corner-canvas" });
  const caption = h("div", { class: "caption", "data-testid": "corner-caption" }, "No reference yet");
  const legend = h(
    "div",
    { class: "legend" },
    h("span", { class: "key key-reference" }, "reference"),
    h("span", { class: "key key-detected" }, "detected (mapped to pad)"),
  );
  root.append(panel("Corner map", "corner-map", canvas, legend, caption));

  const render = rafThrottle(() => {
    const g = fitCanvas(canvas);
    if (!g) return;
    const w = canvas.clientWidth;
    const hh = canvas.clientHeight;
    g.fillStyle = COLORS.bg;
    g.fillRect(0, 0, w, hh);
    const ref = store.reference;
    if (!ref || ref.corners_m.length < 4) {
      setText(caption, "No reference yet: upload one in the Reference panel.");
      return;
    }
    const refPts = ref.corners_m;
    // pad frame (+y up) to canvas (+y down), the pad filling ~80 % of the box
    const half = Math.max(...refPts.map(([x, y]) => Math.max(Math.abs(x), Math.abs(y))), ref.pad_size_m / 2);
    const scale = (0.4 * Math.min(w, hh)) / half;
    const toCanvas = ([x, y]: Point): Point => [w / 2 + x * scale, hh / 2 - y * scale];

    // grid: 10 cm
    g.strokeStyle = COLORS.grid;
    g.lineWidth = 1;
    const step = 0.1 * scale;
    if (step > 6) {
      for (let gx = (w / 2) % step; gx < w; gx += step) line(g, [gx, 0], [gx, hh]);
      for (let gy = (hh / 2) % step; gy < hh; gy += step) line(g, [0, gy], [w, gy]);
    }
    // the H outline
    g.fillStyle = "rgba(148, 163, 184, 0.12)";
    g.strokeStyle = "#94a3b8";
    g.lineWidth = 1.5;
    g.beginPath();
    refPts.forEach((p, i) => {
      const [cx, cy] = toCanvas(p);
      if (i === 0) g.moveTo(cx, cy);
      else g.lineTo(cx, cy);
    });
    g.closePath();
    g.fill();
    g.stroke();
    g.font = "10px ui-monospace, monospace";
    refPts.forEach((p, i) => {
      const [cx, cy] = toCanvas(p);
      g.fillStyle = COLORS.reference;
      g.beginPath();
      g.arc(cx, cy, 3, 0, Math.PI * 2);
      g.fill();
      g.fillStyle = COLORS.muted;
      g.fillText(String(i + 1), cx + 5, cy - 5);
    });

    const f = store.frame;
    const detected = f?.result.detected ? f.result.corners_px : [];
    if (!f || detected.length === 0) {
      setText(caption, `Reference: ${refPts.length} corners, pad ${fmt(ref.pad_size_m, 2, "m")}. No H in the current frame.`);
      return;
    }
    if (detected.length !== refPts.length) {
      setText(caption, `${detected.length} corners detected, reference has ${refPts.length}: not matched.`);
      return;
    }
    let mapped: Point[];
    let rms: number;
    try {
      const hm = fitHomography(detected, refPts);
      mapped = detected.map((p) => applyHomography(hm, p));
      rms = rmsError(hm, detected, refPts);
    } catch (error) {
      setText(caption, `Cannot map the detected corners: ${(error as Error).message}`);
      return;
    }
    g.lineWidth = 1.5;
    mapped.forEach((p, i) => {
      const [cx, cy] = toCanvas(p);
      const [rx, ry] = toCanvas(refPts[i]);
      g.strokeStyle = COLORS.warn;
      line(g, [rx, ry], [cx, cy]);
      g.fillStyle = COLORS.corners;
      g.fillRect(cx - 3, cy - 3, 6, 6);
    });
    setText(
      caption,
      `${detected.length}/${refPts.length} corners matched · fit residual ${fmt(rms * 1000, 1, "mm")}` +
        (f.result.pose ? ` · reprojection ${fmt(f.result.pose.reprojection_px, 2, "px")}` : ""),
    );
  });

  store.subscribe(["frame", "reference"], render);
  window.addEventListener("resize", render);
  render();
}

function line(g: CanvasRenderingContext2D, a: Point, b: Point): void {
  g.beginPath();
  g.moveTo(a[0], a[1]);
  g.lineTo(b[0], b[1]);
  g.stroke();
}
