// A modal that says exactly what a command will do and waits for a deliberate yes.
// Used for everything that moves the vehicle or changes it: arm, take-off, the vision
// missions, parameter writes, reboots, switching the reference during a mission.

import { h } from "./dom";

export interface ConfirmOptions {
  title: string;
  /** One line each: what will happen, in order. */
  lines: string[];
  confirmLabel: string;
  /** A warning shown in the alarm colour (e.g. a mission is running). */
  warning?: string;
  danger?: boolean;
}

let open: HTMLDialogElement | null = null;

/** Resolves true when the operator confirms, false on cancel, Escape or a click outside. */
export function confirmDialog(options: ConfirmOptions): Promise<boolean> {
  open?.close("cancel");
  const yes = h("button", { class: `btn ${options.danger ? "btn-danger" : "btn-primary"}`, type: "button", "data-testid": "confirm-yes" }, options.confirmLabel);
  const no = h("button", { class: "btn btn-ghost", type: "button", "data-testid": "confirm-no" }, "Cancel");
  const dialog = h(
    "dialog",
    { class: "confirm-dialog", "data-testid": "confirm-dialog", "aria-labelledby": "confirm-title" },
    h("h2", { id: "confirm-title", class: "confirm-title" }, options.title),
    options.warning ? h("p", { class: "confirm-warning", "data-testid": "confirm-warning", role: "alert" }, options.warning) : null,
    h("ul", { class: "confirm-lines", "data-testid": "confirm-lines" }, ...options.lines.map((l) => h("li", {}, l))),
    h("div", { class: "confirm-buttons" }, no, yes),
  ) as HTMLDialogElement;
  document.body.append(dialog);
  open = dialog;
  return new Promise((resolve) => {
    dialog.addEventListener("close", () => {
      resolve(dialog.returnValue === "yes");
      dialog.remove();
      if (open === dialog) open = null;
    });
    yes.addEventListener("click", () => dialog.close("yes"));
    no.addEventListener("click", () => dialog.close("cancel"));
    dialog.addEventListener("click", (ev) => {
      if (ev.target === dialog) dialog.close("cancel");
    });
    dialog.showModal();
    no.focus(); // a stray Enter cancels
  });
}
