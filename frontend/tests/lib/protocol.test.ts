import { describe, expect, it } from "vitest";
import {
  encodeBinaryFrame,
  parseBinaryFrame,
  parseServerMessage,
  ProtocolError,
} from "../../src/lib/protocol";

const JPEG = new Uint8Array([0xff, 0xd8, 0xff, 0xe0, 1, 2, 3, 0xff, 0xd9]);
const HEADER = { kind: "camera" as const, seq: 7, t_capture: 1700000000.25, width: 640, height: 480 };

describe("parseServerMessage", () => {
  it("accepts each message type of the contract", () => {
    const hello = parseServerMessage(
      JSON.stringify({ type: "hello", status: { link: {} }, telemetry: {}, reference: null, settings: {} }),
    );
    expect(hello.type).toBe("hello");
    expect(parseServerMessage('{"type":"telemetry","armed":false}').type).toBe("telemetry");
    expect(parseServerMessage('{"type":"status","link":{"state":"up"}}').type).toBe("status");
    expect(parseServerMessage('{"type":"pong"}').type).toBe("pong");
    const ev = parseServerMessage('{"type":"event","kind":"link_lost","t":1}');
    expect(ev).toMatchObject({ kind: "link_lost", text: "" });
  });

  it("fills a missing overlay and missing points of a frame with empty ones", () => {
    const msg = parseServerMessage(JSON.stringify({ type: "frame", seq: 1, result: { detected: false } }));
    expect(msg.type === "frame" && msg.overlay).toEqual({
      reference_corners: [],
      axes: null,
      target: null,
    });
    expect(msg.type === "frame" && [msg.result.contour_px, msg.result.corners_px]).toEqual([[], []]);
  });

  it.each([
    ["not json", "message is not JSON"],
    ["[1,2]", "not a JSON object"],
    ['{"kind":"x"}', "no string 'type'"],
    ['{"type":"nonsense"}', "unknown message type 'nonsense'"],
    ['{"type":"hello","telemetry":{}}', "hello without a status"],
    ['{"type":"frame","seq":"1","result":{}}', "numeric seq"],
    ['{"type":"frame","seq":1}', "without a result"],
    ['{"type":"status"}', "status without a link"],
    ['{"type":"event","text":"x"}', "event without a string kind"],
  ])("rejects %s", (text, why) => {
    expect(() => parseServerMessage(text)).toThrowError(ProtocolError);
    expect(() => parseServerMessage(text)).toThrowError(why);
  });
});

describe("parseBinaryFrame", () => {
  it("round-trips a frame built like the server builds it", () => {
    const wire = encodeBinaryFrame(HEADER, JPEG);
    // the first 4 bytes are the big-endian header length
    const n = new DataView(wire.buffer).getUint32(0, false);
    expect(n).toBe(new TextEncoder().encode(JSON.stringify(HEADER)).byteLength);
    const frame = parseBinaryFrame(wire.buffer as ArrayBuffer);
    expect(frame.header).toEqual(HEADER);
    expect(Array.from(frame.jpeg)).toEqual(Array.from(JPEG));
  });

  it("reads a frame that sits at an offset inside a larger buffer", () => {
    const wire = encodeBinaryFrame({ ...HEADER, kind: "threshold" }, JPEG);
    const big = new Uint8Array(wire.byteLength + 10);
    big.set(wire, 5);
    const frame = parseBinaryFrame(big.subarray(5, 5 + wire.byteLength));
    expect(frame.header.kind).toBe("threshold");
    expect(frame.jpeg.byteLength).toBe(JPEG.byteLength);
  });

  it("rejects a message shorter than the length prefix", () => {
    expect(() => parseBinaryFrame(new Uint8Array([0, 0]))).toThrowError("too short");
  });

  it("rejects a header length that runs past the end", () => {
    const wire = encodeBinaryFrame(HEADER, JPEG);
    new DataView(wire.buffer).setUint32(0, wire.byteLength, false);
    expect(() => parseBinaryFrame(wire)).toThrowError("does not fit");
  });

  it("rejects a zero header length", () => {
    expect(() => parseBinaryFrame(new Uint8Array([0, 0, 0, 0, 0xff, 0xd8]))).toThrowError("does not fit");
  });

  it("rejects a header that is not JSON or not UTF-8", () => {
    const bad = new Uint8Array([0, 0, 0, 2, 0xc3, 0x28, 0xff, 0xd8, 0, 0]);
    expect(() => parseBinaryFrame(bad)).toThrowError("not UTF-8 JSON");
  });

  it("rejects an unknown kind and a missing numeric field", () => {
    expect(() => parseBinaryFrame(encodeBinaryFrame({ ...HEADER, kind: "video" as never }, JPEG))).toThrowError(
      "unknown kind 'video'",
    );
    const { seq: _seq, ...noSeq } = HEADER;
    expect(() => parseBinaryFrame(encodeBinaryFrame(noSeq as never, JPEG))).toThrowError("'seq'");
  });

  it("rejects a payload that is not a JPEG", () => {
    const png = new Uint8Array([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a]);
    expect(() => parseBinaryFrame(encodeBinaryFrame(HEADER, png))).toThrowError("not a JPEG");
  });
});
