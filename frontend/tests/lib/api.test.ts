// The REST client against a real HTTP server on a loopback port.

import { createServer, type IncomingMessage, type Server, type ServerResponse } from "node:http";
import type { AddressInfo } from "node:net";
import { afterEach, beforeEach, describe, expect, it } from "vitest";
import { ApiClient, ApiError, MISSIONS_UNAVAILABLE } from "../../src/lib/api";

interface Seen {
  method: string;
  url: string;
  auth: string | undefined;
  type: string | undefined;
  body: string;
}

type Handler = (req: IncomingMessage, body: string, res: ServerResponse) => void;

let server: Server;
let base: string;
let seen: Seen[];
let handler: Handler;

function json(res: ServerResponse, status: number, body: unknown): void {
  res.writeHead(status, { "Content-Type": "application/json" });
  res.end(JSON.stringify(body));
}

beforeEach(async () => {
  seen = [];
  handler = (_req, _body, res) => json(res, 200, { ok: true });
  server = createServer((req, res) => {
    const chunks: Buffer[] = [];
    req.on("data", (c: Buffer) => chunks.push(c));
    req.on("end", () => {
      const body = Buffer.concat(chunks).toString("latin1");
      seen.push({
        method: req.method ?? "",
        url: req.url ?? "",
        auth: req.headers.authorization,
        type: req.headers["content-type"],
        body,
      });
      handler(req, body, res);
    });
  });
  await new Promise<void>((resolve) => server.listen(0, "127.0.0.1", () => resolve()));
  base = `http://127.0.0.1:${(server.address() as AddressInfo).port}`;
});

afterEach(async () => {
  server.closeAllConnections();
  await new Promise<void>((resolve) => server.close(() => resolve()));
});

describe("ApiClient", () => {
  it("sends the bearer token and reads JSON", async () => {
    handler = (_req, _b, res) => json(res, 200, { ok: true, version: "0.1.0" });
    const api = new ApiClient({ baseUrl: `${base}/`, token: () => "s3cret-token" });
    expect(await api.health()).toEqual({ ok: true, version: "0.1.0" });
    expect(seen[0]).toMatchObject({ method: "GET", url: "/api/health", auth: "Bearer s3cret-token" });
  });

  it("sends no Authorization header without a token", async () => {
    const api = new ApiClient({ baseUrl: base });
    await api.status();
    expect(seen[0].auth).toBeUndefined();
  });

  it("an accepted command gives ok with the result", async () => {
    handler = (_req, _b, res) =>
      json(res, 200, { ok: true, command: "arm", result: 0, result_name: "ACCEPTED", reasons: [], detail: "" });
    const out = await new ApiClient({ baseUrl: base, token: () => "t0ken-123" }).vehicle("arm");
    expect(out).toMatchObject({ ok: true, status: 200, message: "Accepted.", reasons: [] });
    expect(seen[0]).toMatchObject({ method: "POST", url: "/api/vehicle/arm" });
  });

  it("a refused command carries the vehicle's reasons verbatim", async () => {
    const reasons = ["PreArm: Need Position Estimate", "Arm: Throttle too high"];
    handler = (_req, _b, res) =>
      json(res, 409, {
        ok: false,
        command: "arm",
        result: 4,
        result_name: "FAILED",
        reasons,
        detail: "The vehicle refused to arm.",
      });
    const out = await new ApiClient({ baseUrl: base }).vehicle("arm");
    expect(out.ok).toBe(false);
    expect(out.status).toBe(409);
    expect(out.reasons).toEqual(reasons);
    expect(out.message).toBe("Refused by the vehicle (FAILED).");
  });

  it("a refusal without reasons gives the server's sentence", async () => {
    handler = (_req, _b, res) =>
      json(res, 409, { ok: false, command: "takeoff", result: 4, result_name: "FAILED", reasons: [], detail: "Take-off refused." });
    const out = await new ApiClient({ baseUrl: base }).takeoff(2);
    expect(out).toMatchObject({ ok: false, status: 409, reasons: [], message: "Take-off refused." });
  });

  it("posts JSON bodies for mode and take-off", async () => {
    const api = new ApiClient({ baseUrl: base });
    await api.setMode("GUIDED");
    await api.takeoff(2.5);
    expect(seen.map((s) => [s.url, s.type, JSON.parse(s.body)])).toEqual([
      ["/api/vehicle/mode", "application/json", { mode: "GUIDED" }],
      ["/api/vehicle/takeoff", "application/json", { altitude_m: 2.5 }],
    ]);
  });

  it("puts the camera's mount with the token and reads the settings back", async () => {
    handler = (_req, _b, res) => json(res, 200, { record_frames: true, camera_mount_deg: [0.1, 8, 0] });
    const settings = await new ApiClient({ baseUrl: base, token: () => "t0ken-123" }).setCameraMount([0.1, 8, 0]);
    expect(settings.camera_mount_deg).toEqual([0.1, 8, 0]);
    expect(seen[0]).toMatchObject({ method: "PUT", url: "/api/settings", auth: "Bearer t0ken-123", type: "application/json" });
    expect(JSON.parse(seen[0].body)).toEqual({ camera_mount_deg: [0.1, 8, 0] });
  });

  it("refuses a bad take-off altitude without calling the server", async () => {
    const api = new ApiClient({ baseUrl: base });
    for (const alt of [0, -1, Number.NaN, Number.POSITIVE_INFINITY]) {
      const out = await api.takeoff(alt);
      expect(out.ok).toBe(false);
      expect(out.message).toContain("altitude");
    }
    expect(seen).toHaveLength(0);
  });

  it("reports 401, 503 and 504 with the server's sentence", async () => {
    const api = new ApiClient({ baseUrl: base });
    for (const [status, prefix] of [
      [401, "Not authorised"],
      [503, "Link down"],
      [504, "No acknowledgement"],
    ] as const) {
      handler = (_req, _b, res) => json(res, status, { detail: "Because of reasons." });
      const out = await api.vehicle("land");
      expect(out).toMatchObject({ ok: false, status, message: `${prefix}: because of reasons.`, reasons: [] });
    }
  });

  it("turns a missions 404 into 'missions not available yet'", async () => {
    handler = (_req, _b, res) => json(res, 404, { detail: "Not Found" });
    const api = new ApiClient({ baseUrl: base });
    for (const action of ["hover", "land", "abort"] as const) {
      const out = await api.mission(action);
      expect(out).toMatchObject({ ok: false, status: 404, message: MISSIONS_UNAVAILABLE });
    }
    // a static-files mount at / answers an unknown POST with 405: same meaning
    handler = (_req, _b, res) => json(res, 405, { detail: "Method Not Allowed" });
    expect((await api.mission("hover")).message).toBe(MISSIONS_UNAVAILABLE);
    handler = (_req, _b, res) => json(res, 404, { detail: "Not Found" });
    // a vehicle 404 is not a missing mission
    const out = await api.vehicle("rtl");
    expect(out.message).toBe("Not Found.");
  });

  it("reads FastAPI validation error lists into one sentence", async () => {
    handler = (_req, _b, res) =>
      json(res, 422, { detail: [{ loc: ["body", "altitude_m"], msg: "Input should be a valid number" }] });
    const out = await new ApiClient({ baseUrl: base }).takeoff(3);
    // one plain sentence: no field names with underscores, no pydantic wording
    expect(out.message).toBe("Not accepted: altitude (m): must be a number.");
  });

  it("rejects with ApiError for a failed GET, keeping the body", async () => {
    handler = (_req, _b, res) => json(res, 404, { detail: "No reference is active." });
    const err = await new ApiClient({ baseUrl: base }).reference().catch((e: unknown) => e);
    expect(err).toBeInstanceOf(ApiError);
    expect((err as ApiError).status).toBe(404);
    expect((err as ApiError).message).toBe("No reference is active.");
  });

  it("handles a non-JSON error body", async () => {
    handler = (_req, _b, res) => {
      res.writeHead(500, { "Content-Type": "text/plain" });
      res.end("Internal Server Error");
    };
    const err = (await new ApiClient({ baseUrl: base }).status().catch((e: unknown) => e)) as ApiError;
    expect(err.status).toBe(500);
    expect(err.detail).toBe("Internal Server Error");
  });

  it("uploads a reference as multipart with the pad size", async () => {
    handler = (_req, _b, res) => json(res, 201, { id: 3, name: "pad.png", pad_size_m: 0.55 });
    const api = new ApiClient({ baseUrl: base, token: () => "tok-tok-tok" });
    const png = new Blob([new Uint8Array([0x89, 0x50, 0x4e, 0x47])], { type: "image/png" });
    const summary = await api.uploadReference(png, 0.55, "pad.png");
    expect(summary).toMatchObject({ id: 3 });
    expect(seen[0].type).toMatch(/^multipart\/form-data; boundary=/);
    expect(seen[0].auth).toBe("Bearer tok-tok-tok");
    expect(seen[0].body).toContain('name="pad_size_m"\r\n\r\n0.55');
    expect(seen[0].body).toContain('name="file"; filename="pad.png"');
    expect(seen[0].body).toContain("\x89PNG");
  });

  it("refuses an out-of-range pad size before uploading", async () => {
    const api = new ApiClient({ baseUrl: base });
    for (const size of [0, -2, 20.5, Number.NaN]) {
      await expect(api.uploadReference(new Blob(["x"]), size)).rejects.toThrowError("pad size");
    }
    expect(seen).toHaveLength(0);
  });

  it("says the server cannot be reached when nothing listens", async () => {
    const port = (server.address() as AddressInfo).port;
    server.closeAllConnections();
    await new Promise<void>((resolve) => server.close(() => resolve()));
    const api = new ApiClient({ baseUrl: `http://127.0.0.1:${port}` });
    const out = await api.vehicle("arm");
    expect(out).toMatchObject({ ok: false, status: 0 });
    expect(out.message).toContain("cannot be reached");
    server = createServer(); // for afterEach
    await new Promise<void>((resolve) => server.listen(0, "127.0.0.1", () => resolve()));
  });

  it("gives up after its timeout", async () => {
    handler = () => {
      /* never answer */
    };
    const api = new ApiClient({ baseUrl: base, timeoutMs: 150 });
    const err = (await api.status().catch((e: unknown) => e)) as ApiError;
    expect(err.status).toBe(0);
    expect(err.message).toContain("no answer within 0.15 s");
  });

  it("waits longer for a parameter download than for other calls", async () => {
    // answers after the client's usual timeout (the same event loop: its timer fires first)
    const listing = { count: 2, received: 2, complete: true, fetched_at: 1, params: [] };
    handler = (_req, _b, res) => setTimeout(() => json(res, 200, listing), 300);
    const api = new ApiClient({ baseUrl: base, timeoutMs: 150 });
    const err = (await api.params().catch((e: unknown) => e)) as ApiError;
    expect(err.message).toContain("no answer within 0.15 s");
    expect((await api.refreshParams()).complete).toBe(true);
  });

  it("makes server paths absolute and leaves full URLs alone", () => {
    const api = new ApiClient({ baseUrl: "http://h:1" });
    expect(api.url("/api/references/1/image/corners")).toBe("http://h:1/api/references/1/image/corners");
    expect(api.url("http://other/x.png")).toBe("http://other/x.png");
  });
});
