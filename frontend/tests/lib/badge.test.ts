import { describe, expect, it } from "vitest";
import { detectionBadge } from "../../src/lib/badge";
import type { FrameMessage } from "../../src/lib/protocol";
import { type FramePose, frameMessage, framePose } from "./frames";

function frame(detected: boolean, pose: FramePose | null, reason = ""): FrameMessage {
  return frameMessage(1, detected, { pose, reason });
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
    const locked = detectionBadge(frame(true, framePose()));
    expect(locked.text).toBe("H LOCKED · 3.46 m");
    expect(locked.state).toBe("locked");
  });

  it("does not call an ambiguous pose locked, nor give its height", () => {
    const unsure = detectionBadge(frame(true, framePose({ ambiguous: true })));
    expect(unsure.text).toBe("H FOUND · POSE AMBIGUOUS");
    expect(unsure.state).toBe("ambiguous");
    expect(unsure.text).not.toContain("3.46");
    expect(unsure.title).toContain("no vehicle attitude");
  });
});
