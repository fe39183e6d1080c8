// The dashboard's state: one store fed by the WebSocket and the REST answers.
// Widgets subscribe to the topics they draw; the store keeps only the latest of
// everything, bounded rings for the plots and the message log.

import type {
  BinaryFrame,
  EventMessage,
  FrameMessage,
  ReferenceSummary,
  ServerMessage,
  Status,
  Telemetry,
} from "./protocol";
import type { BatteryThresholds } from "./alerts";
import { RateMeter, Ring } from "./ring";
import type { ConnectionState } from "./ws-client";

export type Topic =
  | "connection"
  | "status"
  | "telemetry"
  | "reference"
  | "frame"
  | "image"
  | "event"
  | "settings"
  | "thresholds";

export interface InvariantSample {
  seq: number;
  t: number;
  detected: boolean;
  hu: (number | null)[];
  distance: number | null;
  orientationDeg: number | null;
}

/** How long after a reboot is asked for a link loss is taken for it (ms). */
const REBOOT_GRACE_MS = 30000;

export interface StoreOptions {
  historySize?: number;
  eventsSize?: number;
  now?: () => number;
}

export class Store {
  connection: ConnectionState = "idle";
  status: Status | null = null;
  telemetry: Telemetry | null = null;
  /** Local time (ms) of the last telemetry, to show its age. */
  telemetryAt = 0;
  reference: ReferenceSummary | null = null;
  settings: Record<string, unknown> = {};
  frame: FrameMessage | null = null;
  cameraImage: BinaryFrame | null = null;
  thresholdImage: BinaryFrame | null = null;
  readonly events: Ring<EventMessage>;
  readonly history: Ring<InvariantSample>;
  readonly frameRate = new RateMeter();
  /** The vehicle's BATT_* thresholds (GET /api/params/battery), for the alerts. */
  thresholds: BatteryThresholds | null = null;
  /** Until when (``now()`` ms) a link loss is the reboot the operator asked for. */
  private rebootingUntil = 0;
  /** performance.now() when the first state from the server was applied (first paint). */
  firstStateAt: number | null = null;
  /** The last heartbeat age the server reported, and when it changed here (ms). */
  private heartbeatAge: number | null = null;
  private heartbeatAgeAt = 0;
  /** Frame messages by seq, to pair an image with its own overlay. */
  private readonly recentFrames = new Map<number, FrameMessage>();
  private readonly listeners = new Map<Topic, Set<() => void>>();
  private readonly now: () => number;

  constructor(options: StoreOptions = {}) {
    this.history = new Ring(options.historySize ?? 300);
    this.events = new Ring(options.eventsSize ?? 200);
    this.now = options.now ?? (() => Date.now());
  }

  subscribe(topics: Topic | Topic[], cb: () => void): () => void {
    const list = Array.isArray(topics) ? topics : [topics];
    for (const topic of list) {
      let set = this.listeners.get(topic);
      if (!set) {
        set = new Set();
        this.listeners.set(topic, set);
      }
      set.add(cb);
    }
    return () => {
      for (const topic of list) this.listeners.get(topic)?.delete(cb);
    };
  }

  setThresholds(thresholds: BatteryThresholds | null): void {
    this.thresholds = thresholds;
    this.emit("thresholds");
  }

  setConnection(state: ConnectionState): void {
    this.connection = state;
    this.emit("connection");
  }

  setReference(reference: ReferenceSummary | null): void {
    this.reference = reference;
    this.emit("reference");
  }

  setStatus(status: Status): void {
    this.status = status;
    this.emit("status");
    if (status.reference !== undefined && !sameReference(status.reference, this.reference)) {
      this.setReference(status.reference);
    }
  }

  setTelemetry(telemetry: Telemetry): void {
    this.telemetry = telemetry;
    this.telemetryAt = this.now();
    const age = telemetry.heartbeat_age_s;
    if (typeof age === "number" && Number.isFinite(age)) {
      if (age !== this.heartbeatAge) {
        this.heartbeatAge = age;
        this.heartbeatAgeAt = this.telemetryAt;
      }
    } else {
      this.heartbeatAge = null;
    }
    this.emit("telemetry");
  }

  /**
   * Seconds since the vehicle's last heartbeat, still growing when the server's
   * figure stops changing (a lost link) or the server itself goes silent.
   */
  heartbeatAgeS(): number | null {
    if (this.heartbeatAge === null) return null;
    return this.heartbeatAge + Math.max(0, this.now() - this.heartbeatAgeAt) / 1000;
  }

  /** Settings changed (a "settings" event's changes, or PUT /api/settings's answer). */
  mergeSettings(changes: Record<string, unknown>): void {
    this.settings = { ...this.settings, ...changes };
    this.emit("settings");
  }

  /** A local event (e.g. a command's outcome) shown in the same log as the server's. */
  addEvent(kind: string, text: string, extra: Record<string, unknown> = {}): void {
    this.events.push({ type: "event", kind, text, t: this.now() / 1000, local: true, ...extra });
    this.emit("event");
  }

  /** The frame message for image `seq`, or the latest if that one is gone. */
  frameFor(seq: number): FrameMessage | null {
    return this.recentFrames.get(seq) ?? null;
  }

  apply(msg: ServerMessage): void {
    switch (msg.type) {
      case "hello": {
        // a reconnecting page gets the whole current state at once, and what happened
        // before it (the events survive a reload: they are the server's)
        this.setStatus(msg.status);
        this.setTelemetry(msg.telemetry);
        this.setReference(msg.reference ?? null);
        this.settings = msg.settings ?? {};
        this.emit("settings");
        const seen = new Set(this.events.toArray().map((e) => `${e.t}|${e.kind}|${e.text}`));
        for (const e of msg.events ?? []) {
          if (!seen.has(`${e.t}|${e.kind}|${e.text}`)) this.events.push(e);
        }
        this.emit("event");
        if (this.firstStateAt === null) this.firstStateAt = typeof performance !== "undefined" ? performance.now() : 0;
        break;
      }
      case "telemetry": {
        const { type: _type, ...rest } = msg;
        this.setTelemetry(rest);
        break;
      }
      case "status": {
        const { type: _type, ...rest } = msg;
        this.setStatus(rest as Status);
        break;
      }
      case "frame":
        this.applyFrame(msg);
        break;
      case "event":
        this.events.push(msg);
        // every open page follows a change of settings, whoever made it
        if (msg.kind === "settings" && isRecord(msg.changes)) this.mergeSettings(msg.changes);
        this.emit("event");
        break;
      case "pong":
        break;
    }
  }

  applyImage(frame: BinaryFrame): void {
    if (frame.header.kind === "threshold") {
      this.thresholdImage = frame;
    } else {
      this.cameraImage = frame;
      this.frameRate.tick(this.now());
    }
    this.emit("image");
  }

  private applyFrame(msg: FrameMessage): void {
    this.frame = msg;
    this.recentFrames.set(msg.seq, msg);
    if (this.recentFrames.size > 16) {
      const oldest = this.recentFrames.keys().next().value;
      if (oldest !== undefined) this.recentFrames.delete(oldest);
    }
    const r = msg.result;
    this.history.push({
      seq: msg.seq,
      t: msg.t_capture,
      detected: Boolean(r.detected),
      hu: Array.isArray(r.hu) ? r.hu : [],
      distance: typeof msg.reference_distance === "number" ? msg.reference_distance : null,
      orientationDeg: typeof r.orientation_deg === "number" ? r.orientation_deg : null,
    });
    this.emit("frame");
  }

  /** Whether a link loss now is the reboot the operator asked for. */
  isRebooting(): boolean {
    return this.rebootingUntil > this.now();
  }

  /** Sends a command that reboots the autopilot: the link drops as soon as the
   * vehicle accepts it, before the answer comes, so the drop counts as the asked-for
   * reboot from the start, and no longer once the command failed or was refused. */
  async whileRebooting<T extends { ok: boolean }>(send: () => Promise<T>): Promise<T> {
    this.rebootingUntil = this.now() + REBOOT_GRACE_MS;
    try {
      const r = await send();
      if (!r.ok) this.rebootingUntil = 0;
      return r;
    } catch (error) {
      this.rebootingUntil = 0;
      throw error;
    }
  }

  private emit(topic: Topic): void {
    const set = this.listeners.get(topic);
    if (!set) return;
    for (const cb of set) {
      try {
        cb();
      } catch (error) {
        console.error(`listener for '${topic}' failed`, error);
      }
    }
  }
}

function isRecord(value: unknown): value is Record<string, unknown> {
  return typeof value === "object" && value !== null && !Array.isArray(value);
}

function sameReference(a: ReferenceSummary | null, b: ReferenceSummary | null): boolean {
  if (a === null || b === null) return a === b;
  return (
    a.id === b.id &&
    a.active === b.active &&
    a.verifier?.state === b.verifier?.state &&
    a.verifier?.progress === b.verifier?.progress
  );
}
