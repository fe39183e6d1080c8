// The landing panel: the vision missions with every parameter and its default (hover
// over the pad; land on it by ArduCopter's precision landing or GCS guidance), whether
// the vehicle's precision landing is set up (and a one-step set-up), the running
// mission live (state, the pad in the image, the age of the last target against
// ArduPilot's limits), the camera's mount (camera-mount.ts), and the runs, each
// openable to its whole record.

import type { MissionField, MissionRun, MissionRunSummary } from "../lib/api";
import { fmt, fmtDate } from "../lib/format";
import { sentence } from "../lib/messages";
import { readTelemetry } from "../lib/telemetry";
import { mountCameraMountBox } from "./camera-mount";
import { confirmDialog } from "./confirm-dialog";
import { type Ctx, COLORS, fields, fitCanvas, h, panel, rafThrottle, setText } from "./dom";
import { extnavLine, setupExtnav } from "./extnav";
import { setupPrecland } from "./precland";

/** ArduPilot's AC_PrecLand: a measurement is used for 1 s, the target lost after 2 s. */
export const TARGET_STALE_S = 1;
export const TARGET_LOST_S = 2;

type Dict = Record<string, unknown>;

function num(value: unknown): number | null {
  return typeof value === "number" && Number.isFinite(value) ? value : null;
}

function nums(value: unknown): number[] | null {
  return Array.isArray(value) && value.every((v) => typeof v === "number") ? (value as number[]) : null;
}

/** "ok" / "warn" / "bad" for the age of the last target sent ("" once the mission ended). */
export function targetAgeLevel(age: number | null, running = true): string {
  if (age === null || !running) return "";
  return age < TARGET_STALE_S ? "ok" : age < TARGET_LOST_S ? "warn" : "bad";
}

interface Form {
  el: HTMLElement;
  values(): Record<string, number | string>;
}

function missionForm(kind: string, list: MissionField[]): Form {
  const inputs: [MissionField, HTMLInputElement | HTMLSelectElement][] = [];
  const el = h("div", { class: "mission-form", "data-testid": `${kind}-form` });
  for (const f of list) {
    const id = `${kind}-${f.name}`;
    let input: HTMLInputElement | HTMLSelectElement;
    if (f.kind === "choice") {
      input = h("select", { class: "input", id, "data-testid": id }, ...(f.choices ?? []).map((c) => h("option", { value: c }, c)));
      input.value = String(f.default);
    } else {
      input = h("input", {
        class: "input input-num",
        id,
        type: "number",
        step: "any",
        min: f.minimum ?? f.exclusive_minimum ?? undefined,
        max: f.maximum ?? undefined,
        value: String(f.default),
        "data-testid": id,
      });
    }
    input.title = f.description;
    inputs.push([f, input]);
    el.append(
      h(
        "label",
        { class: "mission-field", for: id, title: f.description },
        h("span", { class: "mission-field-name" }, f.title),
        input,
        h("span", { class: "mission-field-default" }, `default ${String(f.default)}${f.unit ? ` ${f.unit}` : ""}`),
      ),
    );
  }
  return {
    el,
    values() {
      const out: Record<string, number | string> = {};
      for (const [f, input] of inputs) {
        // a default the station works out (for the pad active when the mission starts) is left to it
        if (f.computed && input.value === String(f.default)) continue;
        out[f.name] = f.kind === "choice" ? input.value : Number(input.value);
      }
      return out;
    },
  };
}

/** A field's value outside its bounds, in one sentence (checked before anything is sent). */
export function checkField(f: MissionField, value: number | string): string | null {
  const choices = f.choices ?? [];
  if (f.kind === "choice") return choices.includes(String(value)) ? null : `${f.title} must be one of ${choices.join(", ")}.`;
  const v = Number(value);
  if (!Number.isFinite(v)) return `${f.title} must be a number.`;
  if (f.exclusive_minimum !== null && f.exclusive_minimum !== undefined && !(v > f.exclusive_minimum)) return `${f.title} must be more than ${f.exclusive_minimum} ${f.unit}.`.replace(" .", ".");
  if (f.minimum !== null && f.minimum !== undefined && v < f.minimum) return `${f.title} must be at least ${f.minimum} ${f.unit}.`.replace(" .", ".");
  if (f.maximum !== null && f.maximum !== undefined && v > f.maximum) return `${f.title} must be at most ${f.maximum} ${f.unit}.`.replace(" .", ".");
  return null;
}

export function mountMissionPanel(root: HTMLElement, ctx: Ctx): void {
  const { store, api } = ctx;
  const state = h("div", { class: "mission-state", "data-testid": "mission-panel-state" }, "No mission yet");
  const message = h("div", { class: "caption", "data-testid": "mission-message" }, "");
  const canvas = h("canvas", { class: "mission-canvas", "data-testid": "mission-target" });
  const ageBar = h("div", { class: "age-bar", "data-testid": "target-age-bar" }, h("div", { class: "age-fill" }));
  const right = h("div", { class: "mission-fields" });
  const f = fields(right, [
    ["estimate", "Pad offset (N, E)"],
    ["height", "Height over pad"],
    ["heading", "Heading error"],
    ["targetAge", "Last target sent"],
    ["seen", "Pad last seen"],
    ["counts", "Frames · seen · sent"],
    ["touchdown", "Touchdown"],
  ]);
  const plnd = h("div", { class: "plnd-line", "data-testid": "plnd-state" }, "Precision landing on the vehicle: reading its parameters…");
  const plndButton = h("button", { class: "btn btn-secondary btn-small", type: "button", "data-testid": "precland-setup" }, "Set up precision landing");
  const extnav = h("div", { class: "plnd-line", "data-testid": "extnav-state" }, "GPS-denied landing on the vehicle: reading its parameters…");
  const extnavButton = h("button", { class: "btn btn-secondary btn-small", type: "button", "data-testid": "extnav-setup" }, "Set up GPS-denied landing");
  const outcome = h("div", { class: "caption outcome-line", "data-testid": "mission-outcome", "aria-live": "polite" }, "");
  const hoverBox = h("div", { class: "mission-box" }, h("h3", { class: "sub-title" }, "Hover over the pad"));
  const landBox = h("div", { class: "mission-box" }, h("h3", { class: "sub-title" }, "Land on the pad"));
  const hoverButton = h("button", { class: "btn btn-primary", type: "button", "data-testid": "hover", disabled: true }, "Hover over pad");
  const landButton = h("button", { class: "btn btn-primary", type: "button", "data-testid": "mission-land", disabled: true }, "Land on pad");
  const historyBody = h("tbody", {});
  const history = h(
    "div",
    { class: "table-scroll" },
    h(
      "table",
      { class: "mission-history", "data-testid": "mission-history" },
      h("thead", {}, h("tr", {}, h("th", {}, "#"), h("th", {}, "Mission"), h("th", {}, "Outcome"), h("th", {}, "Touchdown"), h("th", {}, "Heading"), h("th", {}, "Time"))),
      historyBody,
    ),
  );
  const runDetail = h("div", { class: "run-detail", "data-testid": "run-detail", hidden: true });
  // under the live mission, so the mission buttons stay on the first screen
  const cameraMount = h("div", {});
  mountCameraMountBox(cameraMount, ctx);
  const section = panel(
    "Landing",
    "mission",
    h("div", { class: "plnd-row" }, plnd, plndButton),
    h("div", { class: "plnd-row" }, extnav, extnavButton),
    h("div", { class: "mission-forms" }, hoverBox, landBox),
    outcome,
    state,
    message,
    h("div", { class: "mission-body" }, h("div", { class: "mission-view" }, canvas, ageBar), right),
    cameraMount,
    h("h3", { class: "sub-title" }, "Runs (click one for its record)"),
    history,
    runDetail,
  );
  root.append(section);

  function say(ok: boolean, text: string): void {
    setText(outcome, text);
    outcome.dataset.ok = String(ok);
  }

  plndButton.addEventListener("click", async () => {
    plndButton.disabled = true;
    try {
      const r = await setupPrecland(ctx);
      if (r) say(r.ok, r.text);
    } finally {
      plndButton.disabled = false;
    }
  });

  extnavButton.addEventListener("click", async () => {
    extnavButton.disabled = true;
    try {
      const r = await setupExtnav(ctx);
      if (r) say(r.ok, r.text);
    } finally {
      extnavButton.disabled = false;
    }
  });

  // --- the forms, from the server's own defaults and bounds ---
  let hoverFields: MissionField[] = [];
  let landFields: MissionField[] = [];
  let hoverForm: Form | null = null;
  let landForm: Form | null = null;
  void api
    .missionDefaults()
    .then((d) => {
      hoverFields = d.hover;
      landFields = d.land;
      hoverForm = missionForm("hover", d.hover);
      landForm = missionForm("land", d.land);
      hoverBox.append(hoverForm.el, hoverButton);
      landBox.append(landForm.el, landButton);
      hoverButton.disabled = false;
      landButton.disabled = false;
    })
    .catch((error: Error) => say(false, sentence("The mission settings could not be loaded", error.message)));

  function invalid(list: MissionField[], values: Record<string, number | string>): string | null {
    for (const field of list) {
      if (!(field.name in values)) continue; // left to the station
      const problem = checkField(field, values[field.name]);
      if (problem) return problem;
    }
    return null;
  }

  hoverButton.addEventListener("click", async () => {
    if (!hoverForm) return;
    const v = hoverForm.values();
    const problem = invalid(hoverFields, v);
    if (problem) return say(false, problem);
    const tel = readTelemetry(store.telemetry);
    const flying = tel.armed && (tel.altitudeM ?? 0) > 0.3;
    const s = store.settings as Dict;
    const lines = [
      tel.mode === "GUIDED" ? "Stays in GUIDED." : `Switches ${tel.mode ?? "the vehicle"} to GUIDED.`,
      flying ? `Already flying: climbs or descends to ${v.altitude_m} m.` : `Arms the motors and takes off to ${v.altitude_m} m above home.`,
      `Flies over the pad's place (N ${fmt(num(s.pad_north_m) ?? 0, 1)} m, E ${fmt(num(s.pad_east_m) ?? 0, 1)} m) and holds ${v.hold_s} s, centring over the pad by vision and recording.`,
      `If it gives up: ${v.abort_mode}. ABORT (top right) stops it at any time and holds.`,
    ];
    if (!(await confirmDialog({ title: "Start the hover mission?", lines, confirmLabel: flying ? "Start" : "Arm and take off" }))) return;
    await start("hover", v);
  });

  landButton.addEventListener("click", async () => {
    if (!landForm) return;
    const v = landForm.values();
    const problem = invalid(landFields, v);
    if (problem) return say(false, problem);
    const plndOn = v.strategy === "plnd";
    const extnavOn = v.strategy === "extnav";
    const lines = [
      `Looks for the pad from ${String(v.approach_alt_m ?? landFields.find((x) => x.name === "approach_alt_m")?.default)} m over its place, then centres and turns over it by vision (GUIDED).`,
      plndOn
        ? "Descends in LAND mode fed LANDING_TARGET from each frame: ArduCopter's precision landing steers."
        : extnavOn
          ? "Then sends each frame's pose as the vehicle's position (VISION_POSITION_ESTIMATE), switches the EKF to source set 2 (vision) and descends in LAND on it: GPS is not needed from there."
          : "Descends on GUIDED velocity targets from the vision pose, then LAND for the last few centimetres.",
      extnavOn
        ? "Pad lost once on vision (no GPS to hold on): lands where it is at once (LAND, level), not on the pad, and says so."
        : `Pad unseen ${v.lost_timeout_s} s: climbs and searches ${v.search_s} s, then ${v.abort_mode}.`,
      "The vehicle must be flying (take off or hover first). ABORT stops it at any time and holds.",
    ];
    const how = plndOn ? "precision landing" : extnavOn ? "GPS-denied, on vision" : "GCS guidance";
    if (!(await confirmDialog({ title: `Land on the pad (${how})?`, lines, confirmLabel: "Land on pad" }))) return;
    await start("land", v);
  });

  async function start(kind: "hover" | "land", body: Record<string, number | string>): Promise<void> {
    const button = kind === "hover" ? hoverButton : landButton;
    button.disabled = true;
    say(true, `${kind === "hover" ? "Hover" : "Landing"}: starting…`);
    delete outcome.dataset.ok;
    try {
      const r = await api.mission(kind, body);
      say(r.ok, r.ok ? sentence(kind === "hover" ? "Hover mission started" : `Landing started (${String(body.strategy)})`) : sentence(kind === "hover" ? "Hover not started" : "Landing not started", r.message));
      if (r.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    } finally {
      button.disabled = false;
    }
  }

  // --- PLND state, as the vehicle reports it ---
  async function loadPlnd(): Promise<void> {
    try {
      const l = await api.request<{ params: { name: string; value: number }[] }>("GET", "/api/params?names=PLND_ENABLED,PLND_TYPE,PLND_LAG");
      const get = (n: string) => l.params.find((p) => p.name === n)?.value ?? null;
      const en = get("PLND_ENABLED");
      const type = get("PLND_TYPE");
      const lag = get("PLND_LAG");
      if (en === null || type === null) {
        setText(plnd, "Precision landing on the vehicle: not read yet (the link is not up).");
        plnd.dataset.level = "";
        return;
      }
      const ready = en === 1 && type === 1;
      setText(
        plnd,
        ready
          ? `Precision landing is set up on the vehicle: PLND_ENABLED 1, PLND_TYPE 1 (MAVLink), PLND_LAG ${lag === null ? "?" : Number(lag.toPrecision(3))} s.`
          : `Precision landing is off on the vehicle (PLND_ENABLED ${en}, PLND_TYPE ${type}): set it up before landing with the "plnd" strategy.`,
      );
      plnd.dataset.level = ready ? "ok" : "warn";
      plndButton.textContent = ready ? "Set up again" : "Set up precision landing";
    } catch {
      // the server is down: the line keeps what it said
    }
  }

  // --- external navigation (the GPS-denied landing), as the vehicle reports it ---
  async function loadExtnav(): Promise<void> {
    try {
      const l = await api.request<{ params: { name: string; value: number }[] }>("GET", "/api/params?names=VISO_TYPE,EK3_SRC2_POSXY");
      const get = (n: string) => l.params.find((p) => p.name === n)?.value ?? null;
      const line = extnavLine(get("VISO_TYPE"), get("EK3_SRC2_POSXY"));
      setText(extnav, line.text);
      extnav.dataset.level = line.ready ? "ok" : get("VISO_TYPE") === null ? "" : "warn";
      extnavButton.textContent = line.ready ? "Set up again" : "Set up GPS-denied landing";
    } catch {
      // the server is down: the line keeps what it said
    }
  }

  // --- the live mission ---
  let mission: Dict | null = null;
  let receivedAt = performance.now();
  let lastOutcomeKey = "";
  const running = () => mission !== null && !mission.outcome;

  function ageNow(key: string): number | null {
    const age = mission ? num(mission[key]) : null;
    if (age === null) return null;
    // the server's figure is as of its message; it keeps growing while the mission runs
    return running() ? age + (performance.now() - receivedAt) / 1000 : age;
  }

  const draw = rafThrottle(() => {
    const g = fitCanvas(canvas);
    if (!g) return;
    const w = canvas.clientWidth;
    const hgt = canvas.clientHeight;
    g.fillStyle = COLORS.bg;
    g.fillRect(0, 0, w, hgt);
    const size = mission ? nums(mission.image_size) : null;
    const iw = size?.[0] ?? 640;
    const ih = size?.[1] ?? 480;
    const scale = Math.min(w / iw, hgt / ih);
    const ox = (w - iw * scale) / 2;
    const oy = (hgt - ih * scale) / 2;
    g.strokeStyle = COLORS.grid;
    g.strokeRect(ox, oy, iw * scale, ih * scale);
    g.beginPath();
    g.moveTo(ox + (iw * scale) / 2 - 8, oy + (ih * scale) / 2);
    g.lineTo(ox + (iw * scale) / 2 + 8, oy + (ih * scale) / 2);
    g.moveTo(ox + (iw * scale) / 2, oy + (ih * scale) / 2 - 8);
    g.lineTo(ox + (iw * scale) / 2, oy + (ih * scale) / 2 + 8);
    g.stroke();
    const fix = mission && typeof mission.fix === "object" ? (mission.fix as Dict | null) : null;
    const px = fix ? nums(fix.image_px) : null;
    const seen = ageNow("pad_seen_age_s");
    if (px && px.length === 2) {
      g.strokeStyle = !running() ? COLORS.muted : seen === null || seen > TARGET_STALE_S ? COLORS.warn : COLORS.ok;
      g.lineWidth = 2;
      g.beginPath();
      g.arc(ox + px[0] * scale, oy + px[1] * scale, 7, 0, 2 * Math.PI);
      g.stroke();
      g.lineWidth = 1;
    }
    const age = ageNow("target_age_s");
    const fill = ageBar.firstElementChild as HTMLElement;
    fill.style.width = running() ? `${Math.min(100, ((age ?? 0) / TARGET_LOST_S) * 100)}%` : "0%";
    ageBar.dataset.level = targetAgeLevel(age, running());
    // After the mission, the last figures are history: shown plain, never green.
    setText(
      f.targetAge,
      age === null ? "—" : running() ? `${fmt(age, 2, "s")} ago (limits ${TARGET_STALE_S}/${TARGET_LOST_S} s)` : "— (the mission ended)",
    );
    f.targetAge.dataset.level = targetAgeLevel(age, running());
    setText(f.seen, seen === null ? "—" : running() ? `${fmt(seen, 2, "s")} ago` : "— (the mission ended)");
  });

  function render(): void {
    const m = mission;
    if (!m) {
      setText(state, "No mission yet");
      draw();
      return;
    }
    const kind = String(m.kind ?? "mission");
    const strat = m.strategy ? ` (${String(m.strategy)})` : "";
    setText(state, `${kind}${strat} · ${String(m.state ?? "")}${m.outcome ? "" : " · running"}`);
    state.dataset.state = String(m.state ?? "");
    setText(message, m.message ? sentence(String(m.message)) : "");
    const fix = typeof m.fix === "object" && m.fix ? (m.fix as Dict) : null;
    const off = fix ? nums(fix.offset_ned) : null;
    setText(f.estimate, off ? `${fmt(off[0], 2, "m")}, ${fmt(off[1], 2, "m")}` : "—");
    setText(f.height, fix ? fmt(num(fix.height_m), 2, "m") : "—");
    setText(f.heading, fix ? fmt(num(fix.heading_error_deg), 1, "°") : "—");
    setText(f.counts, `${m.frames ?? 0} · ${m.detections ?? 0} · ${m.targets_sent ?? 0}`);
    const td = typeof m.touchdown === "object" && m.touchdown ? (m.touchdown as Dict) : null;
    setText(
      f.touchdown,
      td ? `${fmt((num(td.error_m) ?? NaN) * 100, 1, "cm")} · ${fmt(num(td.heading_error_deg), 1, "°")} (${String(td.source ?? "")})` : "—",
    );
    draw();
  }

  async function showRun(id: number): Promise<void> {
    runDetail.hidden = false;
    runDetail.replaceChildren(h("div", { class: "caption" }, `Loading run ${id}…`));
    try {
      const run = await api.request<MissionRun>("GET", `/api/missions/${id}`);
      const d = run.detail;
      const t0 = run.started;
      runDetail.replaceChildren(
        h("div", { class: "run-head" }, h("strong", {}, `Run ${run.id}: ${run.kind}${d.strategy ? ` (${d.strategy})` : ""}`), ` · ${fmtDate(t0)} · ${run.outcome ?? "running"}`, h("button", { class: "btn btn-ghost btn-small", type: "button", onclick: () => (runDetail.hidden = true) }, "Close")),
        h("p", { class: "caption" }, d.message ? sentence(d.message) : ""),
        h(
          "ol",
          { class: "run-states", "data-testid": "run-states" },
          ...(d.states ?? []).map((s) => h("li", {}, h("span", { class: "num" }, `+${fmt(s.t, 1, "s")}`), ` ${s.state}`, s.reason ? h("span", { class: "caption" }, ` — ${s.reason}`) : null)),
        ),
        h("div", { class: "caption" }, `${d.frames} frames · pad seen in ${d.detections} · ${d.targets_sent} targets sent${d.touchdown?.error_m != null ? ` · touchdown ${fmt(d.touchdown.error_m * 100, 1, "cm")} from the centre` : ""}`),
        ...(d.notes ?? []).map((n) => h("div", { class: "caption" }, n)),
      );
    } catch (error) {
      runDetail.replaceChildren(h("div", { class: "caption" }, sentence("This run could not be loaded", (error as Error).message)));
    }
  }

  async function loadHistory(): Promise<void> {
    try {
      const runs = await api.request<MissionRunSummary[]>("GET", "/api/missions");
      if (!Array.isArray(runs)) return;
      historyBody.replaceChildren(
        ...runs.slice(0, 20).map((r) => {
          const err = num(r.touchdown?.error_m);
          const head = num(r.touchdown?.heading_error_deg);
          const row = h(
            "tr",
            { class: "clickable", tabindex: "0", "data-outcome": r.outcome ?? "running", title: r.message, "data-run": String(r.id) },
            h("td", {}, String(r.id)),
            h("td", {}, `${r.kind}${r.strategy ? ` (${r.strategy})` : ""}`),
            h("td", {}, r.outcome ?? "running"),
            h("td", {}, err === null ? "—" : fmt(err * 100, 1, "cm")),
            h("td", {}, head === null ? "—" : fmt(head, 1, "°")),
            h("td", {}, fmt(num(r.duration_s), 1, "s")),
          );
          row.addEventListener("click", () => void showRun(r.id));
          row.addEventListener("keydown", (ev) => {
            if (ev.key === "Enter") void showRun(r.id);
          });
          return row;
        }),
      );
    } catch {
      // the server is down: the table stays as it was
    }
  }

  store.subscribe(["status"], () => {
    const m = store.status?.mission ?? null;
    mission = m && typeof m === "object" ? (m as Dict) : null;
    receivedAt = performance.now();
    render();
    const key = mission ? `${String(mission.run_id)}:${String(mission.outcome)}:${String(mission.stored)}` : "";
    if (key !== lastOutcomeKey) {
      lastOutcomeKey = key;
      void loadHistory();
    }
  });
  let lastLink = "";
  store.subscribe(["telemetry", "event"], () => {
    const link = readTelemetry(store.telemetry).linkState;
    const last = store.events.length ? store.events.toArray()[store.events.length - 1] : null;
    const key = `${link}|${last?.kind === "param" ? last.t : ""}`;
    if (key !== lastLink) {
      lastLink = key;
      void loadPlnd();
      void loadExtnav();
    }
  });
  setInterval(draw, 250);
  setInterval(() => void loadPlnd(), 5000);
  setInterval(() => void loadExtnav(), 5000);
  render();
  void loadHistory();
}
