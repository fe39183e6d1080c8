// Flight panel: the link state (loud when lost), mode, armed, altitude, attitude,
// battery, GPS/EKF and the vehicle's own messages (STATUSTEXT).

import { batteryLevel } from "../lib/alerts";
import { fmt, fmtAge, fmtClock } from "../lib/format";
import { describeEkf, readiness } from "../lib/readiness";
import { gpsFixName, readTelemetry, severityName } from "../lib/telemetry";
import { type Ctx, fields, fitCanvas, h, panel, rafThrottle, setText } from "./dom";
import { drawAttitude } from "./attitude";

export function mountFlightPanel(root: HTMLElement, ctx: Ctx): void {
  const { store } = ctx;
  const linkBadge = h("div", { class: "link-badge", "data-testid": "link-state" }, "CONNECTING");
  const linkDetail = h("div", { class: "link-detail", "data-testid": "heartbeat-age" }, "—");
  const mode = h("div", { class: "big-value", "data-testid": "mode" }, "—");
  const armed = h("div", { class: "armed-badge", "data-testid": "armed" }, "—");
  const altitude = h("div", { class: "big-value", "data-testid": "altitude" }, "—");
  const att = h("canvas", { class: "attitude-canvas", "data-testid": "attitude" });
  const attText = h("div", { class: "caption", "data-testid": "attitude-text" }, "—");
  const head = h(
    "div",
    { class: "flight-head" },
    h("div", { class: "link-box" }, linkBadge, linkDetail),
    h("div", { class: "kv" }, h("span", { class: "stat-label" }, "Mode"), mode),
    h("div", { class: "kv" }, h("span", { class: "stat-label" }, "State"), armed),
    h("div", { class: "kv" }, h("span", { class: "stat-label" }, "Altitude"), altitude),
  );
  const body = h("div", { class: "flight-body" });
  const left = h("div", { class: "attitude-box" }, att, attText);
  const right = h("div", { class: "flight-fields" });
  body.append(left, right);
  const f = fields(right, [
    ["climb", "Climb"],
    ["speed", "Ground speed"],
    ["battery", "Battery"],
    ["gps", "GPS"],
    ["ekf", "EKF"],
    ["prearm", "Arming"],
    ["rangefinder", "Rangefinder"],
    ["linkq", "Link"],
  ]);
  const messages = h("ol", { class: "messages", "data-testid": "vehicle-messages" });
  const section = panel(
    "Flight",
    "flight",
    head,
    body,
    h("h3", { class: "sub-title" }, "Vehicle messages"),
    messages,
  );
  root.append(section);

  let lastMessagesKey = "";
  const render = rafThrottle(() => {
    const v = readTelemetry(store.telemetry);
    const serverUp = store.connection === "open";
    const state = serverUp ? (store.telemetry ? v.linkState : (store.status?.link.state ?? "unknown")) : "server";
    const age = store.heartbeatAgeS();
    const label =
      state === "up" ? "LINK UP" : state === "lost" ? "LINK LOST" : state === "server" ? "NO SERVER" : state.toUpperCase();
    setText(linkBadge, label);
    linkBadge.dataset.state = state;
    section.classList.toggle("alarm", state === "lost" || state === "server" || state === "closed");
    setText(linkDetail, `heartbeat ${fmtAge(age)}`);
    setText(mode, v.mode ?? "—");
    setText(armed, v.armed === null ? "—" : v.armed ? "ARMED" : "DISARMED");
    armed.dataset.armed = String(v.armed);
    setText(altitude, fmt(v.altitudeM, 2, "m"));
    setText(f.climb, fmt(v.climbMps, 2, "m/s"));
    setText(f.speed, fmt(v.groundSpeedMps, 2, "m/s"));
    setText(
      f.battery,
      v.batteryV === null ? "—" : `${fmt(v.batteryV, 2, "V")} · ${fmt(v.batteryA, 1, "A")} · ${fmt(v.batteryPct, 0, "%")}`,
    );
    const bl = batteryLevel({ batteryV: v.batteryV, batteryPct: v.batteryPct, mahUsed: null, thresholds: store.thresholds });
    f.battery.dataset.level = bl.level === "critical" ? "bad" : bl.level === "low" ? "warn" : bl.level === "ok" ? "ok" : "";
    f.battery.title = bl.why;
    setText(f.gps, v.gpsFix === null ? "—" : `${gpsFixName(v.gpsFix)} · ${v.gpsSats ?? "—"} sats · hdop ${fmt(v.gpsHdop, 1)}`);
    f.gps.dataset.level = v.gpsFix === null ? "" : v.gpsFix >= 3 ? "ok" : "warn";
    const posOk = store.telemetry?.ekf?.pos_horiz_ok ?? null;
    const ekf = describeEkf(v.ekfHealthy, v.ekfFlags, posOk);
    setText(f.ekf, ekf.text);
    f.ekf.dataset.level = ekf.level;
    const r = readiness({ mode: v.mode, armed: v.armed, prearmOk: v.prearmOk, ekfPosOk: posOk, statustexts: v.statustexts, now: Date.now() / 1000 });
    setText(f.prearm, r.text);
    f.prearm.dataset.level = r.ready === null ? "" : r.ready ? "ok" : "warn";
    setText(f.rangefinder, fmt(v.rangefinderM, 2, "m"));
    setText(f.linkq, `${fmt(v.msgsPerS, 0, "msg/s")} · ${v.crcErrors ?? 0} bad`);
    setText(attText, `R ${fmt(v.rollDeg, 1)}°  P ${fmt(v.pitchDeg, 1)}°  Y ${fmt(v.yawDeg, 1)}°`);
    const g = fitCanvas(att);
    if (g) drawAttitude(g, Math.min(att.clientWidth, att.clientHeight), v.rollDeg, v.pitchDeg, v.headingDeg ?? v.yawDeg);

    const texts = v.statustexts;
    const key = texts.length ? `${texts.length}:${texts[texts.length - 1].t}:${texts[texts.length - 1].text}` : "";
    if (key !== lastMessagesKey) {
      lastMessagesKey = key;
      messages.replaceChildren(
        ...texts
          .slice(-30)
          .reverse()
          .map((m) =>
            h(
              "li",
              { class: `sev-${m.severity ?? 6}` },
              h("time", {}, fmtClock(m.t)),
              h("span", { class: "sev" }, severityName(m.severity)),
              h("span", { class: "msg-text" }, m.text),
            ),
          ),
      );
      if (texts.length === 0) messages.append(h("li", { class: "empty" }, "No messages yet"));
    }
  });

  store.subscribe(["telemetry", "status", "connection"], render);
  // keep the heartbeat age moving even when nothing arrives
  setInterval(render, 500);
  window.addEventListener("resize", render);
  render();
}
