// The server <-> dashboard contract (api.md) as TypeScript types, plus the parsers
// that turn wire data into them. Parsers check shape at the edge and throw
// ProtocolError with a sentence, so a bad message is counted, never a crash.

export class ProtocolError extends Error {
  constructor(message: string) {
    super(message);
    this.name = "ProtocolError";
  }
}

export type Point = [number, number];

export interface LinkStatus {
  state: "connecting" | "up" | "lost" | "closed" | string;
  url: string;
  heartbeat_age_s: number | null;
  msgs_per_s?: number;
  crc_errors?: number;
}

export interface CameraStatus {
  name?: string;
  state?: string;
  fps?: number;
  frames?: number;
  errors?: number;
  last_error?: string | null;
}

export interface PipelineStatus {
  fps?: number;
  latency_ms?: number | null;
  processed?: number;
  dropped?: number;
  detected_rate?: number;
}

export interface Status {
  link: LinkStatus;
  camera: CameraStatus;
  pipeline: PipelineStatus;
  mission: Record<string, unknown> | null;
  reference: ReferenceSummary | null;
  flight: { id: string | number; dir: string } | null;
  viser_url: string;
}

export interface ReferenceSummary {
  id: string | number;
  name: string;
  pad_size_m: number;
  created: string | number;
  active: boolean;
  corners_m: Point[];
  hu: number[];
  orientation_deg: number;
  eccentricity: number;
  symmetric: boolean;
  image_size: [number, number];
  images: { original: string; threshold: string; corners: string };
  /** The corner-pattern verifier trained for this reference (RBM/DBN). */
  verifier?: VerifierStatus;
}

export interface VerifierStatus {
  state: "off" | "queued" | "training" | "ready" | "unavailable" | "failed";
  progress: number;
  detail: string;
}

export interface PoseDict {
  position_m: [number, number, number];
  R_pad_cam: number[][];
  yaw_deg: number;
  reprojection_px: number;
  symmetric: boolean;
}

export interface FrameResult {
  detected: boolean;
  corners_px: Point[];
  hu: (number | null)[];
  orientation_deg: number | null;
  eccentricity: number | null;
  pose: PoseDict | null;
  timings_ms: Record<string, number>;
  contour_px: Point[];
  score: number | null;
  reason: string;
}

export interface Overlay {
  contour: Point[];
  corners: Point[];
  reference_corners: Point[];
  axes: { origin: Point; x: Point; y: Point; z: Point } | null;
  target: Point | null;
}

export interface FrameMessage {
  type: "frame";
  seq: number;
  t_capture: number;
  latency_ms: number;
  width: number;
  height: number;
  result: FrameResult;
  overlay: Overlay;
  reference_distance: number | null;
}

/** Telemetry.to_dict() of backend.link; read through lib/telemetry.ts accessors. */
export type Telemetry = Record<string, unknown>;

export interface HelloMessage {
  type: "hello";
  status: Status;
  telemetry: Telemetry;
  reference: ReferenceSummary | null;
  settings: Record<string, unknown>;
}

export interface TelemetryMessage extends Record<string, unknown> {
  type: "telemetry";
}

export interface EventMessage {
  type: "event";
  kind: string;
  text: string;
  t: number;
  [extra: string]: unknown;
}

export interface StatusMessage extends Status {
  type: "status";
}

export interface PongMessage {
  type: "pong";
}

export type ServerMessage =
  | HelloMessage
  | TelemetryMessage
  | FrameMessage
  | EventMessage
  | StatusMessage
  | PongMessage;

export interface CommandResult {
  ok: boolean;
  command: string;
  result: number | null;
  result_name: string;
  reasons: string[];
  detail: string;
}

export interface BinaryFrameHeader {
  kind: "camera" | "threshold";
  seq: number;
  t_capture: number;
  width: number;
  height: number;
}

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
  return { contour: [], corners: [], reference_corners: [], axes: null, target: null };
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
