// Tiny DOM helpers shared by the widgets (no framework: elements are built once and
// their text/attributes updated in place).

import type { ApiClient } from "../lib/api";
import type { Store } from "../lib/store";
import type { TokenKeeper } from "../lib/token";
import type { WsClient } from "../lib/ws-client";

export interface Ctx {
  store: Store;
  api: ApiClient;
  ws: WsClient;
  tokens: TokenKeeper;
}

type Attr = string | number | boolean | null | undefined | ((ev: Event) => void);
type Child = Node | string | number | null | undefined | false;

export function h<K extends keyof HTMLElementTagNameMap>(
  tag: K,
  attrs: Record<string, Attr> = {},
  ...children: Child[]
): HTMLElementTagNameMap[K] {
  const el = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (value === null || value === undefined || value === false) continue;
    if (typeof value === "function") {
      el.addEventListener(key.replace(/^on/, "").toLowerCase(), value);
    } else if (key === "class") {
      el.className = String(value);
    } else if (value === true) {
      el.setAttribute(key, "");
    } else {
      el.setAttribute(key, String(value));
    }
  }
  append(el, ...children);
  return el;
}

export function append(el: Element, ...children: Child[]): void {
  for (const child of children) {
    if (child === null || child === undefined || child === false) continue;
    el.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
}

/** Set text only when it changed (cheap at 10 Hz, no layout thrash). */
export function setText(el: Element, text: string): void {
  if (el.textContent !== text) el.textContent = text;
}

/** A titled panel section. */
export function panel(title: string, testid: string, ...children: Child[]): HTMLElement {
  return h(
    "section",
    { class: `panel panel-${testid}`, "data-testid": testid },
    h("h2", { class: "panel-title" }, title),
    ...children,
  );
}

/** Coalesce calls into one per animation frame (render at screen rate, not message rate). */
export function rafThrottle(fn: () => void): () => void {
  let pending = false;
  return () => {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => {
      pending = false;
      try {
        fn();
      } catch (error) {
        console.error("render failed", error);
      }
    });
  };
}

/** A key/value row list: returns the value elements by key for later updates. */
export function fields(
  container: HTMLElement,
  rows: [key: string, label: string][],
): Record<string, HTMLElement> {
  const out: Record<string, HTMLElement> = {};
  const dl = h("dl", { class: "fields" });
  for (const [key, label] of rows) {
    const dd = h("dd", { "data-testid": `field-${key}` }, "—");
    dl.append(h("dt", {}, label), dd);
    out[key] = dd;
  }
  container.append(dl);
  return out;
}

/** Size a canvas's backing store to its CSS box (crisp on HiDPI); returns the context. */
export function fitCanvas(canvas: HTMLCanvasElement): CanvasRenderingContext2D | null {
  const ratio = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * ratio));
  const hgt = Math.max(1, Math.round(canvas.clientHeight * ratio));
  if (canvas.width !== w || canvas.height !== hgt) {
    canvas.width = w;
    canvas.height = hgt;
  }
  const ctx = canvas.getContext("2d");
  ctx?.setTransform(ratio, 0, 0, ratio, 0, 0);
  return ctx;
}

export const COLORS = {
  bg: "#0b0f14",
  grid: "#1f2a36",
  text: "#c9d4e0",
  muted: "#6b7a8c",
  accent: "#38bdf8",
  ok: "#22c55e",
  warn: "#f59e0b",
  bad: "#ef4444",
  contour: "#22d3ee",
  corners: "#facc15",
  reference: "#e879f9",
  axisX: "#ef4444",
  axisY: "#22c55e",
  axisZ: "#3b82f6",
  target: "#f97316",
  series: ["#38bdf8", "#a78bfa", "#f472b6", "#facc15", "#34d399", "#fb923c", "#94a3b8"],
};
