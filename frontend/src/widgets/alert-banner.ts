// Alerts that cannot be missed: a banner under the status strip, one row per alert,
// a repeating tone while any is unacknowledged and still holds, and an Acknowledge
// button on each. An alert whose condition ended stays (marked) until acknowledged.

import { activeAlerts, type Alert, batteryLevel, endedAcks } from "../lib/alerts";
import { readTelemetry } from "../lib/telemetry";
import { type Ctx, h } from "./dom";

const ACK_KEY = "visland.acked-alerts";

interface Shown extends Alert {
  active: boolean;
}

export interface AlarmState {
  sounding: boolean;
  beeps: number;
  alerts: { id: string; title: string; active: boolean }[];
}

export function mountAlertBanner(root: HTMLElement, ctx: Ctx): AlarmState {
  const { store } = ctx;
  const banner = h("div", { class: "alerts", "data-testid": "alerts", role: "alert", "aria-live": "assertive", hidden: true });
  root.append(banner);
  const acked = new Set<string>(loadAcked());
  const shown = new Map<string, Shown>();
  const rows = new Map<string, HTMLElement>();
  const alarm: AlarmState = { sounding: false, beeps: 0, alerts: [] };
  let ekfWasHealthy = false;
  let wasOpen = false; // the first connection is not a lost one
  // A mission that had already ended when the page opened is history, not an alarm.
  let missionBaseline: string | null | undefined;
  let audio: AudioContext | null = null;

  function beep(critical: boolean): void {
    alarm.beeps += 1;
    try {
      audio ??= new AudioContext();
      if (audio.state === "suspended") void audio.resume();
      const osc = audio.createOscillator();
      const gain = audio.createGain();
      osc.frequency.value = critical ? 880 : 660;
      gain.gain.value = 0.15;
      osc.connect(gain).connect(audio.destination);
      osc.start();
      osc.stop(audio.currentTime + (critical ? 0.35 : 0.2));
    } catch {
      // no audio device: the banner still shows, and the count says it tried
    }
  }

  function render(): void {
    const v = readTelemetry(store.telemetry);
    if (v.linkState !== "up") ekfWasHealthy = false;
    else if (v.ekfHealthy) ekfWasHealthy = true;
    const rebooting = store.isRebooting();
    wasOpen = wasOpen || store.connection === "open";
    const m = store.status?.mission ?? null;
    const missionKey = m ? `${m.run_id}:${m.outcome}` : null;
    if (missionBaseline === undefined && store.status) missionBaseline = m?.outcome ? missionKey : null;
    const battery = { batteryV: v.batteryV, batteryPct: v.batteryPct, mahUsed: null, thresholds: store.thresholds };
    const now = activeAlerts({
      linkState: rebooting ? "up" : store.telemetry ? v.linkState : (store.status?.link.state ?? "unknown"),
      serverConnected: !wasOpen || store.connection === "open",
      armed: v.armed,
      ...battery,
      ekfHealthy: v.ekfHealthy,
      ekfWasHealthy,
      statustexts: v.statustexts,
      mission: missionKey !== null && missionKey === missionBaseline ? null : m,
      now: Date.now() / 1000,
    });
    const activeIds = new Set(now.map((a) => a.id));
    for (const a of now) if (!acked.has(a.id)) shown.set(a.id, { ...a, active: true });
    for (const [id, a] of shown) if (!activeIds.has(id)) a.active = false;
    for (const id of endedAcks([...acked], activeIds, batteryLevel(battery).level)) acked.delete(id);
    const list = [...shown.values()];
    banner.hidden = list.length === 0;
    alarm.alerts = list.map((a) => ({ id: a.id, title: a.title, active: a.active }));
    alarm.sounding = list.some((a) => a.active);
    banner.dataset.level = list.some((a) => a.active && a.level === "critical") ? "critical" : "warning";
    // Rows are kept and updated in place: a row rebuilt on every telemetry message
    // would take its Acknowledge button away from under the operator's click.
    for (const [id, row] of rows) if (!shown.has(id)) {
      row.remove();
      rows.delete(id);
    }
    list.forEach((a, i) => {
      const row = rows.get(a.id) ?? newRow(a.id);
      const cls = `alert alert-${a.level}`;
      if (row.className !== cls) row.className = cls;
      if (row.dataset.active !== String(a.active)) row.dataset.active = String(a.active);
      setText(row.querySelector(".alert-title"), a.title);
      setText(row.querySelector(".alert-detail"), a.active ? a.detail : `${a.detail} (cleared)`);
      if (banner.children[i] !== row) banner.insertBefore(row, banner.children[i] ?? null);
    });
  }

  function newRow(id: string): HTMLElement {
    const ack = h("button", { class: "btn btn-small alert-ack", type: "button", "data-testid": "alert-ack" }, "Acknowledge");
    ack.addEventListener("click", () => {
      acked.add(id);
      shown.delete(id);
      saveAcked(acked);
      render();
    });
    const row = h(
      "div",
      { "data-testid": "alert", "data-alert-id": id },
      h("strong", { class: "alert-title" }),
      h("span", { class: "alert-detail" }),
      ack,
    );
    rows.set(id, row);
    return row;
  }

  store.subscribe(["connection", "telemetry", "status", "thresholds"], render);
  setInterval(render, 1000);
  setInterval(() => {
    const active = [...shown.values()].filter((a) => a.active);
    if (active.length) beep(active.some((a) => a.level === "critical"));
  }, 2000);
  render();
  return alarm;
}

function setText(el: Element | null, text: string): void {
  if (el && el.textContent !== text) el.textContent = text;
}

function loadAcked(): string[] {
  try {
    return JSON.parse(sessionStorage.getItem(ACK_KEY) ?? "[]") as string[];
  } catch {
    return [];
  }
}

function saveAcked(ids: Set<string>): void {
  try {
    sessionStorage.setItem(ACK_KEY, JSON.stringify([...ids].slice(-100)));
  } catch {
    // storage off: acknowledgements hold for this page only
  }
}
