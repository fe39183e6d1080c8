// A reference from a photo of the pad lying on the ground, taken at an angle: the server
// suggests the pad's outline (a quadrilateral, or the square around a round pad), the
// operator drags the four outer corners onto the pad's corners (or clicks where one
// goes), previews the rectified picture and the H found on it, then activates it.

import { ApiError, describeFailure, type PerspectivePhoto, type PerspectivePreview } from "../lib/api";
import { sentence } from "../lib/messages";
import { type Ctx, h, setText } from "./dom";

type Pt = [number, number];
const LABELS = ["top-left", "top-right", "bottom-right", "bottom-left"];

export function mountPerspectiveEditor(
  root: HTMLElement,
  ctx: Ctx,
  confirmSwitch: () => Promise<boolean>,
): void {
  const { api, store } = ctx;
  const file = h("input", { type: "file", accept: "image/*", class: "input", "data-testid": "persp-file", "aria-label": "Photo of the pad in perspective" });
  const size = h("input", { type: "number", class: "input input-num", min: "0.01", max: "20", step: "0.01", value: "0.55", "data-testid": "persp-size", "aria-label": "Pad width in metres" });
  const find = h("button", { class: "btn btn-primary", type: "button", "data-testid": "persp-upload" }, "Find the pad");
  const state = h("div", { class: "caption outcome-line", "data-testid": "persp-state", "aria-live": "polite" });
  const guessQuad = h("button", { class: "btn btn-small btn-ghost", type: "button", "data-testid": "persp-guess-quad" }, "Use the quadrilateral");
  const guessEllipse = h("button", { class: "btn btn-small btn-ghost", type: "button", "data-testid": "persp-guess-ellipse" }, "Use the round pad's square");
  const canvas = h("canvas", { class: "persp-canvas", "data-testid": "persp-canvas" });
  const preview = h("button", { class: "btn btn-primary", type: "button", "data-testid": "persp-preview" }, "Preview");
  const activate = h("button", { class: "btn btn-warn", type: "button", "data-testid": "persp-activate", disabled: true }, "Activate this reference");
  const flat = h("img", { class: "ref-img", alt: "the rectified pad", "data-testid": "persp-rectified" });
  const flatCorners = h("img", { class: "ref-img", alt: "the H's corners on the rectified pad", "data-testid": "persp-rectified-corners" });
  const editor = h(
    "div",
    { class: "persp-editor", hidden: true, "data-testid": "persp-editor" },
    h("div", { class: "caption" }, "Drag each corner onto the pad's outer corner, in order: top-left, top-right, bottom-right, bottom-left (the pad's top becomes the reference's top). A click moves the nearest corner there."),
    h("div", { class: "control-row wrap" }, guessQuad, guessEllipse),
    canvas,
    h("div", { class: "control-row" }, preview, activate),
    h("div", { class: "ref-images" }, h("figure", {}, flat, h("figcaption", {}, "rectified")), h("figure", {}, flatCorners, h("figcaption", {}, "H found"))),
  );
  root.append(
    h("h3", { class: "sub-title" }, "From a photo taken at an angle"),
    h("div", { class: "control-row wrap" }, file, h("label", { class: "stat-label" }, "Pad width"), size, h("span", { class: "unit" }, "m"), find),
    state,
    editor,
  );

  let photo: PerspectivePhoto | null = null;
  let img: HTMLImageElement | null = null;
  let corners: Pt[] = [];
  let current: PerspectivePreview | null = null;
  let drag = -1;
  const say = (ok: boolean | null, text: string) => {
    setText(state, text);
    if (ok === null) delete state.dataset.ok;
    else state.dataset.ok = String(ok);
  };
  const failed = (what: string, error: unknown) => {
    if (error instanceof ApiError && error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    say(false, sentence(what, error instanceof ApiError ? describeFailure(error) : String(error), "the active reference is unchanged"));
  };

  function scale(): number {
    return photo ? canvas.width / photo.width : 1;
  }

  function draw(): void {
    const g = canvas.getContext("2d");
    if (!g || !img || !photo) return;
    const w = Math.min(900, canvas.parentElement?.clientWidth || 640);
    const hgt = Math.round((w * photo.height) / photo.width);
    if (canvas.width !== w) {
      canvas.width = w;
      canvas.height = hgt;
    }
    g.drawImage(img, 0, 0, canvas.width, canvas.height);
    const s = scale();
    g.lineWidth = 2;
    g.strokeStyle = "#38bdf8";
    g.beginPath();
    corners.forEach(([x, y], i) => (i ? g.lineTo(x * s, y * s) : g.moveTo(x * s, y * s)));
    g.closePath();
    g.stroke();
    corners.forEach(([x, y], i) => {
      g.fillStyle = i === drag ? "#f97316" : "#facc15";
      g.beginPath();
      g.arc(x * s, y * s, 7, 0, 2 * Math.PI);
      g.fill();
      g.fillStyle = "#000";
      g.font = "bold 10px sans-serif";
      g.fillText(String(i + 1), x * s - 3, y * s + 4);
      g.fillStyle = "#fff";
      g.font = "11px sans-serif";
      g.fillText(LABELS[i], x * s + 9, y * s - 8);
    });
    canvas.dataset.corners = JSON.stringify(corners.map(([x, y]) => [Math.round(x), Math.round(y)]));
  }

  function toPhoto(ev: PointerEvent): Pt {
    const r = canvas.getBoundingClientRect();
    const s = scale() * (r.width / canvas.width);
    return [(ev.clientX - r.left) / s, (ev.clientY - r.top) / s];
  }
  function nearest(p: Pt): number {
    let best = 0;
    corners.forEach(([x, y], i) => {
      if (Math.hypot(x - p[0], y - p[1]) < Math.hypot(corners[best][0] - p[0], corners[best][1] - p[1])) best = i;
    });
    return best;
  }
  canvas.addEventListener("pointerdown", (ev) => {
    if (!corners.length) return;
    const p = toPhoto(ev);
    drag = nearest(p);
    corners[drag] = p;
    canvas.setPointerCapture(ev.pointerId);
    invalidate();
    draw();
  });
  canvas.addEventListener("pointermove", (ev) => {
    if (drag < 0) return;
    corners[drag] = toPhoto(ev);
    draw();
  });
  canvas.addEventListener("pointerup", () => {
    drag = -1;
    draw();
  });

  function invalidate(): void {
    current = null;
    activate.disabled = true;
  }

  function use(points: Pt[] | null | undefined, what: string): void {
    if (!points) return say(false, `No ${what} was found on this photo: drag the corners by hand.`);
    corners = points.map(([x, y]) => [x, y] as Pt);
    invalidate();
    draw();
  }
  guessQuad.addEventListener("click", () => use(photo?.outline.quad as Pt[], "quadrilateral"));
  guessEllipse.addEventListener("click", () => use(photo?.outline.ellipse as Pt[] | null, "round pad"));

  find.addEventListener("click", async () => {
    const f = file.files?.[0];
    if (!f) return say(false, "Choose a photo of the pad first.");
    find.disabled = true;
    say(null, `Uploading ${f.name} and looking for the pad…`);
    try {
      photo = await api.uploadPerspective(f, f.name);
      const loaded = new Image();
      loaded.src = api.url(photo.photo);
      await loaded.decode();
      img = loaded;
      editor.hidden = false;
      const o = photo.outline;
      corners = ((o.kind === "ellipse" ? o.ellipse : o.quad) ?? o.quad).map(([x, y]) => [x, y] as Pt);
      invalidate();
      guessEllipse.disabled = !o.ellipse;
      draw();
      const found =
        o.kind === "quad"
          ? "the pad's outline was found (a quadrilateral)"
          : o.kind === "ellipse"
            ? "a round pad was found: the corners are those of the square around it"
            : o.h_box
              ? "an H was found but no outline around it: the corners are a guess around the H"
              : "no H was found: the corners are a guess";
      say(true, sentence(found, "check the four corners, then preview"));
    } catch (error) {
      failed("The photo was not taken", error);
    } finally {
      find.disabled = false;
    }
  });

  preview.addEventListener("click", async () => {
    if (!photo) return;
    const pad = Number(size.value);
    if (!Number.isFinite(pad) || pad <= 0 || pad > 20) return say(false, "The pad width must be a number of metres above 0 and at most 20.");
    preview.disabled = true;
    say(null, "Rectifying and measuring the H…");
    try {
      current = await api.previewPerspective(photo.id, corners, pad);
      flat.src = api.url(current.image);
      flatCorners.src = api.url(current.corners_image);
      activate.disabled = false;
      say(true, current.detail);
    } catch (error) {
      invalidate();
      failed("No preview", error);
    } finally {
      preview.disabled = false;
    }
  });

  activate.addEventListener("click", async () => {
    if (!photo || !current) return;
    if (!(await confirmSwitch())) return;
    activate.disabled = true;
    try {
      const s = await api.activatePerspective(photo.id, current.id);
      store.setReference(s);
      say(true, `Reference '${s.name}' is active: ${s.corners_m.length} corners.`);
      document.dispatchEvent(new CustomEvent("visland:references-changed"));
    } catch (error) {
      activate.disabled = false;
      failed("Not activated", error);
    }
  });
  window.addEventListener("resize", draw);
}
