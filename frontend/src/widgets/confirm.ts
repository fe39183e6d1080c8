// A button that acts only on a second click within a few seconds: arm, take-off,
// hover (which takes off) and landing all ask the operator to confirm.
import { h, setText } from "./dom";

export const CONFIRM_WINDOW_MS = 6000;

export function confirmButton(
  label: string,
  testid: string,
  cls: string,
  act: (button: HTMLButtonElement) => void,
): HTMLElement {
  const main = h("button", { class: `btn ${cls}`, "data-testid": testid, type: "button" }, label) as HTMLButtonElement;
  const cancel = h("button", { class: "btn btn-ghost", "data-testid": `${testid}-cancel`, type: "button", hidden: true }, "Cancel");
  let armedUntil = 0;
  let timer: ReturnType<typeof setTimeout> | null = null;
  const reset = () => {
    armedUntil = 0;
    if (timer) clearTimeout(timer);
    timer = null;
    setText(main, label);
    main.classList.remove("confirming");
    main.dataset.confirming = "false";
    cancel.hidden = true;
  };
  main.addEventListener("click", () => {
    if (Date.now() < armedUntil) {
      reset();
      act(main);
      return;
    }
    armedUntil = Date.now() + CONFIRM_WINDOW_MS;
    setText(main, `Confirm ${label.toLowerCase()}?`);
    main.classList.add("confirming");
    main.dataset.confirming = "true";
    cancel.hidden = false;
    timer = setTimeout(reset, CONFIRM_WINDOW_MS);
  });
  cancel.addEventListener("click", reset);
  return h("div", { class: "confirm-group" }, main, cancel);
}
