// The camera's mount, in the landing panel: the one in use, three inputs to change it
// (checked here, confirmed, then PUT /api/settings; not while a mission runs), and the
// mount check's suggestion while it holds, which fills the inputs on request.

import { ApiError, describeFailure } from "../lib/api";
import { sentence } from "../lib/messages";
import { asMount, describeMount, liveSuggestion, type Mount, parseMount, TILT_LIMIT_DEG, YAW_LIMIT_DEG } from "../lib/mount";
import { confirmDialog } from "./confirm-dialog";
import { type Ctx, h, setText } from "./dom";

export function mountCameraMountBox(root: HTMLElement, ctx: Ctx): void {
  const { store, api } = ctx;
  const current = h("div", { class: "mount-current", "data-testid": "mount-current" }, "In use: —");
  const input = (axis: string, limit: number) =>
    h("input", { class: "input input-num", type: "number", step: "any", min: -limit, max: limit, id: `mount-${axis}`, "data-testid": `mount-${axis}` });
  const inputs = [input("roll", TILT_LIMIT_DEG), input("pitch", TILT_LIMIT_DEG), input("yaw", YAW_LIMIT_DEG)] as const;
  const field = (name: string, el: HTMLInputElement) => h("label", { class: "mount-field", for: el.id }, h("span", { class: "mission-field-name" }, `${name} (°)`), el);
  const setButton = h("button", { class: "btn btn-secondary", type: "button", "data-testid": "mount-set" }, "Set mount");
  const suggestionText = h("span", { class: "mount-suggestion-text" });
  const useButton = h("button", { class: "btn btn-ghost btn-small", type: "button", "data-testid": "mount-use-suggestion" }, "Use suggestion");
  const suggestion = h("div", { class: "mount-suggestion", "data-testid": "mount-suggestion", hidden: true }, suggestionText, useButton);
  const busyNote = h("div", { class: "caption", "data-testid": "mount-running", hidden: true }, "A mission is running: the mount can be changed once it ends.");
  const outcome = h("div", { class: "caption outcome-line", "data-testid": "mount-outcome", "aria-live": "polite" }, "");
  root.append(
    h(
      "div",
      { class: "mission-box mount-box", "data-testid": "camera-mount" },
      h("h3", { class: "sub-title" }, "Camera mount"),
      current,
      h("div", { class: "caption" }, `How the camera is turned from looking straight down, its picture's top to the nose: roll and pitch within ±${TILT_LIMIT_DEG}°, yaw within ±${YAW_LIMIT_DEG}°.`),
      suggestion,
      h("div", { class: "mount-fields" }, field("Roll", inputs[0]), field("Pitch", inputs[1]), field("Yaw", inputs[2]), setButton),
      busyNote,
      outcome,
    ),
  );

  function say(ok: boolean, text: string): void {
    setText(outcome, text);
    outcome.dataset.ok = String(ok);
  }

  // The inputs follow the mount in use until the operator edits them.
  let edited = false;
  let sending = false;
  const fill = (m: Mount) => inputs.forEach((el, i) => (el.value = String(m[i])));
  for (const el of inputs) el.addEventListener("input", () => (edited = true));

  const missionRunning = () => {
    const m = store.status?.mission;
    return Boolean(m && !m.outcome);
  };

  function renderMount(): void {
    const m = asMount(store.settings.camera_mount_deg);
    setText(current, `In use: ${m ? describeMount(m) : "—"}`);
    if (m && !edited) fill(m);
  }

  let suggested: Mount | null = null;
  function renderSuggestion(): void {
    const s = liveSuggestion(store.events.toArray());
    suggested = s?.mount ?? null;
    suggestion.hidden = s === null;
    if (s) setText(suggestionText, `The pad's pixels lean ${s.leanDeg.toFixed(1)}° from the vehicle's level: they put the camera at about ${describeMount(s.mount)} (its yaw is not seen).`);
  }

  function renderRunning(): void {
    const running = missionRunning();
    busyNote.hidden = !running;
    setButton.disabled = running || sending;
  }

  useButton.addEventListener("click", () => {
    if (!suggested) return;
    fill(suggested);
    edited = true;
    say(true, "The suggestion is in the fields: check it, then Set mount.");
  });

  setButton.addEventListener("click", async () => {
    const parsed = parseMount([inputs[0].value, inputs[1].value, inputs[2].value]);
    if (!parsed.ok) return say(false, parsed.error);
    const before = asMount(store.settings.camera_mount_deg);
    const yes = await confirmDialog({
      title: "Set the camera mount?",
      lines: [
        `From ${before ? describeMount(before) : "the one set"} to ${describeMount(parsed.mount)}.`,
        "The vision's attitude hints (which hold each pose near the level the vehicle's attitude gives through the mount) use it from the next frame, and so do the next missions and the map's camera footprint.",
        "It is stored: it holds after the station restarts, unless --camera-mount is given then.",
        "Refused while a mission is running.",
      ],
      confirmLabel: "Set mount",
    });
    if (!yes) return;
    sending = true;
    renderRunning();
    setText(outcome, "Setting the camera mount…");
    delete outcome.dataset.ok;
    try {
      const settings = await api.setCameraMount(parsed.mount);
      edited = false;
      store.mergeSettings(settings);
      const now = asMount(settings.camera_mount_deg);
      say(true, `Camera mount set: ${describeMount(now ?? parsed.mount)}.`);
    } catch (error) {
      if (!(error instanceof ApiError)) throw error;
      if (error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
      // a refusal (a mission is running) is the station's own sentence, shown as it is
      say(false, error.status === 409 ? sentence(error.detail) : describeFailure(error));
    } finally {
      sending = false;
      renderRunning();
    }
  });

  store.subscribe("settings", renderMount);
  store.subscribe("event", renderSuggestion);
  store.subscribe("status", renderRunning);
  renderMount();
  renderSuggestion();
  renderRunning();
}
