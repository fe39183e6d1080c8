// The one-step external-navigation set-up for the GPS-denied landing ("extnav"):
// VISO_TYPE 1, EKF source set 2 = vision, ARMING_CHECK without the vision check, then a
// reboot; confirmed first. The vehicle's state line reads VISO_TYPE and EK3_SRC2_POSXY.

import { ApiError, type ExtNavSetup } from "../lib/api";
import { describeFailure } from "../lib/api";
import { confirmDialog } from "./confirm-dialog";
import type { Ctx } from "./dom";

/** The landing panel's line for VISO_TYPE and EK3_SRC2_POSXY as the vehicle reports them. */
export function extnavLine(viso: number | null, posxy: number | null): { ready: boolean; text: string } {
  if (viso === null || posxy === null) return { ready: false, text: "GPS-denied landing on the vehicle: not read yet (the link is not up)." };
  const ready = viso === 1 && posxy === 6;
  return {
    ready,
    text: ready
      ? "GPS-denied landing is set up on the vehicle: VISO_TYPE 1 (MAVLink), EKF source set 2 = vision (ExternalNav)."
      : `GPS-denied landing is not set up on the vehicle (VISO_TYPE ${viso}, EK3_SRC2_POSXY ${posxy}): set it up before landing with the "extnav" strategy.`,
  };
}

/** Ask, then set up; resolves to one sentence for the operator (or null if cancelled). */
export async function setupExtnav(ctx: Ctx): Promise<{ ok: boolean; text: string } | null> {
  const yes = await confirmDialog({
    title: "Set up the GPS-denied landing?",
    lines: [
      "VISO_TYPE = 1 (MAVLink: this station's VISION_POSITION_ESTIMATE from the pad's pose).",
      "EKF source set 2: EK3_SRC2_POSXY = 6 and EK3_SRC2_VELXY = 6 (vision), EK3_SRC2_POSZ = 1 (baro), EK3_SRC2_YAW = 1 (compass). Set 1 stays GPS; the landing switches to set 2 over the pad.",
      "VISO_DELAY_MS = the measured capture-to-result latency plus 10 ms to send (ArduPilot takes the steady part of the delay for clock offset).",
      "ARMING_CHECK without the vision check: the pad is not in view on the ground, and with VISO_TYPE 1 ArduCopter refuses to arm without vision.",
      "If the pad is lost without GPS the landing comes down where it is (LAND), not on the pad.",
      "Then the autopilot reboots (VISO_TYPE is read at boot): the link drops for a few seconds. The vehicle must be disarmed.",
    ],
    confirmLabel: "Write and reboot",
  });
  if (!yes) return null;
  try {
    const r: ExtNavSetup = await ctx.store.whileRebooting(() => ctx.api.extnavSetup());
    return { ok: r.ok, text: r.detail };
  } catch (error) {
    if (!(error instanceof ApiError)) throw error;
    if (error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    const body = error.body as Partial<ExtNavSetup> | null;
    return { ok: false, text: typeof body?.detail === "string" && body.writes ? body.detail : describeFailure(error) };
  }
}
