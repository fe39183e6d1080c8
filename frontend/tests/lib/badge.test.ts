import { describe, expect, it } from "vitest";
import { detectionBadge } from "../../src/lib/badge";
import type { FrameMessage } from "../../src/lib/protocol";

type Pose = NonNullable<FrameMessage["result"]["pose"]>;

function frame(detected: boolean, pose: Partial<Pose> | null, reason = ""): FrameMessage {
  return {
    type: "frame",
    seq: 1,
    t_capture: 1000,
    latency_ms: 12,
    width: 640,
    height: 480,
    result: {
      detected,
      corners_px: [],
      hu: [0.2, 0.01, 0, 0, 0, 0, 0],
      orientation_deg: 5,
      eccentricity: 1.2,
      pose:
        pose === null
          ? null
          : {
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
              ...pose,
            },
      timings_ms: {},
      contour_px: [],
      found_by: detected ? "search" : "",
      score: 0.9,
      reason,
    },
    overlay: { reference_corners: [], axes: null, target: null },
    reference_distance: 0.01,
  };
}

describe("detection badge", () => {
  it("says no data before a frame and no H when none was found, with the reason", () => {
    expect(detectionBadge(null)).toEqual({ text: "NO DATA", state: "none", title: "" });
    const none = detectionBadge(frame(false, null, "no H-shaped candidate"));
    expect(none.text).toBe("NO H");
    expect(none.state).toBe("none");
    expect(none.title).toBe("no H-shaped candidate");
  });

  it("locks with the height when the pose is sure", () => {
    const locked = detectionBadge(frame(true, {}));
    expect(locked.text).toBe("H LOCKED · 3.46 m");
    expect(locked.state).toBe("locked");
  });

  it("does not call an ambiguous pose locked, nor give its height", () => {
    const unsure = detectionBadge(frame(true, { ambiguous: true }));
    expect(unsure.text).toBe("H FOUND · POSE AMBIGUOUS");
    expect(unsure.state).toBe("ambiguous");
    expect(unsure.text).not.toContain("3.46");
    expect(unsure.title).toContain("no vehicle attitude");
  });
});
