// Invariants: Hu's seven moments of the detected H next to the reference's, the
// orientation, eccentricity and the distance to the reference, with a time-series
// plot of the distance and the (log-scaled) moments.

import { fmt, fmtSci, huLog } from "../lib/format";
import type { InvariantSample } from "../lib/store";
import { COLORS, type Ctx, fitCanvas, h, panel, rafThrottle, setText } from "./dom";

export function mountInvariants(root: HTMLElement, ctx: Ctx): void {
  const { store } = ctx;
  const tbody = h("tbody");
  const cells: { now: HTMLElement; ref: HTMLElement; log: HTMLElement }[] = [];
  for (let i = 0; i < 7; i += 1) {
    const now = h("td", { class: "num", "data-testid": `hu${i + 1}` }, "—");
    const log = h("td", { class: "num" }, "—");
    const ref = h("td", { class: "num" }, "—");
    cells.push({ now, ref, log });
    tbody.append(
      h("tr", {}, h("th", {}, h("span", { class: "dot", style: `background:${COLORS.series[i]}` }), `Hu ${i + 1}`), now, log, ref),
    );
  }
  const extra = {
    orientation: h("td", { class: "num", "data-testid": "orientation" }, "—"),
    orientationRef: h("td", { class: "num" }, "—"),
    ecc: h("td", { class: "num", "data-testid": "eccentricity" }, "—"),
    eccRef: h("td", { class: "num" }, "—"),
    distance: h("td", { class: "num", "data-testid": "reference-distance" }, "—"),
  };
  tbody.append(
    h("tr", { class: "sep" }, h("th", {}, "Orientation"), extra.orientation, h("td"), extra.orientationRef),
    h("tr", {}, h("th", {}, "Eccentricity"), extra.ecc, h("td"), extra.eccRef),
    h("tr", {}, h("th", {}, "Distance to ref."), extra.distance, h("td"), h("td")),
  );
  const table = h(
    "table",
    { class: "data-table" },
    h("thead", {}, h("tr", {}, h("th"), h("th", {}, "frame"), h("th", {}, "−sgn·log₁₀|h|"), h("th", {}, "reference"))),
    tbody,
  );
  const plot = h("canvas", { class: "series-canvas", "data-testid": "invariants-plot" });
  root.append(panel("Invariants", "invariants", h("div", { class: "inv-layout" }, table, plot)));

  const renderTable = rafThrottle(() => {
    const f = store.frame;
    const ref = store.reference;
    const hu = f?.result.detected ? f.result.hu : [];
    for (let i = 0; i < 7; i += 1) {
      setText(cells[i].now, fmtSci(hu[i]));
      setText(cells[i].log, fmt(huLog(hu[i]), 2));
      setText(cells[i].ref, fmtSci(ref?.hu[i]));
    }
    setText(extra.orientation, f?.result.detected ? fmt(f.result.orientation_deg, 1, "°") : "—");
    setText(extra.ecc, f?.result.detected ? fmt(f.result.eccentricity, 3) : "—");
    setText(extra.distance, fmt(f?.reference_distance, 4));
    setText(extra.orientationRef, fmt(ref?.orientation_deg, 1, "°"));
    setText(extra.eccRef, fmt(ref?.eccentricity, 3));
    renderPlot();
  });

  function renderPlot(): void {
    const g = fitCanvas(plot);
    if (!g) return;
    const w = plot.clientWidth;
    const hh = plot.clientHeight;
    g.fillStyle = COLORS.bg;
    g.fillRect(0, 0, w, hh);
    const samples = store.history.toArray();
    const top = { x: 48, y: 16, w: w - 56, h: (hh - 50) / 2 };
    const bottom = { x: 48, y: top.y + top.h + 22, w: w - 56, h: (hh - 50) / 2 };
    g.font = "10px ui-monospace, monospace";
    g.fillStyle = COLORS.muted;
    g.fillText("distance to reference", top.x, top.y - 4);
    // Hu 1 and 2 carry the shape of a symmetric H; 3-7 are ~0 for it and would be noise here
    g.fillStyle = COLORS.series[0];
    g.fillText("Hu 1", bottom.x, bottom.y - 4);
    g.fillStyle = COLORS.series[1];
    g.fillText("Hu 2 ×10", bottom.x + 40, bottom.y - 4);
    g.fillStyle = COLORS.muted;
    g.fillText("(dashed: reference)", bottom.x + 100, bottom.y - 4);
    frame(g, top);
    frame(g, bottom);
    if (samples.length < 2) return;
    const n = samples.length;
    // right-aligned: the newest sample at the right edge, the plot scrolls left
    const cap = store.history.capacity;
    const xOf = (i: number, box: Box) => box.x + ((i + cap - n) / Math.max(cap - 1, 1)) * box.w;
    const dists = samples.map((s) => s.distance).filter((d): d is number => d !== null);
    const dmax = Math.max(0.01, ...dists) * 1.1;
    axisLabels(g, top, 0, dmax, (v) => v.toPrecision(3));
    // detection gaps shaded
    g.fillStyle = "rgba(239, 68, 68, 0.14)";
    samples.forEach((s, i) => {
      if (!s.detected) g.fillRect(xOf(i, top), top.y, Math.max(1, top.w / cap), top.h);
    });
    series(g, samples, top, (s) => s.distance, 0, dmax, COLORS.accent, xOf);

    const ref = store.reference;
    const hu1 = (s: InvariantSample) => (s.detected ? s.hu[0] ?? null : null);
    const hu2 = (s: InvariantSample) => (s.detected && s.hu[1] !== null && s.hu[1] !== undefined ? s.hu[1] * 10 : null);
    const values = samples.flatMap((s) => [hu1(s), hu2(s)]).filter((v): v is number => v !== null);
    const refHu1 = ref?.hu[0] ?? null;
    const refHu2 = ref?.hu[1] === null || ref?.hu[1] === undefined ? null : ref.hu[1] * 10;
    for (const v of [refHu1, refHu2]) if (v !== null) values.push(v);
    const lo = Math.min(0, ...values);
    const hi = Math.max(1e-3, ...values) * 1.1;
    axisLabels(g, bottom, lo, hi, (v) => v.toPrecision(2));
    if (ref) {
      g.setLineDash([4, 4]);
      for (const [v, color] of [
        [refHu1, COLORS.series[0]],
        [refHu2, COLORS.series[1]],
      ] as [number | null, string][]) {
        if (v === null) continue;
        const y = bottom.y + bottom.h - ((v - lo) / (hi - lo || 1)) * bottom.h;
        g.strokeStyle = color;
        g.lineWidth = 1;
        g.beginPath();
        g.moveTo(bottom.x, y);
        g.lineTo(bottom.x + bottom.w, y);
        g.stroke();
      }
      g.setLineDash([]);
    }
    series(g, samples, bottom, hu1, lo, hi, COLORS.series[0], xOf);
    series(g, samples, bottom, hu2, lo, hi, COLORS.series[1], xOf);
  }

  store.subscribe(["frame", "reference"], renderTable);
  window.addEventListener("resize", renderTable);
  renderTable();
}

interface Box {
  x: number;
  y: number;
  w: number;
  h: number;
}

function frame(g: CanvasRenderingContext2D, b: Box): void {
  g.strokeStyle = COLORS.grid;
  g.lineWidth = 1;
  g.strokeRect(b.x + 0.5, b.y + 0.5, b.w, b.h);
}

function axisLabels(g: CanvasRenderingContext2D, b: Box, lo: number, hi: number, f: (v: number) => string): void {
  g.fillStyle = COLORS.muted;
  g.textAlign = "right";
  g.fillText(f(hi), b.x - 4, b.y + 9);
  g.fillText(f(lo), b.x - 4, b.y + b.h);
  g.textAlign = "left";
}

function series(
  g: CanvasRenderingContext2D,
  samples: InvariantSample[],
  b: Box,
  value: (s: InvariantSample) => number | null,
  lo: number,
  hi: number,
  color: string,
  xOf: (i: number, b: Box) => number,
): void {
  g.strokeStyle = color;
  g.lineWidth = 1.5;
  g.beginPath();
  let pen = false;
  samples.forEach((s, i) => {
    const v = value(s);
    if (v === null || !Number.isFinite(v)) {
      pen = false;
      return;
    }
    const x = xOf(i, b);
    const y = b.y + b.h - ((v - lo) / (hi - lo || 1)) * b.h;
    if (pen) g.lineTo(x, y);
    else g.moveTo(x, y);
    pen = true;
  });
  g.stroke();
}
