// The 3D view (viser, its own port) embedded, with a link to open it alone.

import { type Ctx, h, panel, setText } from "./dom";

export function mountViserView(root: HTMLElement, ctx: Ctx): void {
  const { store } = ctx;
  const frame = h("iframe", { class: "viser-frame", title: "3D view", "data-testid": "viser-frame", loading: "lazy" });
  const open = h("a", { class: "btn btn-small btn-ghost", target: "_blank", rel: "noopener", "data-testid": "viser-link" }, "Open alone ↗");
  const note = h("div", { class: "viser-note caption" }, "Waiting for the server to tell where the 3D view is…");
  const section = panel("3D view", "viser", h("div", { class: "viser-head" }, note, open), frame);
  root.append(section);
  let current: string | null = null;
  store.subscribe("status", () => {
    if (!store.status) return;
    const url = store.status.viser_url ?? "";
    if (url === current) return;
    current = url;
    if (!url) {
      frame.removeAttribute("src");
      open.removeAttribute("href");
      setText(note, "The 3D view is off on this server.");
      return;
    }
    frame.src = url;
    open.href = url;
    setText(note, `pad, vehicle, camera frustum, vision pose vs telemetry, trail · ${url}`);
  });
}
