// Vehicle parameters: download them all, search, edit one (checked against its type
// and documented range before anything is sent, then confirmed), reboot, and the
// one-step precision-landing set-up. Every write is recorded in the events.

import { ApiError, type CommandOutcome, describeFailure, type ParamInfo, type ParamListing } from "../lib/api";
import { fmtDate } from "../lib/format";
import { sentence } from "../lib/messages";
import { confirmDialog } from "./confirm-dialog";
import { type Ctx, h, panel, setText } from "./dom";
import { setupPrecland } from "./precland";

/** Why ``value`` cannot go into ``p`` (one sentence), or null: the server's rules. */
export function checkParam(p: ParamInfo, value: number): string | null {
  if (!Number.isFinite(value)) return `${p.name} needs a number.`;
  if (p.integer && !Number.isInteger(value)) return `${p.name} takes whole numbers; ${value} is not one.`;
  const choices = Object.keys(p.values);
  if (choices.length && !choices.includes(String(value))) {
    return `${p.name} takes one of ${choices.map((k) => `${k} (${p.values[k]})`).join(", ")}; ${value} is not one of them.`;
  }
  if (p.low !== null && p.high !== null && (value < p.low || value > p.high)) {
    return `${p.name} must be between ${p.low} and ${p.high}${p.units ? ` ${p.units}` : ""}; ${value} is outside.`;
  }
  return null;
}

function rangeText(p: ParamInfo): string {
  const choices = Object.entries(p.values);
  if (choices.length) return choices.map(([k, v]) => `${k}: ${v}`).join(", ");
  if (p.low !== null && p.high !== null) return `${p.low} … ${p.high}${p.units ? ` ${p.units}` : ""}`;
  return p.integer ? "whole number" : "";
}

export function mountParamsPanel(root: HTMLElement, ctx: Ctx): { load(): void } {
  const { api } = ctx;
  const search = h("input", { class: "input", type: "search", placeholder: "search name or description", "data-testid": "param-search", "aria-label": "Search parameters" });
  const refresh = h("button", { class: "btn btn-primary", type: "button", "data-testid": "param-refresh" }, "Download from the vehicle");
  const reboot = h("button", { class: "btn btn-warn", type: "button", "data-testid": "reboot" }, "Reboot autopilot");
  const precland = h("button", { class: "btn btn-secondary", type: "button", "data-testid": "param-precland" }, "Set up precision landing");
  const info = h("div", { class: "caption", "data-testid": "param-info" }, "No parameters read yet: download them from the vehicle.");
  const outcome = h("div", { class: "caption outcome-line", "data-testid": "param-outcome", "aria-live": "polite" });
  const body = h("tbody", { "data-testid": "param-rows" });
  const table = h(
    "div",
    { class: "table-scroll params-scroll" },
    h("table", { class: "data-table params-table" }, h("thead", {}, h("tr", {}, h("th", {}, "Name"), h("th", {}, "Value"), h("th", {}, "Range / choices"), h("th", {}, "Description"), h("th", {}, ""))), body),
  );
  root.append(panel("Vehicle parameters", "params", h("div", { class: "control-row wrap" }, search, refresh, precland, reboot), info, outcome, table));

  let listing: ParamListing | null = null;
  let downloading = false; // a listing read meanwhile is older than the download's
  const say = (ok: boolean, text: string) => {
    setText(outcome, text);
    outcome.dataset.ok = String(ok);
  };

  function row(p: ParamInfo): HTMLElement {
    const value = h("td", { class: "num", "data-testid": `param-value-${p.name}` }, formatValue(p));
    const edit = h("button", { class: "btn btn-small btn-ghost", type: "button", "data-testid": `param-edit-${p.name}` }, "Edit");
    const tr = h(
      "tr",
      { "data-param": p.name },
      h("td", { class: "param-name" }, p.name, p.reboot ? h("span", { class: "tag", title: "takes effect after a reboot" }, "reboot") : null),
      value,
      h("td", { class: "caption" }, rangeText(p)),
      h("td", { class: "caption" }, p.description),
      h("td", {}, edit),
    );
    edit.addEventListener("click", () => {
      const input = h("input", { class: "input input-num", type: "number", step: "any", value: String(p.value), "data-testid": `param-input-${p.name}`, "aria-label": `New value of ${p.name}` });
      const write = h("button", { class: "btn btn-small btn-primary", type: "button", "data-testid": `param-write-${p.name}` }, "Write");
      const cancel = h("button", { class: "btn btn-small btn-ghost", type: "button" }, "Cancel");
      value.replaceChildren(input, write, cancel);
      input.focus();
      cancel.addEventListener("click", () => value.replaceChildren(formatValue(p)));
      write.addEventListener("click", async () => {
        const v = Number(input.value);
        const problem = checkParam(p, v);
        if (problem) return say(false, problem);
        const lines = [`${p.name}: ${formatValue(p)} → ${v}${p.units ? ` ${p.units}` : ""}.`];
        if (p.values[String(v)]) lines.push(`${v} means: ${p.values[String(v)]}.`);
        if (p.reboot) lines.push("It takes effect after the autopilot reboots.");
        if (!(await confirmDialog({ title: `Write ${p.name}?`, lines, confirmLabel: "Write" }))) return;
        write.disabled = true;
        try {
          const r = await api.writeParam(p.name, v);
          p.value = r.value;
          value.replaceChildren(formatValue(p));
          say(true, sentence(`${p.name} is now ${r.value}`, p.reboot ? "reboot the autopilot for it to take effect" : ""));
        } catch (error) {
          if (!(error instanceof ApiError)) throw error;
          if (error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
          say(false, describeFailure(error));
          write.disabled = false;
        }
      });
    });
    return tr;
  }

  function render(): void {
    if (!listing) return;
    const q = search.value.trim().toLowerCase();
    const shown = listing.params.filter((p) => !q || p.name.toLowerCase().includes(q) || p.description.toLowerCase().includes(q));
    body.replaceChildren(...shown.slice(0, 400).map(row));
    setText(
      info,
      `${listing.received} of ${listing.count || "?"} parameters${listing.complete ? "" : " (not all read: download them)"}` +
        `${listing.fetched_at ? `, downloaded ${fmtDate(listing.fetched_at)}` : ""}; ${shown.length} shown${shown.length > 400 ? " (the first 400)" : ""}.`,
    );
  }

  async function load(): Promise<void> {
    try {
      const got = await api.params();
      if (downloading) return;
      listing = got;
      render();
    } catch (error) {
      setText(info, sentence("The parameters could not be listed", (error as Error).message));
    }
  }

  search.addEventListener("input", render);
  refresh.addEventListener("click", async () => {
    refresh.disabled = true;
    downloading = true;
    setText(info, "Downloading every parameter from the vehicle…");
    try {
      listing = await api.refreshParams();
      render();
    } catch (error) {
      if (error instanceof ApiError && error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
      say(false, error instanceof ApiError ? describeFailure(error) : String(error));
      downloading = false;
      void load();
    } finally {
      downloading = false;
      refresh.disabled = false;
    }
  });
  reboot.addEventListener("click", async () => {
    const yes = await confirmDialog({
      title: "Reboot the autopilot?",
      lines: ["The autopilot restarts: the link drops for a few seconds and comes back by itself.", "Refused while the vehicle is armed."],
      confirmLabel: "Reboot",
      danger: true,
    });
    if (!yes) return;
    const r: CommandOutcome = await ctx.store.whileRebooting(() => api.reboot());
    say(r.ok, r.ok ? "Reboot sent: the autopilot is restarting." : sentence("Reboot not done", r.message));
    if (r.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
  });
  precland.addEventListener("click", async () => {
    const r = await setupPrecland(ctx);
    if (r) {
      say(r.ok, r.text);
      void load();
    }
  });
  return { load: () => void load() };
}

function formatValue(p: ParamInfo): string {
  const v = p.integer ? String(Math.round(p.value)) : String(Number(p.value.toPrecision(6)));
  const meaning = p.values[String(Math.round(p.value))];
  return `${v}${p.units ? ` ${p.units}` : ""}${meaning ? ` (${meaning})` : ""}`;
}
