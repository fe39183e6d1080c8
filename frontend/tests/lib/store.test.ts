import { describe, expect, it } from "vitest";
import { encodeBinaryFrame, type ServerMessage, type Status } from "../../src/lib/protocol";
import { Store } from "../../src/lib/store";
import { frameMessage } from "./frames";

// Fixtures carry only what a test reads: typed as wire data the store accepts as is.
// eslint-disable-next-line @typescript-eslint/no-explicit-any
const wire = (x: unknown): any => x;

const STATUS: Status = wire({
  link: { state: "up", url: "tcp:127.0.0.1:5760", heartbeat_age_s: 0.2 },
  camera: { name: "sim", state: "running" },
  pipeline: { fps: 20 },
  mission: null,
  reference: null,
  flight: null,
  viser_url: "http://127.0.0.1:8080",
});

const REF = {
  id: 1,
  name: "pad",
  pad_size_m: 0.55,
  created: "2026-11-22T11:00:00Z",
  active: true,
  corners_m: [] as [number, number][],
  hu: [0.2, 0.01, 0, 0, 0, 0, 0],
  orientation_deg: 0,
  eccentricity: 1.1,
  symmetric: true,
  image_size: [640, 480] as [number, number],
  images: { original: "/o", threshold: "/t", corners: "/c" },
};

describe("Store", () => {
  it("takes the whole state from hello and tells each topic", () => {
    let clock = 5000;
    const store = new Store({ now: () => clock });
    const heard: string[] = [];
    store.subscribe(["status", "telemetry", "reference", "settings"], () => heard.push("x"));
    store.subscribe("telemetry", () => heard.push("telemetry"));
    const hello: ServerMessage = wire({
      type: "hello",
      status: { ...STATUS, reference: REF },
      telemetry: { armed: false, mode: "STABILIZE" },
      reference: REF,
      settings: { record_frames: true },
    });
    store.apply(hello);
    expect(store.status?.link.state).toBe("up");
    expect(store.telemetry).toEqual({ armed: false, mode: "STABILIZE" });
    expect(store.telemetryAt).toBe(5000);
    expect(store.reference?.id).toBe(1);
    expect(store.settings).toEqual({ record_frames: true });
    expect(heard).toContain("telemetry");
    clock = 6000;
    store.apply(wire({ type: "telemetry", armed: true }));
    expect(store.telemetry).toEqual({ armed: true });
    expect(store.telemetryAt).toBe(6000);
  });

  it("merges a settings event's changes into the settings and tells every page", () => {
    const store = new Store();
    store.apply(wire({ type: "hello", status: STATUS, telemetry: {}, reference: null, settings: { record_frames: true, camera_mount_deg: [0, 0, 0] } }));
    let heard = 0;
    store.subscribe("settings", () => (heard += 1));
    store.apply(wire({ type: "event", kind: "settings", text: "settings changed", t: 1, changes: { camera_mount_deg: [0.1, 8, 0] } }));
    expect(store.settings).toEqual({ record_frames: true, camera_mount_deg: [0.1, 8, 0] });
    expect(heard).toBe(1);
    expect(store.events.last()?.kind).toBe("settings");
    // another kind of event, or one without changes, leaves the settings alone
    store.apply(wire({ type: "event", kind: "vision", text: "x", t: 2, changes: { record_frames: false } }));
    store.apply(wire({ type: "event", kind: "settings", text: "settings changed", t: 3 }));
    expect(store.settings).toEqual({ record_frames: true, camera_mount_deg: [0.1, 8, 0] });
    expect(heard).toBe(1);
  });

  it("follows the active reference through status messages", () => {
    const store = new Store();
    let refs = 0;
    store.subscribe("reference", () => (refs += 1));
    store.apply(wire({ type: "status", ...STATUS }));
    expect(refs).toBe(0);
    store.apply(wire({ type: "status", ...STATUS, reference: REF }));
    store.apply(wire({ type: "status", ...STATUS, reference: REF }));
    expect(refs).toBe(1);
    store.apply(wire({ type: "status", ...STATUS, reference: { ...REF, id: 2 } }));
    expect(refs).toBe(2);
    expect(store.reference?.id).toBe(2);
  });

  it("shows the verifier's training progress as it changes", () => {
    const store = new Store();
    let refs = 0;
    store.subscribe("reference", () => (refs += 1));
    const training = (progress: number) => ({ ...REF, verifier: { state: "training" as const, progress, detail: "" } });
    store.apply(wire({ type: "status", ...STATUS, reference: training(0.1) }));
    store.apply(wire({ type: "status", ...STATUS, reference: training(0.1) }));
    store.apply(wire({ type: "status", ...STATUS, reference: training(0.3) }));
    expect(refs).toBe(2);
    store.apply(wire({ type: "status", ...STATUS, reference: { ...REF, verifier: { state: "ready", progress: 1, detail: "" } } }));
    expect(refs).toBe(3);
    expect(store.reference?.verifier?.state).toBe("ready");
  });

  it("keeps a bounded history of invariants and pairs images with their frame", () => {
    const store = new Store({ historySize: 5 });
    for (let seq = 1; seq <= 40; seq += 1) store.apply(frameMessage(seq, seq % 2 === 0));
    expect(store.history.length).toBe(5);
    expect(store.history.toArray().map((s) => s.seq)).toEqual([36, 37, 38, 39, 40]);
    expect(store.history.last()).toMatchObject({ detected: true, distance: 0.4, orientationDeg: 5 });
    expect(store.frameFor(40)?.seq).toBe(40);
    expect(store.frameFor(25)?.seq).toBe(25);
    expect(store.frameFor(3)).toBeNull(); // only the recent ones are kept
    expect(store.frame?.seq).toBe(40);
  });

  it("keeps camera and threshold images apart and counts the camera rate", () => {
    let clock = 0;
    const store = new Store({ now: () => clock });
    const jpeg = new Uint8Array([0xff, 0xd8, 0, 0]);
    let images = 0;
    store.subscribe("image", () => (images += 1));
    for (let i = 0; i < 11; i += 1) {
      clock = i * 100;
      const wire = encodeBinaryFrame({ kind: "camera", seq: i, t_capture: i, width: 2, height: 2 }, jpeg);
      store.applyImage({ header: { kind: "camera", seq: i, t_capture: i, width: 2, height: 2 }, jpeg: wire });
    }
    store.applyImage({ header: { kind: "threshold", seq: 10, t_capture: 10, width: 2, height: 2 }, jpeg });
    expect(images).toBe(12);
    expect(store.cameraImage?.header.seq).toBe(10);
    expect(store.thresholdImage?.header.seq).toBe(10);
    expect(store.frameRate.rate(1000)).toBeCloseTo(10, 5);
  });

  it("logs server and local events in one bounded list", () => {
    const store = new Store({ eventsSize: 3, now: () => 2000 });
    store.apply(wire({ type: "event", kind: "link_lost", text: "Link lost", t: 1 }));
    store.addEvent("command", "arm: ACCEPTED");
    store.apply(wire({ type: "event", kind: "statustext", text: "a", t: 2 }));
    store.apply(wire({ type: "event", kind: "statustext", text: "b", t: 3 }));
    expect(store.events.toArray().map((e) => e.text)).toEqual(["arm: ACCEPTED", "a", "b"]);
    expect(store.events.toArray()[0]).toMatchObject({ kind: "command", t: 2, local: true });
  });

  it("a failing listener does not stop the others; unsubscribe works", () => {
    const store = new Store();
    let good = 0;
    const original = console.error;
    console.error = () => {};
    try {
      store.subscribe("connection", () => {
        throw new Error("bug");
      });
      const off = store.subscribe("connection", () => (good += 1));
      store.setConnection("open");
      off();
      store.setConnection("reconnecting");
    } finally {
      console.error = original;
    }
    expect(good).toBe(1);
    expect(store.connection).toBe("reconnecting");
  });

  it("keeps the heartbeat age growing when the server's figure freezes or stops", () => {
    let clock = 0;
    const store = new Store({ now: () => clock });
    expect(store.heartbeatAgeS()).toBeNull();
    store.setTelemetry(wire({ heartbeat_age_s: 0.2 }));
    clock = 100;
    store.setTelemetry(wire({ heartbeat_age_s: 0.3 }));
    expect(store.heartbeatAgeS()).toBeCloseTo(0.3, 9);
    // link lost: the server keeps sending the same frozen age
    for (let i = 1; i <= 20; i += 1) {
      clock = 100 + i * 100;
      store.setTelemetry(wire({ heartbeat_age_s: 0.3 }));
    }
    expect(store.heartbeatAgeS()).toBeCloseTo(2.3, 9);
    // the server goes silent too
    clock = 5100;
    expect(store.heartbeatAgeS()).toBeCloseTo(5.3, 9);
    store.setTelemetry(wire({ heartbeat_age_s: null }));
    expect(store.heartbeatAgeS()).toBeNull();
  });
});

describe("a command that reboots the autopilot", () => {
  it("counts a link loss as the asked-for reboot from the send, for 30 s, unless refused or failed", async () => {
    let t = 1_000_000;
    const store = new Store({ now: () => t });
    expect(store.isRebooting()).toBe(false);

    let seenDuringSend = false;
    const accepted = await store.whileRebooting(async () => {
      seenDuringSend = store.isRebooting(); // the link may drop before the answer comes
      return { ok: true };
    });
    expect(accepted.ok).toBe(true);
    expect(seenDuringSend).toBe(true);
    t += 29_000;
    expect(store.isRebooting()).toBe(true);
    t += 2_000;
    expect(store.isRebooting()).toBe(false);

    await store.whileRebooting(async () => ({ ok: false, message: "armed" }));
    expect(store.isRebooting()).toBe(false);

    await expect(
      store.whileRebooting(async () => {
        throw new Error("network");
      }),
    ).rejects.toThrow("network");
    expect(store.isRebooting()).toBe(false);
  });
});
