// Controls: mode, arm/disarm, take-off, hover over pad, land on pad, plus the
// always-visible ABORT (in the top bar). Arm, take-off and the landings need a
// second, explicit click; a refusal shows the vehicle's reasons verbatim.

import { type CommandOutcome, MISSIONS_UNAVAILABLE } from "../lib/api";
import { readTelemetry } from "../lib/telemetry";
import { confirmButton } from "./confirm";
import { type Ctx, h, panel, setText } from "./dom";

const MODES = ["GUIDED", "LOITER", "ALT_HOLD", "POSHOLD", "BRAKE", "STABILIZE", "LAND", "RTL"];

export interface Outcomes {
  show(title: string, outcome: CommandOutcome): void;
}

export function mountControls(root: HTMLElement, ctx: Ctx): Outcomes {
  const { api, store } = ctx;

  const outcomeTitle = h("div", { class: "outcome-title", "data-testid": "command-outcome" }, "No command sent yet");
  const outcomeReasons = h("ul", { class: "outcome-reasons", "data-testid": "command-reasons" });
  const outcomeBox = h("div", { class: "outcome", "aria-live": "polite" }, outcomeTitle, outcomeReasons);

  const outcomes: Outcomes = {
    show(title, outcome) {
      outcomeBox.dataset.ok = String(outcome.ok);
      outcomeBox.dataset.missing = String(outcome.message === MISSIONS_UNAVAILABLE);
      setText(outcomeTitle, `${title}: ${outcome.ok ? "accepted" : outcome.message}`);
      outcomeReasons.replaceChildren(...outcome.reasons.map((r) => h("li", {}, r)));
      store.addEvent("command", `${title}: ${outcome.ok ? "accepted" : outcome.message}`, {
        reasons: outcome.reasons,
      });
      if (outcome.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    },
  };

  async function run(title: string, button: HTMLButtonElement, action: () => Promise<CommandOutcome>): Promise<void> {
    button.disabled = true;
    button.classList.add("busy");
    setText(outcomeTitle, `${title}: sending…`);
    outcomeReasons.replaceChildren();
    delete outcomeBox.dataset.ok;
    try {
      outcomes.show(title, await action());
    } finally {
      button.disabled = false;
      button.classList.remove("busy");
    }
  }

  /** A button that needs a second click within a few seconds to act. */
  function confirmed(label: string, testid: string, cls: string, action: () => Promise<CommandOutcome>): HTMLElement {
    return confirmButton(label, testid, cls, (button) => void run(label, button, action));
  }

  function plain(label: string, testid: string, cls: string, action: () => Promise<CommandOutcome>): HTMLButtonElement {
    const b = h("button", { class: `btn ${cls}`, "data-testid": testid, type: "button" }, label);
    b.addEventListener("click", () => void run(label, b, action));
    return b;
  }

  const modeSelect = h("select", { class: "input", "data-testid": "mode-select", "aria-label": "Flight mode" });
  for (const m of MODES) modeSelect.append(h("option", { value: m }, m));
  const modeButton = plain("Set mode", "set-mode", "btn-secondary", () => api.setMode(modeSelect.value));

  const altInput = h("input", {
    class: "input input-num",
    type: "number",
    min: "0.5",
    max: "100",
    step: "0.5",
    value: "2",
    "data-testid": "takeoff-altitude",
    "aria-label": "Take-off altitude in metres",
  });

  const missionState = h("div", { class: "caption", "data-testid": "mission-state" }, "No mission");

  const section = panel(
    "Controls",
    "controls",
    h("div", { class: "control-row" }, h("label", { class: "stat-label" }, "Mode"), modeSelect, modeButton),
    h(
      "div",
      { class: "control-row" },
      confirmed("Arm", "arm", "btn-warn", () => api.vehicle("arm")),
      plain("Disarm", "disarm", "btn-secondary", () => api.vehicle("disarm")),
    ),
    h(
      "div",
      { class: "control-row" },
      h("label", { class: "stat-label" }, "Alt"),
      altInput,
      h("span", { class: "unit" }, "m"),
      confirmed("Take off", "takeoff", "btn-primary", () => api.takeoff(Number(altInput.value))),
    ),
    h("h3", { class: "sub-title" }, "Vision missions"),
    h(
      "div",
      { class: "control-row" },
      confirmed("Hover over pad", "hover", "btn-primary", () => api.mission("hover")),
      confirmed("Land on pad", "land-pad", "btn-primary", () => api.mission("land")),
    ),
    missionState,
    h("h3", { class: "sub-title" }, "Vehicle"),
    h(
      "div",
      { class: "control-row" },
      confirmed("Land", "land", "btn-secondary", () => api.vehicle("land")),
      plain("RTL", "rtl", "btn-secondary", () => api.vehicle("rtl")),
      confirmed("Force disarm", "force-disarm", "btn-danger-outline", () => api.vehicle("force-disarm")),
    ),
    outcomeBox,
  );
  root.append(section);

  store.subscribe(["status", "telemetry"], () => {
    const m = store.status?.mission;
    setText(missionState, m ? `Mission: ${describeMission(m)}` : "No mission running");
    const v = readTelemetry(store.telemetry);
    if (v.mode && document.activeElement !== modeSelect && !modeSelect.dataset.touched) {
      // follow the vehicle's mode until the operator picks one
      if (MODES.includes(v.mode)) modeSelect.value = v.mode;
    }
  });
  modeSelect.addEventListener("change", () => {
    modeSelect.dataset.touched = "1";
  });
  return outcomes;
}

function describeMission(m: Record<string, unknown>): string {
  const kind = m.kind ?? m.type ?? m.name ?? "mission";
  const state = m.state ?? m.phase ?? m.status ?? "";
  return `${String(kind)}${state ? ` · ${String(state)}` : ""}`;
}
