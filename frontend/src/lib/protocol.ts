// The server <-> dashboard contract, plus the parsers that turn wire data into it.
// The types come from the server's OpenAPI document (api-types.ts, made by
// `make types` from backend/api/schemas.py and backend/api/messages.py; never edit
// it by hand). Parsers check shape at the edge and throw ProtocolError with a
// sentence, so a bad message is counted, never a crash.

import type { components } from "./api-types";

type Schemas = components["schemas"];

export class ProtocolError extends Error {
  constructor(message: string) {
    super(message);
    this.name = "ProtocolError";
  }
}

export type Point = [number, number];

export type LinkStatus = Schemas["LinkStatus"];
export type CameraStatus = Schemas["CameraStatus"];
export type PipelineStatus = Schemas["PipelineStatus"];
export type Status = Schemas["Status"];
export type ReferenceSummary = Schemas["ReferenceSummary"];
export type VerifierStatus = Schemas["VerifierStatus"];
export type MissionSnapshot = Schemas["MissionSnapshot"];
export type PoseDict = Schemas["Pose"];
export type FrameResult = Schemas["FrameResult"];
export type Overlay = Schemas["Overlay"];
export type FrameMessage = Schemas["FrameMessage"];
export type PublicSettings = Schemas["PublicSettings"];
/** The link's telemetry snapshot; read through lib/telemetry.ts accessors. */
export type Telemetry = Schemas["Telemetry"];
export type HelloMessage = Schemas["HelloMessage"];
export type TelemetryMessage = Schemas["TelemetryMessage"];
export type EventMessage = Schemas["EventMessage"];
export type StatusMessage = Schemas["StatusMessage"];
export type PongMessage = Schemas["PongMessage"];
export type CommandResult = Schemas["CommandResult"];
export type BinaryFrameHeader = Schemas["BinaryFrameHeader"];
export type ClientMessage = Schemas["PingMessage"] | Schemas["SubscribeMessage"] | Schemas["AuthMessage"];

export type ServerMessage =
  | HelloMessage
  | TelemetryMessage
  | FrameMessage
  | EventMessage
  | StatusMessage
  | PongMessage;

export interface BinaryFrame {
  header: BinaryFrameHeader;
  /** The JPEG bytes (a view into the received buffer, not a copy). */
  jpeg: Uint8Array;
}

const KNOWN_TYPES = new Set(["hello", "telemetry", "frame", "event", "status", "pong"]);

function isObject(value: unknown): value is Record<string, unknown> {
  return typeof value === "object" && value !== null && !Array.isArray(value);
}

/** Parse one text message from /ws. Throws ProtocolError on anything off-contract. */
export function parseServerMessage(text: string): ServerMessage {
  let value: unknown;
  try {
    value = JSON.parse(text);
  } catch {
    throw new ProtocolError("message is not JSON");
  }
  if (!isObject(value)) throw new ProtocolError("message is not a JSON object");
  const type = value.type;
  if (typeof type !== "string") throw new ProtocolError("message has no string 'type'");
  if (!KNOWN_TYPES.has(type)) throw new ProtocolError(`unknown message type '${type}'`);
  switch (type) {
    case "hello":
      if (!isObject(value.status)) throw new ProtocolError("hello without a status object");
      if (!isObject(value.telemetry)) throw new ProtocolError("hello without a telemetry object");
      break;
    case "frame":
      if (typeof value.seq !== "number") throw new ProtocolError("frame without a numeric seq");
      if (!isObject(value.result)) throw new ProtocolError("frame without a result object");
      if (!isObject(value.overlay)) value.overlay = emptyOverlay();
      // The contour and corners travel once, in the result: drawn from there.
      for (const key of ["contour_px", "corners_px"] as const) {
        if (!Array.isArray(value.result[key])) value.result[key] = [];
      }
      break;
    case "status":
      if (!isObject(value.link)) throw new ProtocolError("status without a link object");
      break;
    case "event":
      if (typeof value.kind !== "string") throw new ProtocolError("event without a string kind");
      if (typeof value.text !== "string") value.text = "";
      break;
    default:
      break;
  }
  return value as unknown as ServerMessage;
}

export function emptyOverlay(): Overlay {
  return { reference_corners: [], axes: null, target: null };
}

const textDecoder = new TextDecoder("utf-8", { fatal: true });

/**
 * Parse a binary /ws message: 4-byte big-endian header length N, N bytes of UTF-8
 * JSON header, then the JPEG bytes.
 */
export function parseBinaryFrame(data: ArrayBuffer | Uint8Array): BinaryFrame {
  const bytes = data instanceof Uint8Array ? data : new Uint8Array(data);
  if (bytes.byteLength < 4) {
    throw new ProtocolError(`binary message too short (${bytes.byteLength} bytes)`);
  }
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const n = view.getUint32(0, false);
  if (n === 0 || 4 + n > bytes.byteLength) {
    throw new ProtocolError(
      `binary header length ${n} does not fit a ${bytes.byteLength}-byte message`,
    );
  }
  let header: unknown;
  try {
    header = JSON.parse(textDecoder.decode(bytes.subarray(4, 4 + n)));
  } catch {
    throw new ProtocolError("binary header is not UTF-8 JSON");
  }
  if (!isObject(header)) throw new ProtocolError("binary header is not a JSON object");
  if (header.kind !== "camera" && header.kind !== "threshold") {
    throw new ProtocolError(`binary frame of unknown kind '${String(header.kind)}'`);
  }
  for (const key of ["seq", "t_capture", "width", "height"] as const) {
    if (typeof header[key] !== "number" || !Number.isFinite(header[key])) {
      throw new ProtocolError(`binary header field '${key}' is not a number`);
    }
  }
  const jpeg = bytes.subarray(4 + n);
  if (jpeg.byteLength < 4 || jpeg[0] !== 0xff || jpeg[1] !== 0xd8) {
    throw new ProtocolError("binary frame payload is not a JPEG (no SOI marker)");
  }
  return { header: header as unknown as BinaryFrameHeader, jpeg };
}

/** Build a binary frame the way the server does (used by tests and tools). */
export function encodeBinaryFrame(header: BinaryFrameHeader, jpeg: Uint8Array): Uint8Array {
  const head = new TextEncoder().encode(JSON.stringify(header));
  const out = new Uint8Array(4 + head.byteLength + jpeg.byteLength);
  new DataView(out.buffer).setUint32(0, head.byteLength, false);
  out.set(head, 4);
  out.set(jpeg, 4 + head.byteLength);
  return out;
}
