// The camera view's detection badge: what the latest frame found, said as it is. A pose
// made without the vehicle's attitude that the pixels do not pin is "ambiguous": the
// pad may be tilted the other way, or a look-alike; the missions do not use it.
import { fmt } from "./format";
import type { FrameMessage } from "./protocol";

export type BadgeState = "none" | "locked" | "ambiguous";

export interface Badge {
  text: string;
  state: BadgeState;
  title: string;
}

export function detectionBadge(frame: FrameMessage | null): Badge {
  if (!frame) return { text: "NO DATA", state: "none", title: "" };
  const result = frame.result;
  if (!result.detected) return { text: "NO H", state: "none", title: result.reason };
  const pose = result.pose;
  if (pose?.ambiguous) {
    return {
      text: "H FOUND · POSE AMBIGUOUS",
      state: "ambiguous",
      title:
        "Another pose fits the pixels as well, or they show the tilt too little to tell it: " +
        "no vehicle attitude came with this frame. Missions do not use such a pose.",
    };
  }
  return { text: `H LOCKED · ${fmt(pose?.position_m?.[2], 2, "m")}`, state: "locked", title: result.reason };
}
