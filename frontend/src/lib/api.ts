// REST client for /api: adds the operator token to commands and uploads, turns
// every failure into an ApiError carrying the server's sentence (and, for a
// refused vehicle command, the vehicle's reasons verbatim).

import type { components } from "./api-types";
import { plainValidation, sentence } from "./messages";
import type { Mount } from "./mount";
import type { CommandResult, ReferenceSummary, Status, Telemetry } from "./protocol";

type S = components["schemas"];
export type ParamListing = S["ParamListing"];
export type ParamInfo = S["ParamInfo"];
export type ParamWriteResult = S["ParamWriteResult"];
export type PrecLandSetup = S["PrecLandSetup"];
export type ExtNavSetup = S["ExtNavSetup"];
export type AbortResult = S["AbortResult"];
export type FlightSummary = S["FlightSummary"];
export type FlightReplay = S["FlightReplay"];
export type MissionDefaults = S["MissionDefaults"];
export type MissionField = S["MissionField"];
export type MissionRun = S["MissionRun"];
export type MissionRunSummary = S["MissionRunSummary"];
export type PerspectivePhoto = S["PerspectivePhoto"];
export type PerspectivePreview = S["PerspectivePreview"];
export type BatteryThresholdsBody = S["BatteryThresholds"];
export type PublicSettings = S["PublicSettings"];

export type FetchLike = (input: string, init?: RequestInit) => Promise<Response>;

export class ApiError extends Error {
  constructor(
    readonly status: number,
    readonly detail: string,
    readonly body: unknown = null,
  ) {
    super(detail);
    this.name = "ApiError";
  }

  /** The vehicle's refusal reasons when the body is a CommandResult. */
  get reasons(): string[] {
    const body = this.body as { reasons?: unknown } | null;
    return Array.isArray(body?.reasons) ? body.reasons.map(String) : [];
  }
}

/** What a command button shows: accepted, refused with reasons, or failed. */
export interface CommandOutcome {
  ok: boolean;
  status: number;
  /** One sentence for the operator. */
  message: string;
  /** The vehicle's reasons, verbatim (empty when none). */
  reasons: string[];
  result: CommandResult | null;
}

export const MISSIONS_UNAVAILABLE = "missions not available yet";

/** A parameter download lasts while the vehicle keeps sending: up to the server's
 * LIST_MAX_S (backend/services/params.py, 120 s), not the usual timeout. */
export const PARAM_DOWNLOAD_TIMEOUT_MS = 125_000;

export interface ApiClientOptions {
  baseUrl?: string;
  token?: () => string | null;
  fetch?: FetchLike;
  timeoutMs?: number;
}

export class ApiClient {
  private readonly baseUrl: string;
  private readonly token: () => string | null;
  private readonly fetchFn: FetchLike;
  private readonly timeoutMs: number;

  constructor(options: ApiClientOptions = {}) {
    this.baseUrl = (options.baseUrl ?? "").replace(/\/+$/, "");
    this.token = options.token ?? (() => null);
    this.fetchFn = options.fetch ?? ((input, init) => fetch(input, init));
    this.timeoutMs = options.timeoutMs ?? 10000;
  }

  health(): Promise<{ ok: boolean; version: string }> {
    return this.request("GET", "/api/health");
  }

  status(): Promise<Status> {
    return this.request("GET", "/api/status");
  }

  telemetry(): Promise<Telemetry> {
    return this.request("GET", "/api/telemetry");
  }

  reference(): Promise<ReferenceSummary> {
    return this.request("GET", "/api/reference");
  }

  references(): Promise<ReferenceSummary[]> {
    return this.request("GET", "/api/references");
  }

  activateReference(id: string | number): Promise<ReferenceSummary> {
    return this.request("POST", `/api/references/${encodeURIComponent(String(id))}/activate`);
  }

  uploadReference(file: Blob, padSizeM: number, filename = "reference.png"): Promise<ReferenceSummary> {
    if (!Number.isFinite(padSizeM) || padSizeM <= 0 || padSizeM > 20) {
      return Promise.reject(
        new ApiError(0, "The pad size must be a number of metres above 0 and at most 20."),
      );
    }
    const form = new FormData();
    form.append("file", file, filename);
    form.append("pad_size_m", String(padSizeM));
    return this.request("POST", "/api/reference", form);
  }

  /** A URL from the server (e.g. a reference image) made absolute against baseUrl. */
  url(path: string): string {
    return /^[a-z]+:/i.test(path) ? path : `${this.baseUrl}${path}`;
  }

  /** POST /api/vehicle/<action>: arm, disarm, force-disarm, land, rtl. */
  vehicle(action: "arm" | "disarm" | "force-disarm" | "land" | "rtl"): Promise<CommandOutcome> {
    return this.command(`/api/vehicle/${action}`);
  }

  setMode(mode: string): Promise<CommandOutcome> {
    return this.command("/api/vehicle/mode", { mode });
  }

  takeoff(altitudeM: number): Promise<CommandOutcome> {
    if (!Number.isFinite(altitudeM) || altitudeM <= 0) {
      return Promise.resolve(localRefusal("The take-off altitude must be a number above 0 m."));
    }
    return this.command("/api/vehicle/takeoff", { altitude_m: altitudeM });
  }

  /**
   * POST /api/missions/<action>; a 404 means the missions are not in this server yet
   * (405 too: a server that mounts the dashboard at / answers unknown POSTs so).
   */
  mission(action: "hover" | "land" | "abort", body?: Record<string, unknown>): Promise<CommandOutcome> {
    return this.command(`/api/missions/${action}`, body, true);
  }

  /** POST /api/abort: stop any mission and hold the vehicle; never rejects. */
  async abort(): Promise<{ ok: boolean; status: number; message: string; sent: AbortResult["sent"] }> {
    try {
      const r = await this.request<AbortResult>("POST", "/api/abort");
      return { ok: r.ok, status: 200, message: sentence(r.detail), sent: r.sent };
    } catch (error) {
      if (!(error instanceof ApiError)) throw error;
      const body = error.body as Partial<AbortResult> | null;
      return {
        ok: false,
        status: error.status,
        message: describeFailure(error),
        sent: Array.isArray(body?.sent) ? body.sent : [],
      };
    }
  }

  params(): Promise<ParamListing> {
    return this.request("GET", "/api/params");
  }

  refreshParams(): Promise<ParamListing> {
    return this.request("POST", "/api/params/refresh", undefined, PARAM_DOWNLOAD_TIMEOUT_MS);
  }

  writeParam(name: string, value: number): Promise<ParamWriteResult> {
    return this.request("PUT", `/api/params/${encodeURIComponent(name)}`, { value });
  }

  batteryThresholds(): Promise<BatteryThresholdsBody> {
    return this.request("GET", "/api/params/battery");
  }

  preclandSetup(): Promise<PrecLandSetup> {
    return this.request("POST", "/api/params/precland-setup");
  }

  extnavSetup(): Promise<ExtNavSetup> {
    return this.request("POST", "/api/params/extnav-setup");
  }

  reboot(): Promise<CommandOutcome> {
    return this.command("/api/vehicle/reboot");
  }

  /** PUT /api/settings: the camera's mount (refused with 409 while a mission runs). */
  setCameraMount(mount: Mount): Promise<PublicSettings> {
    return this.request("PUT", "/api/settings", { camera_mount_deg: mount });
  }

  missionDefaults(): Promise<MissionDefaults> {
    return this.request("GET", "/api/missions/defaults");
  }

  flights(): Promise<FlightSummary[]> {
    return this.request("GET", "/api/flights");
  }

  deleteFlight(id: number): Promise<{ id: number; freed_bytes: number }> {
    return this.request("DELETE", `/api/flights/${id}`);
  }

  replay(id: number): Promise<FlightReplay> {
    return this.request("GET", `/api/flights/${id}/replay`);
  }

  uploadPerspective(file: Blob, filename: string): Promise<PerspectivePhoto> {
    const form = new FormData();
    form.append("file", file, filename);
    return this.request("POST", "/api/reference/perspective", form);
  }

  previewPerspective(draft: string, corners: [number, number][], padSizeM: number): Promise<PerspectivePreview> {
    return this.request("POST", `/api/reference/perspective/${draft}/preview`, { corners, pad_size_m: padSizeM });
  }

  activatePerspective(draft: string, preview: string): Promise<ReferenceSummary> {
    return this.request("POST", `/api/reference/perspective/${draft}/previews/${preview}/activate`);
  }

  /** A command: never rejects; the outcome says what happened in one sentence. */
  async command(path: string, body?: unknown, isMission = false): Promise<CommandOutcome> {
    try {
      const data = await this.request<unknown>("POST", path, body === undefined ? undefined : body);
      const result = asCommandResult(data);
      return {
        ok: result ? result.ok : true,
        status: 200,
        message: sentence(result?.detail || "accepted"),
        reasons: result?.reasons ?? [],
        result,
      };
    } catch (error) {
      if (!(error instanceof ApiError)) throw error;
      if (isMission && (error.status === 404 || error.status === 405)) {
        return { ok: false, status: 404, message: MISSIONS_UNAVAILABLE, reasons: [], result: null };
      }
      const result = asCommandResult(error.body);
      // A refusal with reasons: the reasons (verbatim) say it all, keep the title short.
      const refused = error.status === 409 && result !== null && result.reasons.length > 0;
      return {
        ok: false,
        status: error.status,
        message: refused ? sentence(`Refused by the vehicle (${result.result_name || "refused"})`) : describeFailure(error),
        reasons: result?.reasons ?? [],
        result,
      };
    }
  }

  async request<T>(method: string, path: string, body?: unknown, timeoutMs = this.timeoutMs): Promise<T> {
    const headers: Record<string, string> = { Accept: "application/json" };
    const token = this.token();
    if (token) headers.Authorization = `Bearer ${token}`;
    let payload: BodyInit | undefined;
    if (body instanceof FormData) {
      payload = body; // the browser sets the multipart boundary
    } else if (body !== undefined) {
      headers["Content-Type"] = "application/json";
      payload = JSON.stringify(body);
    }
    const controller = new AbortController();
    const timer = setTimeout(() => controller.abort(), timeoutMs);
    let response: Response;
    try {
      response = await this.fetchFn(this.url(path), {
        method,
        headers,
        body: payload,
        signal: controller.signal,
      });
    } catch (error) {
      const why = controller.signal.aborted
        ? `no answer within ${timeoutMs / 1000} s`
        : "the server cannot be reached";
      throw new ApiError(0, `${method} ${path}: ${why}.`, { cause: String(error) });
    } finally {
      clearTimeout(timer);
    }
    const text = await response.text();
    let data: unknown = null;
    if (text) {
      try {
        data = JSON.parse(text);
      } catch {
        data = text;
      }
    }
    if (!response.ok) {
      throw new ApiError(response.status, detailOf(data, response), data);
    }
    return data as T;
  }
}

function detailOf(data: unknown, response: Response): string {
  if (data && typeof data === "object") {
    const detail = (data as { detail?: unknown }).detail;
    if (typeof detail === "string" && detail) return detail;
    if (Array.isArray(detail) && detail.length > 0) {
      // FastAPI validation errors: a list of {loc, msg}
      return detail
        .map((d) => {
          const item = d as { loc?: unknown[]; msg?: string };
          const where = Array.isArray(item.loc) ? item.loc.filter((x) => x !== "body").join(".") : "";
          return where ? `${where}: ${item.msg ?? "invalid"}` : String(item.msg ?? "invalid");
        })
        .join("; ");
    }
  }
  if (typeof data === "string" && data.trim() && data.length < 300) return data.trim();
  return `HTTP ${response.status} ${response.statusText}`.trim();
}

/** One sentence for a failed request: what kind of failure, then the server's words. */
export function describeFailure(error: ApiError): string {
  const detail = plainValidation(error.detail);
  switch (error.status) {
    case 401:
      return sentence("Not authorised", detail);
    case 409:
      // "refused by the vehicle (FAILED)" needs no "Refused" before it
      return sentence(/refus/i.test(detail) ? "" : "Refused", detail);
    case 422:
      return sentence("Not accepted", detail);
    case 503:
      return sentence("Link down", detail);
    case 504:
      return sentence("No acknowledgement", detail);
    default:
      return sentence(detail);
  }
}

function asCommandResult(data: unknown): CommandResult | null {
  if (!data || typeof data !== "object") return null;
  const d = data as Partial<CommandResult>;
  if (typeof d.ok !== "boolean" || typeof d.command !== "string") return null;
  return {
    ok: d.ok,
    command: d.command,
    result: typeof d.result === "number" ? d.result : null,
    result_name: typeof d.result_name === "string" ? d.result_name : "",
    reasons: Array.isArray(d.reasons) ? d.reasons.map(String) : [],
    detail: typeof d.detail === "string" ? d.detail : "",
    elapsed_s: typeof d.elapsed_s === "number" ? d.elapsed_s : 0,
  };
}

function localRefusal(message: string): CommandOutcome {
  return { ok: false, status: 0, message, reasons: [], result: null };
}
