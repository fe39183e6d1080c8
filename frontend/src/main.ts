// The dashboard's entry: builds the page, wires the WebSocket and REST clients to the
// store, and mounts one widget per panel. Layout: the status strip (always in view,
// with ABORT) and the alerts, the tabs, then the pages: Live (camera and landing side
// by side, then the map, the 3D view, the vehicle and the analysis), Parameters,
// Flights (list and replay), Reference pad.

import "./styles.css";
import { ApiClient } from "./lib/api";
import { Store } from "./lib/store";
import { keepViewCookie } from "./lib/session";
import { TokenKeeper, withoutTokenInAddress } from "./lib/token";
import { CLOSE_AUTH_TIMEOUT, CLOSE_UNAUTHORIZED, WsClient, wsUrlFor } from "./lib/ws-client";
import { mountAlertBanner } from "./widgets/alert-banner";
import { mountCameraView } from "./widgets/camera-view";
import { mountControls } from "./widgets/controls";
import { mountCornerMap } from "./widgets/corner-map";
import type { Ctx } from "./widgets/dom";
import { h } from "./widgets/dom";
import { mountEventLog } from "./widgets/event-log";
import { mountFlightPanel } from "./widgets/flight-panel";
import { mountFlightsPanel } from "./widgets/flights-panel";
import { mountInvariants } from "./widgets/invariants";
import { mountLocalMap } from "./widgets/local-map";
import { mountMissionPanel } from "./widgets/mission-panel";
import { mountNav, tabFromHash } from "./widgets/nav";
import { mountParamsPanel } from "./widgets/params-panel";
import { mountReferencePanel } from "./widgets/reference-panel";
import { mountStatusStrip } from "./widgets/status-strip";
import { mountViserView } from "./widgets/viser-view";

function storage(): Storage | null {
  try {
    return window.localStorage;
  } catch {
    return null;
  }
}

function start(): void {
  const tokens = new TokenKeeper(storage());
  // A token left in the address (an old bookmark) is removed, never used.
  const cleaned = withoutTokenInAddress(window.location.href);
  if (cleaned) window.history.replaceState(null, "", cleaned);
  const store = new Store();
  const api = new ApiClient({ token: () => tokens.get() });
  const ws = new WsClient({ url: () => wsUrlFor(window.location), auth: () => tokens.usable() });
  keepViewCookie(tokens, api);
  ws.onState((s) => {
    store.setConnection(s);
    if (s !== "reconnecting") return;
    const code = ws.stats.lastCloseCode;
    if (code === CLOSE_UNAUTHORIZED) tokens.markRefused(); // offered no more until a new one
    if (code === CLOSE_UNAUTHORIZED || code === CLOSE_AUTH_TIMEOUT) {
      document.dispatchEvent(new CustomEvent("visland:need-token"));
    }
  });
  // a new token applies at once: reconnect so the socket authenticates with it
  tokens.onChange(() => ws.restart());
  ws.onMessage((m) => store.apply(m));
  ws.onBinary((f) => store.applyImage(f));
  const ctx: Ctx = { store, api, ws, tokens };

  const app = document.getElementById("app");
  if (!app) throw new Error("no #app element");
  // The strip and the alerts stay in view; the tabs scroll away with the page.
  const top = h("header", { class: "top" });
  const navRow = h("div", { class: "nav-row" });
  const main = h("main", { class: "pages" });
  app.append(top, navRow, main);
  const strip = mountStatusStrip(top, ctx);
  const alarm = mountAlertBanner(top, ctx);
  const nav = mountNav(navRow, main, ctx);

  // Live: camera and landing side by side; then the map, the 3D view, the vehicle.
  const live = nav.pages.live;
  const first = h("div", { class: "live-first" });
  const camCol = h("div", { class: "col-camera" });
  const landCol = h("div", { class: "col-landing" });
  first.append(camCol, landCol);
  const second = h("div", { class: "live-grid" });
  live.append(first, second);
  mountCameraView(camCol, ctx);
  mountMissionPanel(landCol, ctx);
  mountControls(landCol, ctx);
  mountLocalMap(second, ctx);
  const viser = mountViserView(second, ctx);
  mountFlightPanel(second, ctx);
  mountEventLog(second, ctx);
  const analysis = h("div", { class: "row-2" });
  second.append(analysis);
  mountCornerMap(analysis, ctx);
  mountInvariants(analysis, ctx);

  const params = mountParamsPanel(nav.pages.params, ctx);
  const flights = mountFlightsPanel(nav.pages.flights, ctx);
  mountReferencePanel(nav.pages.reference, ctx);
  nav.onShow((tab) => {
    if (tab === "live") viser.open();
    if (tab === "params") params.load();
    if (tab === "flights") flights.load();
  });
  nav.show(tabFromHash(window.location.hash));

  // The battery alerts' thresholds: read when the page starts, then now and then.
  const loadThresholds = () =>
    api
      .batteryThresholds()
      .then((t) => store.setThresholds(t))
      .catch(() => undefined);
  setInterval(loadThresholds, 10000);
  store.subscribe("connection", () => {
    if (store.connection === "open") void loadThresholds();
  });
  store.subscribe("event", () => {
    const last = store.events.length ? store.events.toArray()[store.events.length - 1] : null;
    if (last?.kind === "param" || last?.kind === "link_up") void loadThresholds();
  });

  ws.start();
  // for debugging from the console and for the end-to-end tests
  (window as unknown as { visland: unknown }).visland = { store, api, ws, alarm, strip, nav };
}

start();
