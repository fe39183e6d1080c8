// Recorded flights: list (start, length, frames, size on disk, how it ended), .tlog
// download, delete (confirmed), and replay in the page: the camera frames with their
// overlays, the telemetry, the mission's state, the map and a 3D view, all at one time
// driven by play/pause and the scrubber.

import { ApiError, describeFailure, type FlightReplay, type FlightSummary } from "../lib/api";
import { cameraFootprint, mountOf } from "../lib/footprint";
import { fmt, fmtDate } from "../lib/format";
import { sentence } from "../lib/messages";
import { at, clock, missionStateAt } from "../lib/timeline";
import { confirmDialog } from "./confirm-dialog";
import { COLORS, type Ctx, fitCanvas, h, panel, setText } from "./dom";
import { drawPerspective, drawTopDown, type LocalScene } from "./map-draw";

export function fmtBytes(n: number): string {
  if (n < 1024) return `${n} B`;
  if (n < 1024 * 1024) return `${(n / 1024).toFixed(0)} kB`;
  return `${(n / 1024 / 1024).toFixed(1)} MB`;
}

export function mountFlightsPanel(root: HTMLElement, ctx: Ctx): { load(): void } {
  const { api, store } = ctx;
  const body = h("tbody", { "data-testid": "flight-rows" });
  const outcome = h("div", { class: "caption outcome-line", "data-testid": "flight-outcome", "aria-live": "polite" });
  const reload = h("button", { class: "btn btn-small btn-ghost", type: "button", "data-testid": "flights-reload" }, "Refresh");
  const player = h("div", { class: "replay", "data-testid": "replay", hidden: true });
  root.append(
    panel(
      "Flights",
      "flights",
      h("div", { class: "control-row" }, h("span", { class: "caption" }, "A flight is recorded from arming to disarming (.tlog, frames, vision results)."), reload),
      outcome,
      h(
        "div",
        { class: "table-scroll" },
        h(
          "table",
          { class: "data-table flights-table" },
          h("thead", {}, h("tr", {}, h("th", {}, "#"), h("th", {}, "Started"), h("th", {}, "Length"), h("th", {}, "Frames"), h("th", {}, "Size"), h("th", {}, "Ended"), h("th", {}, ""))),
          body,
        ),
      ),
      player,
    ),
  );
  const say = (ok: boolean, text: string) => {
    setText(outcome, text);
    outcome.dataset.ok = String(ok);
  };

  async function load(): Promise<void> {
    try {
      const flights = await api.flights();
      const current = store.status?.flight?.id ?? null;
      body.replaceChildren(...flights.map((f) => row(f, f.id === current)));
      if (flights.length === 0) body.append(h("tr", {}, h("td", { colspan: "7", class: "caption" }, "No flights yet: one is recorded each time the vehicle arms.")));
    } catch (error) {
      say(false, sentence("The flights could not be listed", (error as Error).message));
    }
  }

  function row(f: FlightSummary, recording: boolean): HTMLElement {
    const replay = h("button", { class: "btn btn-small btn-primary", type: "button", "data-testid": `replay-${f.id}` }, "Replay");
    const tlog = h("a", { class: "btn btn-small btn-ghost", href: api.url(f.tlog), download: `flight-${f.id}.tlog`, "data-testid": `tlog-${f.id}` }, ".tlog");
    const del = h("button", { class: "btn btn-small btn-danger-outline", type: "button", "data-testid": `delete-${f.id}` }, "Delete");
    del.disabled = recording;
    replay.addEventListener("click", () => void openReplay(f.id));
    del.addEventListener("click", async () => {
      const yes = await confirmDialog({
        title: `Delete flight ${f.id}?`,
        lines: [`Its .tlog, ${f.frames} frames and vision results (${fmtBytes(f.size_bytes)}) are deleted for good.`],
        confirmLabel: "Delete",
        danger: true,
      });
      if (!yes) return;
      try {
        const r = await api.deleteFlight(f.id);
        say(true, `Flight ${r.id} deleted: ${fmtBytes(r.freed_bytes)} freed.`);
        if (openId === f.id) closeReplay();
      } catch (error) {
        if (error instanceof ApiError && error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
        say(false, error instanceof ApiError ? describeFailure(error) : String(error));
      }
      void load();
    });
    const length = f.ended ? f.ended - f.started : null;
    return h(
      "tr",
      { "data-flight": String(f.id) },
      h("td", {}, String(f.id)),
      h("td", {}, fmtDate(f.started)),
      h("td", { class: "num" }, length === null ? "recording" : clock(length)),
      h("td", { class: "num" }, String(f.frames)),
      h("td", { class: "num", "data-testid": `size-${f.id}` }, fmtBytes(f.size_bytes)),
      h("td", { class: "caption" }, recording ? "recording now" : (f.end_reason ?? "")),
      h("td", { class: "row-actions" }, replay, tlog, del),
    );
  }

  // --- the player ---
  let openId: number | null = null;
  let stopPlayer: (() => void) | null = null;
  function closeReplay(): void {
    stopPlayer?.();
    stopPlayer = null;
    openId = null;
    player.hidden = true;
    player.replaceChildren();
  }

  async function openReplay(id: number): Promise<void> {
    closeReplay();
    openId = id;
    player.hidden = false;
    player.replaceChildren(h("div", { class: "caption" }, `Loading flight ${id}…`));
    let data: FlightReplay;
    try {
      data = await api.replay(id);
    } catch (error) {
      player.replaceChildren(h("div", { class: "caption" }, sentence("This flight cannot be replayed", (error as Error).message)));
      return;
    }
    if (openId !== id) return;
    stopPlayer = buildPlayer(player, ctx, data, closeReplay);
  }

  reload.addEventListener("click", () => void load());
  return { load: () => void load() };
}

function buildPlayer(root: HTMLElement, ctx: Ctx, data: FlightReplay, close: () => void): () => void {
  const { api, store } = ctx;
  const duration = Math.max(0.1, data.t1 - data.t0);
  let t = data.frames[0]?.t ?? data.telemetry[0]?.t ?? data.t0;
  let playing = false;
  let speed = 1;
  let last = 0;
  let raf = 0;

  const frameCanvas = h("canvas", { class: "replay-frame", "data-testid": "replay-frame" });
  const mapCanvas = h("canvas", { class: "replay-map", "data-testid": "replay-map" });
  const view3d = h("canvas", { class: "replay-3d", "data-testid": "replay-3d" });
  const play = h("button", { class: "btn btn-primary btn-small", type: "button", "data-testid": "replay-play" }, "Play");
  const scrub = h("input", { type: "range", class: "scrubber", min: "0", max: String(duration), step: "0.05", value: String(t - data.t0), "data-testid": "replay-scrubber", "aria-label": "Time in the flight" });
  const time = h("span", { class: "num", "data-testid": "replay-time" }, "");
  const speedSel = h("select", { class: "input", "data-testid": "replay-speed", "aria-label": "Replay speed" }, ...[1, 2, 4, 8].map((s) => h("option", { value: String(s) }, `${s}×`)));
  const tel = h("div", { class: "replay-telemetry", "data-testid": "replay-telemetry" });
  const mission = h("div", { class: "replay-mission", "data-testid": "replay-mission" });
  const texts = h("ol", { class: "messages replay-texts", "data-testid": "replay-texts" });
  const closeBtn = h("button", { class: "btn btn-ghost btn-small", type: "button" }, "Close");
  closeBtn.addEventListener("click", close);
  root.replaceChildren(
    h("div", { class: "replay-head" }, h("strong", {}, `Replay of flight ${data.id}`), h("span", { class: "caption" }, ` ${fmtDate(data.t0)} · ${data.frames.length} frames · ${data.telemetry.length} telemetry samples`), closeBtn),
    h("div", { class: "replay-controls" }, play, scrub, time, speedSel),
    h(
      "div",
      { class: "replay-grid" },
      h("figure", { class: "replay-cell" }, frameCanvas, h("figcaption", {}, "camera with the vision's overlay")),
      h("figure", { class: "replay-cell" }, mapCanvas, h("figcaption", {}, "map: home, pad, vehicle, track, camera footprint")),
      h("figure", { class: "replay-cell" }, view3d, h("figcaption", {}, "3D: drag to turn")),
      h("div", { class: "replay-cell" }, mission, tel, texts),
    ),
  );

  // frames: the last one at or before t, its JPEG loaded once and kept while near
  const images = new Map<string, HTMLImageElement>();
  function image(url: string): HTMLImageElement {
    let img = images.get(url);
    if (!img) {
      img = new Image();
      img.onload = () => draw();
      img.src = api.url(url);
      images.set(url, img);
      if (images.size > 40) images.delete(images.keys().next().value as string);
    }
    return img;
  }

  let az = 35;
  let el = 35;
  let dragging: [number, number] | null = null;
  view3d.addEventListener("pointerdown", (ev) => (dragging = [ev.clientX, ev.clientY]));
  window.addEventListener("pointerup", () => (dragging = null));
  view3d.addEventListener("pointermove", (ev) => {
    if (!dragging) return;
    az -= (ev.clientX - dragging[0]) * 0.5;
    el = Math.max(5, Math.min(85, el + (ev.clientY - dragging[1]) * 0.3));
    dragging = [ev.clientX, ev.clientY];
    draw();
  });

  const settings = store.settings as Record<string, unknown>;
  const pad = { n: Number(settings.pad_north_m ?? 0), e: Number(settings.pad_east_m ?? 0), size: Number(settings.pad_size_m ?? 0.55), headingDeg: Number(settings.pad_heading_deg ?? 0) };

  function draw(): void {
    const rel = t - data.t0;
    setText(time, `${clock(rel)} / ${clock(duration)}`);
    if (document.activeElement !== scrub) scrub.value = String(rel);
    // camera frame
    const f = at(data.frames, t);
    const g = frameCanvas.getContext("2d");
    if (g) {
      if (f?.url) {
        const img = image(f.url);
        if (img.complete && img.naturalWidth > 0) {
          if (frameCanvas.width !== img.naturalWidth) {
            frameCanvas.width = img.naturalWidth;
            frameCanvas.height = img.naturalHeight;
          }
          g.drawImage(img, 0, 0);
        }
      } else {
        frameCanvas.width = 640;
        frameCanvas.height = 480;
        g.fillStyle = COLORS.bg;
        g.fillRect(0, 0, 640, 480);
        g.fillStyle = COLORS.muted;
        g.font = "16px sans-serif";
        g.fillText(f ? "no picture kept for this frame" : "no frame yet", 20, 40);
      }
      if (f) drawOverlay(g, f);
      frameCanvas.dataset.seq = f ? String(f.seq) : "";
    }
    // telemetry, mission
    const s = at(data.telemetry, t);
    tel.replaceChildren(
      h("div", {}, h("span", { class: "stat-label" }, "Mode "), s?.mode ?? "—", h("span", { class: "stat-label" }, "  State "), s?.armed === null || s?.armed === undefined ? "—" : s.armed ? "ARMED" : "DISARMED"),
      h("div", {}, h("span", { class: "stat-label" }, "Alt "), fmt(s?.alt ?? (s?.d == null ? null : -s.d), 2, "m"), h("span", { class: "stat-label" }, "  Battery "), fmt(s?.battery_v ?? null, 2, "V")),
      h("div", {}, h("span", { class: "stat-label" }, "Vision "), f ? (f.detected ? `H found (frame ${f.seq})` : `no H (frame ${f.seq})`) : "—"),
    );
    tel.dataset.mode = s?.mode ?? "";
    const ms = missionStateAt(data.missions, t);
    setText(mission, ms ? `Mission ${ms.run}: ${ms.kind}${ms.strategy ? ` (${ms.strategy})` : ""} · ${ms.state}${ms.reason ? ` — ${ms.reason}` : ""}` : "No mission at this time.");
    mission.dataset.state = ms?.state ?? "";
    const recent = data.texts.filter((x) => x.t <= t).slice(-6).reverse();
    texts.replaceChildren(...recent.map((x) => h("li", {}, x.text)));
    // map and 3D
    const track = data.telemetry.filter((x) => x.t <= t && x.n !== null && x.e !== null && x.d !== null).map((x) => [x.n, x.e, x.d] as [number, number, number]);
    const vehicle = s && s.n !== null && s.e !== null && s.d !== null ? { n: s.n, e: s.e, d: s.d, yaw: s.yaw ?? 0 } : null;
    const footprint =
      vehicle && s && s.roll !== null && s.pitch !== null && s.yaw !== null
        ? cameraFootprint([vehicle.n, vehicle.e, vehicle.d], s.roll, s.pitch, s.yaw, Number(settings.camera_hfov_deg ?? 60), Number(settings.camera_aspect ?? 4 / 3), mountOf(settings))
        : null;
    const scene: LocalScene = { pad, vehicle, track, footprint };
    const gm = fitCanvas(mapCanvas);
    if (gm) drawTopDown(gm, mapCanvas.clientWidth, mapCanvas.clientHeight, scene);
    const g3 = fitCanvas(view3d);
    if (g3) drawPerspective(g3, view3d.clientWidth, view3d.clientHeight, scene, az, el);
    root.dataset.t = String(rel.toFixed(2));
  }

  function drawOverlay(g: CanvasRenderingContext2D, f: FlightReplay["frames"][number]): void {
    const px = Math.max(1, frameCanvas.width / 640);
    if (f.contour_px.length > 1) {
      g.strokeStyle = COLORS.contour;
      g.lineWidth = 2 * px;
      g.beginPath();
      f.contour_px.forEach(([x, y], i) => (i ? g.lineTo(x, y) : g.moveTo(x, y)));
      g.closePath();
      g.stroke();
    }
    g.fillStyle = COLORS.corners;
    for (const [x, y] of f.corners_px) g.fillRect(x - 3 * px, y - 3 * px, 6 * px, 6 * px);
    const target = (f.overlay as { target?: [number, number] | null } | null)?.target;
    if (target) {
      const [x, y] = target;
      g.strokeStyle = COLORS.target;
      g.lineWidth = 2 * px;
      g.beginPath();
      g.moveTo(x - 14 * px, y);
      g.lineTo(x + 14 * px, y);
      g.moveTo(x, y - 14 * px);
      g.lineTo(x, y + 14 * px);
      g.stroke();
    }
  }

  function tick(now: number): void {
    if (!playing) return;
    const dt = last ? (now - last) / 1000 : 0;
    last = now;
    t = Math.min(data.t1, t + dt * speed);
    draw();
    if (t >= data.t1) {
      setPlaying(false);
      return;
    }
    raf = requestAnimationFrame(tick);
  }
  function setPlaying(on: boolean): void {
    playing = on;
    play.textContent = on ? "Pause" : "Play";
    play.dataset.playing = String(on);
    cancelAnimationFrame(raf);
    if (on) {
      if (t >= data.t1) t = data.t0;
      last = 0;
      raf = requestAnimationFrame(tick);
    }
  }
  play.addEventListener("click", () => setPlaying(!playing));
  scrub.addEventListener("input", () => {
    t = data.t0 + Number(scrub.value);
    draw();
  });
  speedSel.addEventListener("change", () => (speed = Number(speedSel.value)));
  window.addEventListener("resize", draw);
  draw();
  // for the browser tests: the player's clock
  (window as unknown as { visland: Record<string, unknown> }).visland.replay = { get t() { return t - data.t0; }, get playing() { return playing; } };
  return () => {
    playing = false;
    cancelAnimationFrame(raf);
    window.removeEventListener("resize", draw);
  };
}
