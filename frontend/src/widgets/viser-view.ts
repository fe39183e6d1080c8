// The 3D view: a light perspective view of the local frame drawn here (pad, home,
// vehicle, track, camera footprint and where the vision puts the camera), which
// keeps the camera view at full rate; and viser's full 3D scene (the pad's picture,
// the camera frustums), embedded on demand or opened alone. Each with its legend.

import { type Ctx, fitCanvas, h, panel, rafThrottle, setText } from "./dom";
import { drawPerspective, type LocalScene, liveScene } from "./map-draw";

const TRACK_POINTS = 600;

export function mountViserView(root: HTMLElement, ctx: Ctx): { open(): void } {
  const { store } = ctx;
  const canvas = h("canvas", { class: "view3d-canvas", "data-testid": "view3d" });
  const legend3d = h(
    "div",
    { class: "legend" },
    h("span", { class: "lg lg-home" }, "home"),
    h("span", { class: "lg lg-pad" }, "pad"),
    h("span", { class: "lg lg-vehicle" }, "vehicle (its heading)"),
    h("span", { class: "lg lg-track" }, "track"),
    h("span", { class: "lg lg-footprint" }, "camera footprint"),
    h("span", { class: "lg lg-vision" }, "camera where the vision puts it"),
  );
  const embed = h("button", { class: "btn btn-small btn-ghost", type: "button", "data-testid": "viser-embed" }, "Embed viser here");
  const open = h("a", { class: "btn btn-small btn-ghost", target: "_blank", rel: "noopener", "data-testid": "viser-link" }, "Open viser alone ↗");
  const frame = h("iframe", { class: "viser-frame", title: "viser 3D view", "data-testid": "viser-frame", hidden: true });
  const note = h(
    "div",
    { class: "caption", "data-testid": "viser-note" },
    "viser draws the full scene in WebGL; without a graphics card that costs the camera view frames, so it is embedded only when asked.",
  );
  const legend = h(
    "ul",
    { class: "legend viser-legend", "data-testid": "viser-legend", hidden: true },
    h("li", {}, h("span", { class: "swatch", style: "background:#2878ff" }), "blue frustum: the camera where the telemetry puts it"),
    h("li", {}, h("span", { class: "swatch", style: "background:#ff8c00" }), "orange frustum: the camera where the vision puts it (on the blue one when both agree)"),
    h("li", {}, h("span", { class: "swatch", style: "background:#ef4444" }), "axes: the vehicle (red forward, green right, blue down)"),
    h("li", {}, h("span", { class: "swatch", style: "background:#50c8ff" }), "dots: its trail; the picture on the ground: the pad"),
  );
  root.append(panel("3D view", "viser", canvas, legend3d, h("div", { class: "viser-head" }, note, embed, open), frame, legend));

  const track: [number, number, number][] = [];
  let az = 35;
  let el = 35;
  let drag: [number, number] | null = null;
  canvas.addEventListener("pointerdown", (ev) => {
    drag = [ev.clientX, ev.clientY];
    canvas.setPointerCapture(ev.pointerId);
  });
  canvas.addEventListener("pointerup", () => (drag = null));
  canvas.addEventListener("pointermove", (ev) => {
    if (!drag) return;
    az -= (ev.clientX - drag[0]) * 0.5;
    el = Math.max(5, Math.min(85, el + (ev.clientY - drag[1]) * 0.3));
    drag = [ev.clientX, ev.clientY];
    draw();
  });

  const draw = rafThrottle(() => {
    const g = fitCanvas(canvas);
    if (!g) return;
    const scene = liveScene(store, track);
    const { pad, vehicle } = scene;
    const w = canvas.clientWidth;
    const hgt = canvas.clientHeight;
    drawPerspective(g, w, hgt, scene, az, el);
    // where the vision puts the camera: the pose (pad frame) turned into the local frame
    const pose = store.frame?.result.pose;
    if (pose) {
      const [x, y, z] = pose.position_m;
      const hd = (pad.headingDeg * Math.PI) / 180;
      const n = pad.n + y * Math.cos(hd) - x * Math.sin(hd);
      const e = pad.e + y * Math.sin(hd) + x * Math.cos(hd);
      const vision: LocalScene = { pad, vehicle: { n, e, d: -z, yaw: vehicle?.yaw ?? 0 }, track: [], footprint: null };
      g.save();
      g.globalAlpha = 0.9;
      drawVisionMark(g, w, hgt, vision, az, el);
      g.restore();
    }
  });

  store.subscribe("telemetry", () => {
    const p = store.telemetry?.position_ned;
    if (p && p.x !== null && p.y !== null && p.z !== null) {
      const last = track[track.length - 1];
      if (!last || Math.hypot(last[0] - p.x, last[1] - p.y, last[2] - p.z) > 0.05) {
        track.push([p.x, p.y, p.z]);
        if (track.length > TRACK_POINTS) track.shift();
      }
    }
    draw();
  });
  window.addEventListener("resize", draw);

  let embedded = false;
  let current: string | null = null;
  const apply = () => {
    const url = store.status?.viser_url ?? "";
    if (!url) {
      open.removeAttribute("href");
      embed.disabled = true;
      if (store.status) setText(note, "viser is off on this server.");
      return;
    }
    embed.disabled = false;
    open.href = url;
    if (embedded && url !== current) {
      current = url;
      frame.src = url;
    }
  };
  embed.addEventListener("click", () => {
    embedded = !embedded;
    frame.hidden = !embedded;
    legend.hidden = !embedded;
    embed.textContent = embedded ? "Close viser" : "Embed viser here";
    if (!embedded) {
      frame.removeAttribute("src");
      current = null;
    }
    apply();
  });
  store.subscribe("status", apply);
  return {
    open() {
      apply();
      draw();
    },
  };
}

/** The vision's camera position as an orange ring with a line down to the ground. */
function drawVisionMark(g: CanvasRenderingContext2D, w: number, hgt: number, scene: LocalScene, az: number, el: number): void {
  // the same projection as drawPerspective: draw onto a scratch scene and reuse it by
  // projecting one point through a tiny helper canvas would be heavier; recompute here
  const v = scene.vehicle;
  if (!v) return;
  const target: [number, number, number] = [scene.pad.n, scene.pad.e, 0];
  const dist = 14;
  const a = (az * Math.PI) / 180;
  const e = (el * Math.PI) / 180;
  const eye = [target[0] - dist * Math.cos(e) * Math.cos(a), target[1] - dist * Math.cos(e) * Math.sin(a), -dist * Math.sin(e)];
  const fwd = norm([target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]]);
  const right = norm(cross(fwd, [0, 0, -1]));
  const up = cross(right, fwd);
  const f = Math.min(w, hgt) * 1.1;
  const P = (p: number[]): [number, number] | null => {
    const d = [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]];
    const z = dot(d, fwd);
    return z <= 0.1 ? null : [w / 2 + (f * dot(d, right)) / z, hgt / 2 - (f * dot(d, up)) / z];
  };
  const c = P([v.n, v.e, v.d]);
  const ground = P([v.n, v.e, 0]);
  if (!c) return;
  g.strokeStyle = "#ff8c00";
  g.lineWidth = 2;
  g.beginPath();
  g.arc(c[0], c[1], 7, 0, 2 * Math.PI);
  g.stroke();
  if (ground) {
    g.setLineDash([3, 3]);
    g.beginPath();
    g.moveTo(c[0], c[1]);
    g.lineTo(ground[0], ground[1]);
    g.stroke();
    g.setLineDash([]);
  }
}

function dot(a: number[], b: number[]): number {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
function cross(a: number[], b: number[]): number[] {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}
function norm(a: number[]): number[] {
  const n = Math.hypot(a[0], a[1], a[2]) || 1;
  return [a[0] / n, a[1] / n, a[2] / n];
}
