// Precision-landing panel: the running mission's state, the pad in the image, the
// estimate the guidance steers by, the age of the last target sent against
// ArduPilot's limits (a LANDING_TARGET is used for 1 s; the target is lost 2 s after
// the last one), and the history of runs with their touchdown errors.

import { fmt } from "../lib/format";
import { confirmButton } from "./confirm";
import { type Ctx, COLORS, fields, fitCanvas, h, panel, rafThrottle, setText } from "./dom";

/** ArduPilot's AC_PrecLand: a measurement is used for 1 s, the target lost after 2 s. */
export const TARGET_STALE_S = 1;
export const TARGET_LOST_S = 2;

type Dict = Record<string, unknown>;

interface RunSummary {
  id: number;
  kind: string;
  strategy: string | null;
  outcome: string | null;
  message: string;
  started: number;
  duration_s: number | null;
  touchdown: { error_m?: number | null; heading_error_deg?: number | null; source?: string } | null;
}

function num(value: unknown): number | null {
  return typeof value === "number" && Number.isFinite(value) ? value : null;
}

function nums(value: unknown): number[] | null {
  return Array.isArray(value) && value.every((v) => typeof v === "number") ? (value as number[]) : null;
}

/** "ok" / "warn" / "bad" for the age of the last target sent. */
export function targetAgeLevel(age: number | null): string {
  if (age === null) return "";
  return age < TARGET_STALE_S ? "ok" : age < TARGET_LOST_S ? "warn" : "bad";
}

export function mountMissionPanel(root: HTMLElement, ctx: Ctx): void {
  const { store, api } = ctx;
  const state = h("div", { class: "mission-state", "data-testid": "mission-panel-state" }, "No mission");
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
  const strategy = h(
    "select",
    { class: "select", "data-testid": "mission-strategy", "aria-label": "Landing strategy" },
    h("option", { value: "plnd" }, "ArduCopter precision landing"),
    h("option", { value: "guided" }, "GCS guidance (GUIDED)"),
  );
  const outcome = h("div", { class: "caption", "data-testid": "mission-outcome" }, "");
  const landButton = confirmButton("Land on pad", "mission-land", "btn-primary", async (button) => {
    button.disabled = true;
    try {
      const result = await api.mission("land", { strategy: strategy.value });
      setText(outcome, result.ok ? `Landing started (${strategy.value})` : result.message);
      outcome.dataset.ok = String(result.ok);
      if (result.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    } finally {
      button.disabled = false;
    }
  });
  const historyBody = h("tbody", {});
  const history = h(
    "table",
    { class: "mission-history", "data-testid": "mission-history" },
    h(
      "thead",
      {},
      h("tr", {}, h("th", {}, "#"), h("th", {}, "Mission"), h("th", {}, "Outcome"), h("th", {}, "Touchdown"), h("th", {}, "Heading"), h("th", {}, "Time")),
    ),
    historyBody,
  );
  const section = panel(
    "Precision landing",
    "mission",
    state,
    message,
    h("div", { class: "mission-body" }, h("div", { class: "mission-view" }, canvas, ageBar), right),
    h("div", { class: "control-row" }, strategy, landButton),
    outcome,
    h("h3", { class: "sub-title" }, "Runs"),
    history,
  );
  root.append(section);

  let mission: Dict | null = null;
  let receivedAt = performance.now();
  let lastOutcomeKey = "";

  function ageNow(key: string): number | null {
    const age = mission ? num(mission[key]) : null;
    // The server's figure is as of its message; it keeps growing until the next one.
    return age === null ? null : age + (performance.now() - receivedAt) / 1000;
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
    // the image centre: where the pad is when the camera is straight over it
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
      const level = seen === null || seen > TARGET_STALE_S ? COLORS.warn : COLORS.ok;
      g.strokeStyle = level;
      g.lineWidth = 2;
      g.beginPath();
      g.arc(ox + px[0] * scale, oy + px[1] * scale, 7, 0, 2 * Math.PI);
      g.stroke();
      g.lineWidth = 1;
    }
    const age = ageNow("target_age_s");
    const fill = ageBar.firstElementChild as HTMLElement;
    fill.style.width = `${Math.min(100, ((age ?? 0) / TARGET_LOST_S) * 100)}%`;
    ageBar.dataset.level = targetAgeLevel(age);
    setText(f.targetAge, age === null ? "—" : `${fmt(age, 2, "s")} (limits ${TARGET_STALE_S}/${TARGET_LOST_S} s)`);
    f.targetAge.dataset.level = targetAgeLevel(age);
    setText(f.seen, seen === null ? "—" : `${fmt(seen, 2, "s")} ago`);
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
    setText(state, `${kind}${strat} · ${String(m.state ?? "")}`);
    state.dataset.state = String(m.state ?? "");
    setText(message, String(m.message ?? ""));
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

  async function loadHistory(): Promise<void> {
    try {
      const runs = await api.request<RunSummary[]>("GET", "/api/missions");
      if (!Array.isArray(runs)) return;
      historyBody.replaceChildren(
        ...runs.slice(0, 20).map((r) => {
          const err = num(r.touchdown?.error_m);
          const head = num(r.touchdown?.heading_error_deg);
          return h(
            "tr",
            { "data-outcome": r.outcome ?? "running", title: r.message },
            h("td", {}, String(r.id)),
            h("td", {}, `${r.kind}${r.strategy ? ` (${r.strategy})` : ""}`),
            h("td", {}, r.outcome ?? "running"),
            h("td", {}, err === null ? "—" : fmt(err * 100, 1, "cm")),
            h("td", {}, head === null ? "—" : fmt(head, 1, "°")),
            h("td", {}, fmt(num(r.duration_s), 1, "s")),
          );
        }),
      );
    } catch {
      // missions not in this server (404) or it is down: the table stays as it was
    }
  }

  store.subscribe(["status"], () => {
    const m = store.status?.mission ?? null;
    mission = m && typeof m === "object" ? (m as Dict) : null;
    receivedAt = performance.now();
    render();
    // new run, new outcome, or its record just stored: the history has changed
    const key = mission ? `${String(mission.run_id)}:${String(mission.outcome)}:${String(mission.stored)}` : "";
    if (key !== lastOutcomeKey) {
      lastOutcomeKey = key;
      void loadHistory();
    }
  });
  // the ages keep moving between messages
  setInterval(draw, 250);
  render();
  void loadHistory();
}
