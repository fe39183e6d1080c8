// The status strip: always in view on every screen (sticky), the vehicle's state at a
// glance and ABORT. Link, mode, armed, altitude, battery, GPS/EKF, readiness to arm in
// the current mode (from what the vehicle says), the mission and its state; under it
// the server/camera/vision pills, the tabs and the token live in the nav row.

import { batteryLevel } from "../lib/alerts";
import { fmt, fmtAge } from "../lib/format";
import { describeEkf, readiness } from "../lib/readiness";
import { gpsFixName, readTelemetry } from "../lib/telemetry";
import { type Ctx, h, setText } from "./dom";

export interface StripHandles {
  element: HTMLElement;
  /** Show what the last ABORT did. */
  showAbort(ok: boolean, text: string, sent: string[]): void;
}

/** Camera state in words: a camera that never sent a frame is waiting, not at fault. */
export function cameraText(cam: { state: string; fps: number; frames: number; errors: number } | undefined): { text: string; level: string } {
  if (!cam) return { text: "camera …", level: "" };
  if (cam.frames === 0 && cam.state !== "error") return { text: "camera waiting for its first frame", level: "" };
  if (cam.state === "streaming") return { text: `camera ${fmt(cam.fps, 0)} fps`, level: "ok" };
  return { text: `camera ${cam.state}`, level: cam.state === "error" || cam.errors > 0 ? "bad" : "warn" };
}

export function mountStatusStrip(root: HTMLElement, ctx: Ctx): StripHandles {
  const { store, api } = ctx;
  const cell = (testid: string, label: string) => {
    const value = h("span", { class: "strip-value", "data-testid": testid }, "—");
    return { value, el: h("div", { class: `strip-cell strip-${testid}` }, h("span", { class: "strip-label" }, label), value) };
  };
  const link = cell("strip-link", "Link");
  const mode = cell("strip-mode", "Mode");
  const armed = cell("strip-armed", "State");
  const alt = cell("strip-alt", "Alt");
  const battery = cell("strip-battery", "Battery");
  const nav = cell("strip-nav", "GPS · EKF");
  const ready = cell("strip-ready", "Arming");
  const mission = cell("strip-mission", "Mission");
  const abort = h(
    "button",
    { class: "btn btn-abort", type: "button", "data-testid": "abort", title: "Stop any Visland mission and hold the vehicle where it is" },
    "ABORT",
  );
  const abortOutcome = h("div", { class: "abort-outcome", "data-testid": "abort-outcome", hidden: true, role: "status" });
  const strip = h(
    "div",
    { class: "status-strip", "data-testid": "status-strip" },
    h("div", { class: "brand", title: "Visland ground control" }, h("span", { class: "brand-mark" }, "H")),
    h("div", { class: "strip-cells" }, link.el, mode.el, armed.el, alt.el, battery.el, nav.el, ready.el, mission.el),
    abort,
  );
  root.append(strip, abortOutcome);

  let abortTimer: ReturnType<typeof setTimeout> | null = null;
  const handles: StripHandles = {
    element: strip,
    showAbort(ok, text, sent) {
      abortOutcome.hidden = false;
      abortOutcome.dataset.ok = String(ok);
      abortOutcome.replaceChildren(
        h("strong", {}, "ABORT: "),
        text,
        sent.length ? h("span", { class: "abort-sent" }, ` Sent: ${sent.join("; ")}.`) : "",
        h("button", { class: "btn btn-ghost btn-small", type: "button", onclick: () => (abortOutcome.hidden = true) }, "Close"),
      );
      if (abortTimer) clearTimeout(abortTimer);
      abortTimer = setTimeout(() => (abortOutcome.hidden = true), 60000);
    },
  };

  abort.addEventListener("click", async () => {
    abort.classList.add("busy");
    try {
      const r = await api.abort();
      handles.showAbort(
        r.ok,
        r.message,
        r.sent.map((s) => `${s.command} (${s.ok ? (s.result_name === "SENT" ? "sent" : "accepted") : `refused: ${s.reasons.join("; ") || s.detail}`})`),
      );
      if (r.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    } finally {
      abort.classList.remove("busy");
    }
  });

  const render = () => {
    const v = readTelemetry(store.telemetry);
    const open = store.connection === "open";
    const linkState = !open ? "server" : store.telemetry ? v.linkState : (store.status?.link.state ?? "unknown");
    const rebooting = store.isRebooting() && linkState !== "up";
    setText(
      link.value,
      rebooting
        ? "REBOOTING"
        : linkState === "up"
          ? "UP"
          : linkState === "server"
            ? "NO SERVER"
            : `${linkState.toUpperCase()} ${linkState === "lost" ? fmtAge(store.heartbeatAgeS()) : ""}`.trim(),
    );
    link.el.dataset.level = linkState === "up" ? "ok" : rebooting || linkState === "connecting" ? "warn" : "bad";
    setText(mode.value, v.mode ?? "—");
    setText(armed.value, v.armed === null ? "—" : v.armed ? "ARMED" : "DISARMED");
    armed.el.dataset.level = v.armed ? "warn" : "";
    setText(alt.value, fmt(v.altitudeM, 1, "m"));
    const bl = batteryLevel({ batteryV: v.batteryV, batteryPct: v.batteryPct, mahUsed: null, thresholds: store.thresholds });
    setText(battery.value, v.batteryV === null ? "—" : `${fmt(v.batteryV, 1, "V")}${v.batteryPct === null ? "" : ` ${fmt(v.batteryPct, 0, "%")}`}`);
    battery.el.dataset.level = bl.level === "critical" ? "bad" : bl.level === "low" ? "warn" : bl.level === "ok" ? "ok" : "";
    battery.el.title = bl.why;
    const t = store.telemetry;
    const ekf = describeEkf(v.ekfHealthy, v.ekfFlags, t?.ekf?.pos_horiz_ok ?? null);
    setText(nav.value, `${v.gpsFix === null ? "—" : gpsFixName(v.gpsFix)} · ${ekf.text}`);
    nav.el.dataset.level = ekf.level;
    const r = readiness({
      mode: v.mode,
      armed: v.armed,
      prearmOk: v.prearmOk,
      ekfPosOk: t?.ekf?.pos_horiz_ok ?? null,
      statustexts: v.statustexts,
      now: Date.now() / 1000,
    });
    setText(ready.value, r.text);
    ready.el.dataset.level = r.ready === null ? "" : r.ready ? "ok" : "warn";
    const m = store.status?.mission;
    const running = m && !m.outcome;
    setText(mission.value, m ? `${m.kind}${m.strategy ? ` (${m.strategy})` : ""} · ${m.state}` : "none");
    mission.el.dataset.level = running ? "active" : m?.outcome === "landed" || m?.outcome === "completed" ? "ok" : m?.outcome ? "warn" : "";
  };
  store.subscribe(["connection", "telemetry", "status", "thresholds"], render);
  setInterval(render, 500); // ages keep counting when nothing arrives
  render();
  return handles;
}
