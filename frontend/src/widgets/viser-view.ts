// The 3D view (viser, its own port) embedded large, with a legend for what it shows,
// and a link to open it alone.

import { type Ctx, h, panel, setText } from "./dom";

export function mountViserView(root: HTMLElement, ctx: Ctx): { open(): void } {
  const { store } = ctx;
  const frame = h("iframe", { class: "viser-frame", title: "3D view", "data-testid": "viser-frame" });
  const open = h("a", { class: "btn btn-small btn-ghost", target: "_blank", rel: "noopener", "data-testid": "viser-link" }, "Open alone ↗");
  const note = h("div", { class: "viser-note caption" }, "Waiting for the server to tell where the 3D view is…");
  const legend = h(
    "ul",
    { class: "legend viser-legend", "data-testid": "viser-legend" },
    h("li", {}, h("span", { class: "swatch", style: "background:#2878ff" }), "blue frustum: the camera where the telemetry puts it"),
    h("li", {}, h("span", { class: "swatch", style: "background:#ff8c00" }), "orange frustum: the camera where the vision puts it (on the blue one when both agree)"),
    h("li", {}, h("span", { class: "swatch", style: "background:#ef4444" }), "axes: the vehicle (red forward, green right, blue down)"),
    h("li", {}, h("span", { class: "swatch", style: "background:#50c8ff" }), "dots: its trail; the picture on the ground: the pad"),
  );
  const section = panel("3D view", "viser", h("div", { class: "viser-head" }, note, open), frame, legend);
  root.append(section);
  let current: string | null = null;
  let wanted = false;
  const apply = () => {
    const url = store.status?.viser_url ?? "";
    if (!url) {
      frame.removeAttribute("src");
      open.removeAttribute("href");
      setText(note, store.status ? "The 3D view is off on this server." : note.textContent ?? "");
      return;
    }
    open.href = url;
    setText(note, url);
    if (wanted && url !== current) {
      current = url;
      frame.src = url;
    }
  };
  store.subscribe("status", apply);
  return {
    open() {
      wanted = true;
      apply();
    },
  };
}
