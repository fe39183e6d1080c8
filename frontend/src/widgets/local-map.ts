// The live local-frame map: top-down, north up, metres from home: home, the pad (its
// place, size and heading), the vehicle and its track, the camera's footprint.

import { readTelemetry } from "../lib/telemetry";
import { type Ctx, fitCanvas, h, panel, rafThrottle, setText } from "./dom";
import { drawTopDown, liveScene } from "./map-draw";

const TRACK_POINTS = 600;

export function mountLocalMap(root: HTMLElement, ctx: Ctx): void {
  const { store } = ctx;
  const canvas = h("canvas", { class: "map-canvas", "data-testid": "local-map" });
  const caption = h("div", { class: "caption", "data-testid": "map-caption" }, "Waiting for the vehicle's local position…");
  const legend = h(
    "div",
    { class: "legend" },
    h("span", { class: "lg lg-home" }, "home"),
    h("span", { class: "lg lg-pad" }, "pad"),
    h("span", { class: "lg lg-vehicle" }, "vehicle"),
    h("span", { class: "lg lg-track" }, "track"),
    h("span", { class: "lg lg-footprint" }, "camera footprint"),
  );
  root.append(panel("Map (local frame)", "map", canvas, legend, caption));
  const track: [number, number, number][] = [];

  const draw = rafThrottle(() => {
    const g = fitCanvas(canvas);
    if (!g) return;
    const t = store.telemetry;
    const scene = liveScene(store, track);
    const vehicle = scene.vehicle;
    drawTopDown(g, canvas.clientWidth, canvas.clientHeight, scene);
    if (vehicle) {
      const v = readTelemetry(t);
      const dn = vehicle.n - scene.pad.n;
      const de = vehicle.e - scene.pad.e;
      setText(caption, `vehicle N ${vehicle.n.toFixed(1)} m, E ${vehicle.e.toFixed(1)} m, ${(v.altitudeM ?? -vehicle.d).toFixed(1)} m up; ${Math.hypot(dn, de).toFixed(1)} m from the pad`);
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
  store.subscribe("settings", draw);
  window.addEventListener("resize", draw);
  draw();
}
