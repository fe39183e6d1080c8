// The page's tabs (Live, Parameters, Flights, Reference), the server/camera/vision
// pills and the operator token. The tab is kept in the address's hash, so a reload
// stays where it was.

import { fmt } from "../lib/format";
import { type Ctx, h, setText } from "./dom";
import { cameraText } from "./status-strip";

export const TABS = [
  ["live", "Live"],
  ["params", "Parameters"],
  ["flights", "Flights"],
  ["reference", "Reference pad"],
] as const;

export type TabId = (typeof TABS)[number][0];

export interface Nav {
  pages: Record<TabId, HTMLElement>;
  show(tab: TabId): void;
  onShow(cb: (tab: TabId) => void): void;
  current(): TabId;
}

export function mountNav(root: HTMLElement, main: HTMLElement, ctx: Ctx): Nav {
  const { store, tokens } = ctx;
  const pages = {} as Record<TabId, HTMLElement>;
  const buttons = {} as Record<TabId, HTMLButtonElement>;
  const listeners: ((tab: TabId) => void)[] = [];
  const tabs = h("nav", { class: "tabs", role: "tablist", "aria-label": "Pages" });
  for (const [id, label] of TABS) {
    const b = h("button", { class: "tab", type: "button", role: "tab", "data-testid": `tab-${id}` }, label);
    b.addEventListener("click", () => nav.show(id));
    buttons[id] = b;
    tabs.append(b);
    pages[id] = h("div", { class: `page page-${id}`, "data-testid": `page-${id}`, role: "tabpanel", hidden: true });
    main.append(pages[id]);
  }
  tabs.append(h("a", { class: "tab tab-link", href: "/docs", target: "_blank", rel: "noopener", "data-testid": "docs-link" }, "API docs ↗"));

  const server = h("span", { class: "pill", "data-testid": "server-state" }, "server …");
  const camera = h("span", { class: "pill", "data-testid": "camera-pill" }, "camera …");
  const vision = h("span", { class: "pill", "data-testid": "pipeline-pill" }, "vision …");
  const recording = h("span", { class: "pill pill-rec", "data-testid": "recording-pill", hidden: true }, "● REC");

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

  root.append(
    h(
      "div",
      { class: "navbar" },
      tabs,
      h("div", { class: "pills" }, server, camera, vision, recording),
      h("div", { class: "token-box" }, tokenInput, tokenSave, tokenState),
    ),
  );

  const render = () => {
    const open = store.connection === "open";
    setText(server, open ? "server connected" : `server ${store.connection}`);
    server.dataset.level = open ? "ok" : "bad";
    server.title = ctx.ws.stats.lastError || "";
    const cam = cameraText(store.status?.camera);
    setText(camera, cam.text);
    camera.dataset.level = cam.level;
    const p = store.status?.pipeline;
    const waiting = !p || p.processed === 0;
    setText(vision, waiting ? "vision waiting for frames" : `vision ${fmt(p.fps, 1)} fps · ${fmt(p.latency_ms, 0, "ms")}`);
    vision.dataset.level = waiting ? "" : p.fps ? "ok" : "warn";
    recording.hidden = !store.status?.flight;
  };
  store.subscribe(["connection", "status"], render);
  render();

  let current: TabId = "live";
  const nav: Nav = {
    pages,
    current: () => current,
    onShow(cb) {
      listeners.push(cb);
    },
    show(tab) {
      current = tab;
      for (const [id] of TABS) {
        pages[id].hidden = id !== tab;
        buttons[id].setAttribute("aria-selected", String(id === tab));
        buttons[id].classList.toggle("active", id === tab);
      }
      if (window.location.hash !== `#${tab}`) history.replaceState(null, "", `#${tab}`);
      for (const cb of listeners) cb(tab);
    },
  };
  return nav;
}

/** The tab named by the address's hash (a token fragment is not a tab). */
export function tabFromHash(hash: string): TabId {
  const id = hash.replace(/^#/, "");
  return (TABS.find(([t]) => t === id)?.[0] ?? "live") as TabId;
}
