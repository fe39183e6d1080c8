// The live camera with the vision overlays the operator can toggle. Images are
// decoded off the main thread (createImageBitmap) and only the newest one is kept:
// a slow page draws fewer frames, it never falls behind.

import { detectionBadge } from "../lib/badge";
import { fmt } from "../lib/format";
import type { BinaryFrame, FrameMessage, Point } from "../lib/protocol";
import { RateMeter } from "../lib/ring";
import { COLORS, type Ctx, h, panel, setText } from "./dom";

type OverlayKey = "threshold" | "contour" | "corners" | "reference" | "axes" | "target";

const TOGGLES: [OverlayKey, string][] = [
  ["threshold", "Threshold mask"],
  ["contour", "H contour"],
  ["corners", "Corners"],
  ["reference", "Reference corners"],
  ["axes", "Pose axes"],
  ["target", "Landing target"],
];

interface Decoded {
  bitmap: ImageBitmap;
  seq: number;
  /** performance.now() when the frame's JSON arrived (its result was ready). */
  receivedAt: number | null;
}

export function mountCameraView(root: HTMLElement, ctx: Ctx): void {
  const { store, ws } = ctx;
  const enabled: Record<OverlayKey, boolean> = {
    threshold: false,
    contour: true,
    corners: true,
    reference: true,
    axes: true,
    target: true,
  };
  const canvas = h("canvas", { class: "camera-canvas", "data-testid": "camera-canvas" });
  const placeholder = h("div", { class: "camera-placeholder", "data-testid": "camera-placeholder" }, "Waiting for camera frames…");
  const badge = h("div", { class: "camera-badge", "data-testid": "detection-badge" }, "NO H");
  const stage = h("div", { class: "camera-stage" }, canvas, placeholder, badge);
  const stats = {
    pipeline: h("span", { "data-testid": "pipeline-fps" }, "—"),
    latency: h("span", { "data-testid": "pipeline-latency" }, "—"),
    screen: h("span", { "data-testid": "screen-latency" }, "—"),
    display: h("span", { "data-testid": "display-fps" }, "—"),
    dropped: h("span", { "data-testid": "dropped" }, "—"),
    size: h("span", {}, "—"),
  };
  const statBar = h(
    "div",
    { class: "camera-stats" },
    stat("Pipeline", stats.pipeline),
    stat("Capture→result", stats.latency),
    stat("Camera→screen", stats.screen),
    stat("Shown", stats.display),
    stat("Dropped", stats.dropped),
    stat("Frame", stats.size),
  );
  const toggles = h("div", { class: "overlay-toggles", role: "group", "aria-label": "Overlays" });
  for (const [key, label] of TOGGLES) {
    const input = h("input", { type: "checkbox", "data-testid": `toggle-${key}` });
    input.checked = enabled[key];
    input.addEventListener("change", () => {
      enabled[key] = input.checked;
      if (key === "threshold") ws.setThreshold(input.checked);
      draw();
    });
    toggles.append(h("label", { class: `toggle toggle-${key}` }, input, h("span", { class: "swatch" }), label));
  }
  root.append(panel("Camera", "camera", stage, toggles, statBar));

  const receivedAt = new Map<number, number>();
  const shown = new RateMeter(2000);
  let current: Decoded | null = null;
  let mask: ImageBitmap | null = null;
  let maskSeq = -1;
  let decoding = false;
  let pending: BinaryFrame | null = null;
  let pendingMask: BinaryFrame | null = null;
  let lastScreenLatency: number | null = null;
  let lastDrawn = 0;
  let drawnTotal = 0; // new frames drawn since the page opened (the benchmark reads it)

  store.subscribe("frame", () => {
    const f = store.frame;
    if (!f) return;
    receivedAt.set(f.seq, performance.now());
    if (receivedAt.size > 32) receivedAt.delete(receivedAt.keys().next().value as number);
  });

  store.subscribe("image", () => {
    if (store.cameraImage && store.cameraImage.header.seq !== current?.seq) pending = store.cameraImage;
    if (store.thresholdImage && store.thresholdImage.header.seq !== maskSeq) pendingMask = store.thresholdImage;
    void pump();
  });

  async function pump(): Promise<void> {
    if (decoding) return;
    decoding = true;
    try {
      while (pending || pendingMask) {
        if (pendingMask) {
          const m = pendingMask;
          pendingMask = null;
          const bmp = await decode(m);
          if (bmp) {
            mask?.close();
            mask = bmp;
            maskSeq = m.header.seq;
          }
        }
        if (pending) {
          const f = pending;
          pending = null;
          const bmp = await decode(f);
          if (bmp) {
            current?.bitmap.close();
            current = { bitmap: bmp, seq: f.header.seq, receivedAt: receivedAt.get(f.header.seq) ?? null };
            requestAnimationFrame(() => draw(true));
          }
        }
      }
    } finally {
      decoding = false;
    }
  }

  async function decode(frame: BinaryFrame): Promise<ImageBitmap | null> {
    try {
      return await createImageBitmap(new Blob([frame.jpeg as BlobPart], { type: "image/jpeg" }));
    } catch {
      return null; // a corrupt JPEG is skipped; the next one will do
    }
  }

  function draw(isNewFrame = false): void {
    if (!current) return;
    const { bitmap } = current;
    if (canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
      canvas.width = bitmap.width;
      canvas.height = bitmap.height;
    }
    const g = canvas.getContext("2d");
    if (!g) return;
    g.drawImage(bitmap, 0, 0);
    if (enabled.threshold && mask) {
      g.save();
      g.globalAlpha = 0.55;
      g.globalCompositeOperation = "screen";
      g.drawImage(mask, 0, 0, bitmap.width, bitmap.height);
      g.restore();
    }
    const frame = store.frameFor(current.seq) ?? store.frame;
    if (frame) drawOverlay(g, frame, bitmap.width, canvas.clientWidth || bitmap.width);
    placeholder.hidden = true;
    const now = performance.now();
    lastDrawn = now;
    if (isNewFrame) {
      shown.tick(now);
      drawnTotal += 1;
      (window as unknown as { visland?: { cameraDrawn?: number } }).visland ??= {};
      (window as unknown as { visland: { cameraDrawn?: number } }).visland.cameraDrawn = drawnTotal;
      if (frame && frame.seq === current.seq && current.receivedAt !== null) {
        // capture->result on the server, then result->screen measured here
        lastScreenLatency = frame.latency_ms + (now - current.receivedAt);
      }
    }
  }

  function drawOverlay(g: CanvasRenderingContext2D, f: FrameMessage, width: number, cssWidth: number): void {
    const o = f.overlay;
    // The H's own contour and corners come with the result (sent once, not again here).
    const contour = f.result.contour_px;
    const corners = f.result.corners_px;
    // keep strokes ~2 CSS px whatever the frame size
    const px = width / Math.max(cssWidth, 1);
    g.lineJoin = "round";
    if (enabled.contour && contour.length > 1) {
      g.strokeStyle = COLORS.contour;
      g.lineWidth = 2 * px;
      polyline(g, contour, true);
    }
    if (enabled.reference && o.reference_corners.length > 0) {
      g.strokeStyle = COLORS.reference;
      g.lineWidth = 1.5 * px;
      for (const [x, y] of o.reference_corners) {
        g.beginPath();
        g.arc(x, y, 6 * px, 0, Math.PI * 2);
        g.stroke();
      }
    }
    if (enabled.corners && corners.length > 0) {
      g.font = `${Math.round(11 * px)}px ui-monospace, monospace`;
      g.textBaseline = "bottom";
      corners.forEach(([x, y], i) => {
        g.fillStyle = COLORS.corners;
        g.fillRect(x - 3 * px, y - 3 * px, 6 * px, 6 * px);
        const label = String(i + 1);
        const tw = g.measureText(label).width;
        g.fillStyle = "rgba(0,0,0,0.7)";
        g.fillRect(x + 4 * px, y - 16 * px, tw + 4 * px, 13 * px);
        g.fillStyle = COLORS.corners;
        g.fillText(label, x + 6 * px, y - 4 * px);
      });
    }
    if (enabled.axes && o.axes) {
      const { origin, x, y, z } = o.axes;
      g.lineWidth = 3 * px;
      for (const [end, color] of [
        [x, COLORS.axisX],
        [y, COLORS.axisY],
        [z, COLORS.axisZ],
      ] as [Point, string][]) {
        g.strokeStyle = color;
        g.beginPath();
        g.moveTo(origin[0], origin[1]);
        g.lineTo(end[0], end[1]);
        g.stroke();
      }
    }
    if (enabled.target && o.target) {
      const [x, y] = o.target;
      const r = 14 * px;
      g.strokeStyle = COLORS.target;
      g.lineWidth = 2 * px;
      g.beginPath();
      g.moveTo(x - r, y);
      g.lineTo(x + r, y);
      g.moveTo(x, y - r);
      g.lineTo(x, y + r);
      g.stroke();
      g.beginPath();
      g.arc(x, y, r * 0.6, 0, Math.PI * 2);
      g.stroke();
    }
  }

  // Numbers refresh at 4 Hz; the picture at frame rate.
  setInterval(() => {
    const p = store.status?.pipeline;
    const f = store.frame;
    setText(stats.pipeline, fmt(p?.fps, 1, "fps"));
    setText(stats.latency, fmt(p?.latency_ms ?? f?.latency_ms, 0, "ms"));
    setText(stats.screen, fmt(lastScreenLatency, 0, "ms"));
    setText(stats.display, fmt(shown.rate(performance.now()), 1, "fps"));
    setText(stats.dropped, p?.dropped === undefined ? "—" : String(p.dropped));
    setText(stats.size, f ? `${f.width}×${f.height} #${f.seq}` : "—");
    const said = detectionBadge(f);
    setText(badge, said.text);
    badge.classList.toggle("locked", said.state === "locked");
    badge.classList.toggle("ambiguous", said.state === "ambiguous");
    badge.title = said.title;
    if (performance.now() - lastDrawn > 3000) {
      placeholder.hidden = false;
      setText(placeholder, current ? "Camera frames stopped" : "Waiting for camera frames…");
    }
  }, 250);

  window.addEventListener("resize", () => draw());
}

function stat(label: string, value: HTMLElement): HTMLElement {
  return h("div", { class: "stat" }, h("span", { class: "stat-label" }, label), value);
}

function polyline(g: CanvasRenderingContext2D, pts: Point[], closed: boolean): void {
  g.beginPath();
  g.moveTo(pts[0][0], pts[0][1]);
  for (let i = 1; i < pts.length; i += 1) g.lineTo(pts[i][0], pts[i][1]);
  if (closed) g.closePath();
  g.stroke();
}
