// Reference panel: upload a helipad picture with its size, see what the pipeline
// extracted from it (threshold mask, numbered corners), its corners in metres and
// its invariants; pick an earlier reference again.

import { ApiError, describeFailure } from "../lib/api";
import { fmt, fmtDate, fmtSci, plural } from "../lib/format";
import type { ReferenceSummary } from "../lib/protocol";
import { confirmDialog } from "./confirm-dialog";
import { type Ctx, h, panel, setText } from "./dom";
import { mountPerspectiveEditor } from "./perspective-editor";

// A picture cropped to its pad's outer edge: the board's rim spans all of it (a disc's,
// with a hem beyond it, 0.97 of it).
const MIN_OUTLINE_SHARE = 0.95;
// A picture taken straight from above: its H's parallel sides stay so (a photo rectified by
// hand, within 0.5°); 5° off the vertical, close up, they converge by 2.4° and poses come
// 5 % off.
const MAX_SLANT_DEG = 1.5;

/** While a mission runs, switching the reference asks first and says what happens. */
export async function confirmReferenceSwitch(ctx: Ctx, what: string): Promise<boolean> {
  const m = ctx.store.status?.mission;
  if (!m || m.outcome) return true;
  return confirmDialog({
    title: `${what} during the ${m.kind} mission?`,
    warning: `A ${m.kind} mission is running (${m.state}).`,
    lines: [
      "From the next frame the vision looks for the new pad, not the one under the vehicle.",
      "If the vehicle is over the old pad, the mission loses it: it holds, climbs to search, and aborts if it cannot find the new one.",
      "ABORT (top right) stops the mission and holds the vehicle.",
    ],
    confirmLabel: `${what} anyway`,
    danger: true,
  });
}

export function mountReferencePanel(root: HTMLElement, ctx: Ctx): void {
  const { api, store } = ctx;
  const file = h("input", { type: "file", accept: "image/*", class: "input", "data-testid": "reference-file", "aria-label": "Reference picture" });
  const size = h("input", {
    type: "number",
    class: "input input-num",
    min: "0.01",
    max: "20",
    step: "0.01",
    value: "0.55",
    "data-testid": "reference-size",
    "aria-label": "Pad size in metres",
  });
  const upload = h("button", { class: "btn btn-primary btn-fixed", type: "button", "data-testid": "reference-upload" }, "Upload");
  const uploadState = h("div", { class: "caption", "data-testid": "reference-upload-state" });
  const form = h(
    "div",
    { class: "control-row wrap" },
    file,
    h("label", { class: "stat-label" }, "Pad size"),
    size,
    h("span", { class: "unit" }, "m"),
    upload,
  );

  const title = h("div", { class: "ref-title", "data-testid": "reference-name" }, "No active reference");
  const meta = h("div", { class: "caption", "data-testid": "reference-meta" });
  const verifierLine = h("div", { class: "caption verifier-line", "data-testid": "reference-verifier" });
  const outlineLine = h("div", { class: "caption caution-line", "data-testid": "reference-outline" });
  const slantLine = h("div", { class: "caption caution-line", "data-testid": "reference-slant" });
  const imgThreshold = h("img", { class: "ref-img", alt: "threshold mask of the reference", "data-testid": "reference-threshold" });
  const imgCorners = h("img", {
    class: "ref-img",
    alt: "the H's corners found on the reference, its other marks in cyan, smaller H's told apart in magenta",
    "data-testid": "reference-corners-img",
  });
  const images = h(
    "div",
    { class: "ref-images" },
    h("figure", {}, imgThreshold, h("figcaption", {}, "threshold")),
    h("figure", {}, imgCorners, h("figcaption", {}, "corners · other marks (cyan) · smaller H's (magenta)")),
  );
  const cornersBody = h("tbody", { "data-testid": "reference-corners" });
  const cornersTable = h(
    "table",
    { class: "data-table compact" },
    h("thead", {}, h("tr", {}, h("th", {}, "#"), h("th", {}, "x (m)"), h("th", {}, "y (m)"))),
    cornersBody,
  );
  const invBody = h("tbody", { "data-testid": "reference-invariants" });
  const invTable = h("table", { class: "data-table compact" }, invBody);
  const list = h("ul", { class: "ref-list", "data-testid": "reference-list" });

  const perspective = h("div", { class: "perspective" });
  root.append(
    panel(
      "Reference pad",
      "reference",
      h("h3", { class: "sub-title" }, "From a picture taken straight from above"),
      form,
      uploadState,
      h(
        "div",
        { class: "ref-layout" },
        h("div", { class: "ref-main" }, title, meta, outlineLine, slantLine, verifierLine, images),
        h("div", { class: "ref-tables" }, cornersTable, invTable),
      ),
      perspective,
      h("h3", { class: "sub-title" }, "Earlier references"),
      list,
    ),
  );
  mountPerspectiveEditor(perspective, ctx, () => confirmReferenceSwitch(ctx, "Activate the new reference"));
  document.addEventListener("visland:references-changed", () => void refreshList());

  let shownId: string | null = null;
  function show(ref: ReferenceSummary | null): void {
    showVerifier(ref);
    showOutline(ref);
    showSlant(ref);
    if (!ref) {
      setText(title, "No active reference");
      setText(meta, "");
      cornersBody.replaceChildren();
      invBody.replaceChildren();
      imgThreshold.removeAttribute("src");
      imgCorners.removeAttribute("src");
      shownId = null;
      return;
    }
    setText(title, `${ref.name} ${ref.active ? "· active" : ""}`);
    setText(
      meta,
      `pad ${fmt(ref.pad_size_m, 2, "m")} · ${ref.image_size?.[0] ?? "?"}×${ref.image_size?.[1] ?? "?"} px · ` +
        `${ref.corners_m.length} corners · ${ref.symmetric ? "symmetric (180° ambiguity resolved by heading)" : "asymmetric"} · ` +
        `${plural(ref.marks, "other mark")}` +
        (ref.letter_hs > 0 ? ` · ${plural(ref.letter_hs, "smaller H", "smaller H's")} told apart from the pad's` : "") +
        ` · added ${fmtDate(ref.created)}`,
    );
    const key = String(ref.id);
    if (key !== shownId) {
      shownId = key;
      imgThreshold.src = api.url(ref.images.threshold);
      imgCorners.src = api.url(ref.images.corners);
    }
    cornersBody.replaceChildren(
      ...ref.corners_m.map(([x, y], i) =>
        h("tr", {}, h("td", {}, String(i + 1)), h("td", { class: "num" }, fmt(x, 3)), h("td", { class: "num" }, fmt(y, 3))),
      ),
    );
    invBody.replaceChildren(
      ...ref.hu.map((v, i) => h("tr", {}, h("th", {}, `Hu ${i + 1}`), h("td", { class: "num" }, fmtSci(v)))),
      h("tr", {}, h("th", {}, "Orientation"), h("td", { class: "num" }, fmt(ref.orientation_deg, 1, "°"))),
      h("tr", {}, h("th", {}, "Eccentricity"), h("td", { class: "num" }, fmt(ref.eccentricity, 3))),
    );
  }

  function showOutline(ref: ReferenceSummary | null): void {
    const share = ref?.outline_share;
    if (!ref || share === null || share === undefined || share >= MIN_OUTLINE_SHARE) {
      setText(outlineLine, "");
      return;
    }
    const size = fmt(ref.pad_size_m, 2, "m");
    setText(
      outlineLine,
      `The pad's outer edge found on the picture spans ${Math.round(100 * share)} % of it, and ${size} is taken ` +
        `for the whole picture's width. If ${size} is that edge's width, every distance would come ` +
        `${Math.round(100 * (1 - share))} % short: crop the picture to the pad's edge, or mark its corners ` +
        'below ("From a photo taken at an angle").',
    );
  }

  function showSlant(ref: ReferenceSummary | null): void {
    const slant = ref?.slant_deg;
    if (!ref || slant === null || slant === undefined || slant <= MAX_SLANT_DEG) {
      setText(slantLine, "");
      return;
    }
    setText(
      slantLine,
      `The H's parallel sides converge by ${fmt(slant, 1, "°")} on the picture: it looks taken at a slant, ` +
        "not straight from above, and poses measured against it may come several % off. Take it straight " +
        'from above, or mark the pad\'s corners below ("From a photo taken at an angle").',
    );
  }

  function showVerifier(ref: ReferenceSummary | null): void {
    const v = ref?.verifier;
    verifierLine.dataset.state = v?.state ?? "none";
    if (!v) {
      setText(verifierLine, "");
      return;
    }
    const label: Record<string, string> = {
      off: "pattern verifier off",
      queued: "pattern verifier: waiting to train",
      training: `pattern verifier: training ${Math.round(100 * v.progress)} %`,
      ready: "pattern verifier: on",
      unavailable: "pattern verifier off for this pad",
      failed: "pattern verifier: training failed",
    };
    setText(verifierLine, `${label[v.state] ?? v.state}${v.detail ? ` · ${v.detail}` : ""}`);
  }

  async function refreshList(): Promise<void> {
    try {
      const refs = await api.references();
      list.replaceChildren(
        ...refs
          .slice()
          .reverse()
          .map((r) => {
            const activate = h("button", { class: "btn btn-small btn-secondary btn-fixed", type: "button", "data-testid": `activate-${r.id}` }, "Activate");
            activate.disabled = r.active;
            activate.addEventListener("click", async () => {
              if (!(await confirmReferenceSwitch(ctx, `Switch to '${r.name}'`))) return;
              activate.disabled = true;
              try {
                const s = await api.activateReference(r.id);
                store.setReference(s);
                setText(uploadState, `Reference '${s.name}' is active.`);
                uploadState.dataset.ok = "true";
              } catch (error) {
                setText(uploadState, error instanceof ApiError ? `Could not activate: ${describeFailure(error)}` : String(error));
                uploadState.dataset.ok = "false";
                if (error instanceof ApiError && error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
              }
              void refreshList();
            });
            return h(
              "li",
              { class: r.active ? "active" : "" },
              h("span", { class: "ref-list-name" }, r.name),
              h("span", { class: "caption" }, `${fmt(r.pad_size_m, 2, "m")} · ${fmtDate(r.created)}`),
              r.active ? h("span", { class: "tag" }, "active") : activate,
            );
          }),
      );
      if (refs.length === 0) list.append(h("li", { class: "empty" }, "None yet"));
    } catch (error) {
      list.replaceChildren(h("li", { class: "empty" }, `Cannot list references: ${(error as Error).message}`));
    }
  }

  upload.addEventListener("click", async () => {
    const f = file.files?.[0];
    if (!f) {
      setText(uploadState, "Choose a picture of the pad first.");
      uploadState.dataset.ok = "false";
      return;
    }
    if (!(await confirmReferenceSwitch(ctx, "Upload a new reference"))) return;
    upload.disabled = true;
    setText(uploadState, `Uploading ${f.name}…`);
    delete uploadState.dataset.ok;
    try {
      const s = await api.uploadReference(f, Number(size.value), f.name);
      store.setReference(s);
      setText(uploadState, `Reference '${s.name}' uploaded: ${s.corners_m.length} corners found.`);
      uploadState.dataset.ok = "true";
      void refreshList();
    } catch (error) {
      const e = error as ApiError;
      const why = e instanceof ApiError && e.status ? describeFailure(e) : `${e.message.replace(/[.\s]+$/, "")}.`;
      setText(uploadState, `Upload refused${e.status ? ` (${e.status})` : ""}: ${why.replace(/[.\s]+$/, "")}; the previous reference stays active.`);
      uploadState.dataset.ok = "false";
      if (e.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    } finally {
      upload.disabled = false;
    }
  });

  store.subscribe("reference", () => {
    show(store.reference);
    void refreshList();
  });
  show(store.reference);
  void refreshList();
}
