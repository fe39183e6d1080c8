// Vehicle controls: mode, arm/disarm, take-off, land here, RTL, force disarm. Arm,
// take-off, land and force disarm ask first in a dialog that says what will happen;
// a refusal shows the vehicle's reasons verbatim. The vision missions (hover over
// the pad, land on it) are in the landing panel, with their parameters.

import type { CommandOutcome } from "../lib/api";
import { sentence } from "../lib/messages";
import { readTelemetry } from "../lib/telemetry";
import { confirmDialog } from "./confirm-dialog";
import { type Ctx, h, panel, setText } from "./dom";

const MODES = ["GUIDED", "LOITER", "ALT_HOLD", "POSHOLD", "BRAKE", "STABILIZE", "LAND", "RTL"];

export interface Outcomes {
  show(title: string, outcome: CommandOutcome): void;
}

export function mountControls(root: HTMLElement, ctx: Ctx): Outcomes {
  const { api, store } = ctx;

  const outcomeTitle = h("div", { class: "outcome-title", "data-testid": "command-outcome" }, "No command sent yet.");
  const outcomeReasons = h("ul", { class: "outcome-reasons", "data-testid": "command-reasons" });
  const outcomeBox = h("div", { class: "outcome", "aria-live": "polite" }, outcomeTitle, outcomeReasons);

  const outcomes: Outcomes = {
    show(title, outcome) {
      outcomeBox.dataset.ok = String(outcome.ok);
      setText(outcomeTitle, sentence(title, outcome.ok ? "accepted" : outcome.message));
      outcomeReasons.replaceChildren(...outcome.reasons.map((r) => h("li", {}, r)));
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

  function button(label: string, testid: string, cls: string, action: () => Promise<CommandOutcome>, ask?: () => Parameters<typeof confirmDialog>[0]): HTMLButtonElement {
    const b = h("button", { class: `btn ${cls}`, "data-testid": testid, type: "button" }, label);
    b.addEventListener("click", async () => {
      if (ask && !(await confirmDialog(ask()))) return;
      await run(label, b, action);
    });
    return b;
  }

  const modeSelect = h("select", { class: "input", "data-testid": "mode-select", "aria-label": "Flight mode" });
  for (const m of MODES) modeSelect.append(h("option", { value: m }, m));
  const modeButton = button("Set mode", "set-mode", "btn-secondary", () => api.setMode(modeSelect.value));

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
  const mode = () => readTelemetry(store.telemetry).mode ?? "its current mode";

  const section = panel(
    "Vehicle controls",
    "controls",
    h("div", { class: "control-row" }, h("label", { class: "stat-label" }, "Mode"), modeSelect, modeButton),
    h(
      "div",
      { class: "control-row" },
      button("Arm", "arm", "btn-warn", () => api.vehicle("arm"), () => ({
        title: "Arm the motors?",
        lines: [`Arms in ${mode()}: the propellers start to spin.`, "ArduCopter disarms again by itself if it does not take off within a few seconds."],
        confirmLabel: "Arm",
      })),
      button("Disarm", "disarm", "btn-secondary", () => api.vehicle("disarm")),
    ),
    h(
      "div",
      { class: "control-row" },
      h("label", { class: "stat-label" }, "Alt"),
      altInput,
      h("span", { class: "unit" }, "m"),
      button("Take off", "takeoff", "btn-primary", () => api.takeoff(Number(altInput.value)), () => ({
        title: `Take off to ${Number(altInput.value)} m?`,
        lines: [`Climbs to ${Number(altInput.value)} m above home (GUIDED and armed only).`],
        confirmLabel: "Take off",
      })),
    ),
    h(
      "div",
      { class: "control-row" },
      button("Land here", "land", "btn-secondary", () => api.vehicle("land"), () => ({
        title: "Land where the vehicle is?",
        lines: ["Switches to LAND: descends straight down here, without vision, and disarms."],
        confirmLabel: "Land here",
      })),
      button("RTL", "rtl", "btn-secondary", () => api.vehicle("rtl")),
      button("Force disarm", "force-disarm", "btn-danger-outline", () => api.vehicle("force-disarm"), () => ({
        title: "Force disarm?",
        lines: ["The motors stop at once, even in flight: the vehicle falls."],
        confirmLabel: "Force disarm",
        danger: true,
      })),
    ),
    outcomeBox,
  );
  root.append(section);

  store.subscribe(["telemetry"], () => {
    const v = readTelemetry(store.telemetry);
    if (v.mode && document.activeElement !== modeSelect && !modeSelect.dataset.touched && MODES.includes(v.mode)) {
      modeSelect.value = v.mode; // follow the vehicle's mode until the operator picks one
    }
  });
  modeSelect.addEventListener("change", () => {
    modeSelect.dataset.touched = "1";
  });
  return outcomes;
}
