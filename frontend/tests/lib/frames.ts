// A frame message as the station sends it, for the tests that read one.
import type { FrameMessage } from "../../src/lib/protocol";

export type FramePose = NonNullable<FrameMessage["result"]["pose"]>;

/** Frame ``seq``, its pad found or not, with ``result``'s fields as given. */
export function frameMessage(
  seq: number,
  detected = true,
  result: Partial<FrameMessage["result"]> = {},
): FrameMessage {
  return {
    type: "frame",
    seq,
    t_capture: 1000 + seq,
    latency_ms: 12,
    width: 640,
    height: 480,
    result: {
      detected,
      corners_px: [],
      hu: [0.2, 0.01, 0, 0, 0, 0, 0],
      orientation_deg: 5,
      eccentricity: 1.2,
      pose: null,
      timings_ms: {},
      contour_px: [],
      found_by: detected ? "search" : "",
      score: 0.9,
      reason: "",
      ...result,
    },
    overlay: { reference_corners: [], axes: null, target: null },
    reference_distance: 0.01 * seq,
  };
}

/** A sure pose 3.456 m over the pad, looking straight down, with ``changes``. */
export function framePose(changes: Partial<FramePose> = {}): FramePose {
  return {
    position_m: [0.1, -0.2, 3.456],
    R_pad_cam: [
      [1, 0, 0],
      [0, -1, 0],
      [0, 0, -1],
    ],
    yaw_deg: 0,
    reprojection_px: 0.2,
    symmetric: true,
    ambiguous: false,
    lean_deg: null,
    lean_rotation: null,
    ...changes,
  };
}
