// The dashboard's entry: builds the page, wires the WebSocket and REST clients to
// the store, and mounts one widget per panel.

import "./styles.css";
import { ApiClient } from "./lib/api";
import { Store } from "./lib/store";
import { keepViewCookie } from "./lib/session";
import { TokenKeeper, withoutTokenInAddress } from "./lib/token";
import { CLOSE_AUTH_TIMEOUT, CLOSE_UNAUTHORIZED, WsClient, wsUrlFor } from "./lib/ws-client";
import { mountCameraView } from "./widgets/camera-view";
import { type Outcomes, mountControls } from "./widgets/controls";
import { mountCornerMap } from "./widgets/corner-map";
import type { Ctx } from "./widgets/dom";
import { h } from "./widgets/dom";
import { mountEventLog } from "./widgets/event-log";
import { mountFlightPanel } from "./widgets/flight-panel";
import { mountInvariants } from "./widgets/invariants";
import { mountMissionPanel } from "./widgets/mission-panel";
import { mountReferencePanel } from "./widgets/reference-panel";
import { mountTopbar } from "./widgets/topbar";
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
  let outcomes: Outcomes | null = null;
  mountTopbar(app, ctx, () => outcomes);
  const layout = h("main", { class: "layout" });
  const left = h("div", { class: "col-main" });
  const right = h("div", { class: "col-side" });
  layout.append(left, right);
  app.append(layout);

  mountCameraView(left, ctx);
  const analysis = h("div", { class: "row-2" });
  left.append(analysis);
  mountCornerMap(analysis, ctx);
  mountInvariants(analysis, ctx);
  mountReferencePanel(left, ctx);

  mountFlightPanel(right, ctx);
  outcomes = mountControls(right, ctx);
  mountMissionPanel(right, ctx);
  mountViserView(right, ctx);
  mountEventLog(right, ctx);

  ws.start();
  // for debugging from the console and for the end-to-end tests
  (window as unknown as { visland: unknown }).visland = { store, api, ws };
}

start();
