// Event log: the server's events (link up/lost, commands, missions, references,
// flights) and this page's own command outcomes, newest first.

import { fmtClock } from "../lib/format";
import { type Ctx, h, panel, rafThrottle } from "./dom";

export function mountEventLog(root: HTMLElement, ctx: Ctx): void {
  const { store } = ctx;
  const list = h("ol", { class: "events", "data-testid": "event-log" });
  root.append(panel("Events", "events", list));
  const render = rafThrottle(() => {
    const events = store.events.toArray().slice(-60).reverse();
    list.replaceChildren(
      ...events.map((e) =>
        h(
          "li",
          { class: `ev ev-${e.kind}` },
          h("time", {}, fmtClock(e.t)),
          h("span", { class: "ev-kind" }, e.kind.replaceAll("_", " ")),
          h("span", { class: "msg-text" }, e.text),
        ),
      ),
    );
    if (events.length === 0) list.append(h("li", { class: "empty" }, "No events yet"));
  });
  store.subscribe("event", render);
  render();
}
