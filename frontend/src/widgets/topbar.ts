// Top bar: the station's name, server/link/pipeline state at a glance, the operator
// token, and ABORT, which stays on screen whatever the page scrolls to. Under it, a
// full-width banner when the vehicle link or the server connection is lost.

import { fmt, fmtAge } from "../lib/format";
import { readTelemetry } from "../lib/telemetry";
import type { Outcomes } from "./controls";
import { type Ctx, h, setText } from "./dom";

export function mountTopbar(root: HTMLElement, ctx: Ctx, outcomes: () => Outcomes | null): void {
  const { store, api, tokens } = ctx;
  const server = h("span", { class: "pill", "data-testid": "server-state" }, "server …");
  const link = h("span", { class: "pill", "data-testid": "link-pill" }, "link …");
  const camera = h("span", { class: "pill", "data-testid": "camera-pill" }, "camera …");
  const pipeline = h("span", { class: "pill", "data-testid": "pipeline-pill" }, "vision …");
  const recording = h("span", { class: "pill", "data-testid": "recording-pill", hidden: true }, "● REC");

  const tokenInput = h("input", {
    class: "input token-input",
    type: "password",
    placeholder: "operator token",
    autocomplete: "off",
    "data-testid": "token-input",
    "aria-label": "Operator token",
  });
  const tokenState = h("span", { class: "token-state", "data-testid": "token-state" });
  const tokenSave = h("button", { class: "btn btn-ghost btn-small", type: "button", "data-testid": "token-save" }, "Save");
  const showTokenState = () => {
    const has = Boolean(tokens.get());
    const refused = tokens.isRefused;
    setText(tokenState, refused ? "token refused: enter it again" : has ? "token set" : "no token: view only");
    tokenState.dataset.ok = String(has && !refused);
  };
  tokenSave.addEventListener("click", () => {
    tokens.set(tokenInput.value);
    tokenInput.value = "";
    tokenInput.classList.remove("attention");
    showTokenState();
  });
  tokenInput.addEventListener("keydown", (ev) => {
    if (ev.key === "Enter") tokenSave.click();
  });
  document.addEventListener("visland:need-token", () => {
    showTokenState();
    tokenInput.classList.add("attention");
    tokenInput.focus();
  });
  showTokenState();

  const abort = h("button", { class: "btn btn-abort", type: "button", "data-testid": "abort", title: "Abort the running mission" }, "ABORT");
  abort.addEventListener("click", async () => {
    abort.disabled = true;
    try {
      const outcome = await api.mission("abort");
      outcomes()?.show("Abort", outcome);
    } finally {
      abort.disabled = false;
    }
  });

  const bar = h(
    "header",
    { class: "topbar" },
    h("div", { class: "brand" }, h("span", { class: "brand-mark" }, "H"), h("span", {}, "VISLAND"), h("span", { class: "brand-sub" }, "ground control")),
    h("div", { class: "pills" }, server, link, camera, pipeline, recording),
    h("div", { class: "token-box" }, tokenInput, tokenSave, tokenState),
    abort,
  );
  const banner = h("div", { class: "banner", "data-testid": "link-banner", hidden: true, role: "alert" });
  root.append(bar, banner);

  const render = () => {
    const open = store.connection === "open";
    setText(server, open ? "server connected" : `server ${store.connection}`);
    server.dataset.level = open ? "ok" : "bad";
    server.title = ctx.ws.stats.lastError || "";
    const v = readTelemetry(store.telemetry);
    const linkState = store.telemetry ? v.linkState : (store.status?.link.state ?? "unknown");
    setText(link, `link ${linkState}`);
    link.dataset.level = linkState === "up" ? "ok" : linkState === "connecting" ? "warn" : "bad";
    const cam = store.status?.camera;
    setText(camera, `camera ${cam?.state ?? "—"}${cam?.fps ? ` ${fmt(cam.fps, 0)} fps` : ""}`);
    camera.dataset.level = ["running", "up", "streaming"].includes(cam?.state ?? "") ? "ok" : cam?.errors ? "bad" : "warn";
    const p = store.status?.pipeline;
    setText(pipeline, `vision ${fmt(p?.fps, 1)} fps · ${fmt(p?.latency_ms, 0, "ms")}`);
    pipeline.dataset.level = p?.fps ? "ok" : "warn";
    recording.hidden = !store.status?.flight;

    let alarm = "";
    if (!open && store.connection !== "idle") {
      alarm = `SERVER CONNECTION LOST — reconnecting… Values shown are stale.`;
    } else if (linkState === "lost") {
      alarm = `VEHICLE LINK LOST — no heartbeat for ${fmtAge(store.heartbeatAgeS())}. Commands cannot reach the vehicle.`;
    } else if (linkState === "closed") {
      alarm = "VEHICLE LINK CLOSED";
    }
    banner.hidden = alarm === "";
    setText(banner, alarm);
    document.body.classList.toggle("link-alarm", alarm !== "");
  };
  store.subscribe(["connection", "telemetry", "status"], render);
  setInterval(render, 500); // the alarm's age keeps counting when nothing arrives
  render();
}
