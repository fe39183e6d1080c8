// The one-step precision-landing set-up (PLND_* incl. PLND_LAG from the measured
// latency, then a reboot), confirmed first; shared by the landing and parameter panels.

import { ApiError, type PrecLandSetup } from "../lib/api";
import { fmt } from "../lib/format";
import { describeFailure } from "../lib/api";
import { confirmDialog } from "./confirm-dialog";
import type { Ctx } from "./dom";

/** PLND_LAG the server will write for a measured capture->result latency (ms). */
export function expectedLag(latencyMs: number | null | undefined): number {
  if (latencyMs === null || latencyMs === undefined || !Number.isFinite(latencyMs)) return 0.1;
  return Math.round(Math.min(0.25, Math.max(0.02, (latencyMs + 10) / 1000)) * 1000) / 1000;
}

/** Ask, then set up; resolves to one sentence for the operator (or null if cancelled). */
export async function setupPrecland(ctx: Ctx): Promise<{ ok: boolean; text: string } | null> {
  const latency = ctx.store.status?.pipeline.latency_ms ?? null;
  const lag = expectedLag(latency);
  const yes = await confirmDialog({
    title: "Set up precision landing?",
    lines: [
      "PLND_ENABLED = 1, PLND_TYPE = 1 (MAVLink: this station's LANDING_TARGET), PLND_EST_TYPE = 1 (Kalman filter), PLND_ORIENT = 25 (down).",
      `PLND_LAG = ${lag} s: the measured capture-to-result latency (${latency === null ? "none measured yet" : fmt(latency, 0, "ms")}) plus 10 ms to send.`,
      "PLND_CAM_POS_X/Y/Z = the camera's mount (0 m: centred under the vehicle).",
      "Then the autopilot reboots (PLND_TYPE is read at boot): the link drops for a few seconds. The vehicle must be disarmed.",
    ],
    confirmLabel: "Write and reboot",
  });
  if (!yes) return null;
  try {
    const r: PrecLandSetup = await ctx.store.whileRebooting(() => ctx.api.preclandSetup());
    return { ok: r.ok, text: r.detail };
  } catch (error) {
    if (!(error instanceof ApiError)) throw error;
    if (error.status === 401) document.dispatchEvent(new CustomEvent("visland:need-token"));
    const body = error.body as Partial<PrecLandSetup> | null;
    return { ok: false, text: typeof body?.detail === "string" && body.writes ? body.detail : describeFailure(error) };
  }
}
