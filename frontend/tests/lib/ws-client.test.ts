// The WebSocket client against a real WebSocket server on a loopback port (the `ws`
// package), with the `ws` client as the socket: real frames, real closes.

import type { AddressInfo } from "node:net";
import { afterEach, beforeEach, describe, expect, it } from "vitest";
import WebSocket, { WebSocketServer } from "ws";
import { encodeBinaryFrame, type ServerMessage } from "../../src/lib/protocol";
import { type ConnectionState, type SocketLike, WsClient, wsUrlFor } from "../../src/lib/ws-client";

const JPEG = new Uint8Array([0xff, 0xd8, 0xff, 0xe0, 9, 9, 0xff, 0xd9]);
const HELLO = JSON.stringify({ type: "hello", status: { link: { state: "up" } }, telemetry: {}, reference: null, settings: {} });

let server: WebSocketServer;
let url: string;
let clients: WsClient[];
const received: string[] = [];

function factory(u: string): SocketLike {
  return new WebSocket(u) as unknown as SocketLike;
}

function waitFor(cond: () => boolean, timeoutMs = 3000): Promise<void> {
  return new Promise((resolve, reject) => {
    const start = Date.now();
    const poll = () => {
      if (cond()) resolve();
      else if (Date.now() - start > timeoutMs) reject(new Error("timed out waiting"));
      else setTimeout(poll, 10);
    };
    poll();
  });
}

function make(options: Partial<ConstructorParameters<typeof WsClient>[0]> = {}): WsClient {
  const client = new WsClient({ url, factory, minDelayMs: 20, maxDelayMs: 100, ...options });
  clients.push(client);
  return client;
}

beforeEach(async () => {
  clients = [];
  received.length = 0;
  server = new WebSocketServer({ host: "127.0.0.1", port: 0 });
  await new Promise<void>((resolve) => server.on("listening", () => resolve()));
  url = `ws://127.0.0.1:${(server.address() as AddressInfo).port}/ws`;
  server.on("connection", (sock) => {
    sock.on("message", (data) => received.push(String(data)));
    sock.send(HELLO);
  });
});

afterEach(async () => {
  for (const c of clients) c.stop();
  for (const s of server.clients) s.terminate();
  await new Promise<void>((resolve) => server.close(() => resolve()));
});

describe("WsClient", () => {
  it("opens, gets hello at once, and parses text and binary messages", async () => {
    const client = make();
    const messages: ServerMessage[] = [];
    const frames: number[] = [];
    client.onMessage((m) => messages.push(m));
    client.onBinary((f) => frames.push(f.header.seq));
    client.start();
    await waitFor(() => messages.length === 1);
    expect(client.state).toBe("open");
    expect(messages[0].type).toBe("hello");
    for (const s of server.clients) {
      s.send(JSON.stringify({ type: "telemetry", armed: true }));
      s.send(encodeBinaryFrame({ kind: "camera", seq: 42, t_capture: 1, width: 4, height: 2 }, JPEG));
    }
    await waitFor(() => messages.length === 2 && frames.length === 1);
    expect(messages[1]).toMatchObject({ type: "telemetry", armed: true });
    expect(frames).toEqual([42]);
    expect(client.stats).toMatchObject({ messages: 2, binaryFrames: 1, protocolErrors: 0 });
  });

  it("counts garbage from the server and keeps listening", async () => {
    const client = make();
    const types: string[] = [];
    const errors: string[] = [];
    client.onMessage((m) => types.push(m.type));
    client.onProtocolError((e) => errors.push(e.message));
    client.start();
    await waitFor(() => types.length === 1);
    for (const s of server.clients) {
      s.send("{not json");
      s.send(new Uint8Array([1, 2, 3]));
      s.send('{"type":"bogus"}');
      s.send('{"type":"pong"}');
    }
    await waitFor(() => types.length === 2);
    expect(types).toEqual(["hello", "pong"]);
    expect(client.stats.protocolErrors).toBe(3);
    expect(errors).toHaveLength(3);
    expect(client.state).toBe("open");
  });

  it("a listener that throws does not stop the others", async () => {
    const client = make();
    let heard = 0;
    client.onMessage(() => {
      throw new Error("widget bug");
    });
    client.onMessage(() => {
      heard += 1;
    });
    const original = console.error;
    console.error = () => {};
    try {
      client.start();
      await waitFor(() => heard === 1);
    } finally {
      console.error = original;
    }
    expect(client.stats.protocolErrors).toBe(0);
  });

  it("reconnects by itself when the server drops the socket, and gets hello again", async () => {
    const client = make();
    const states: ConnectionState[] = [];
    let hellos = 0;
    client.onState((s) => states.push(s));
    client.onMessage((m) => {
      if (m.type === "hello") hellos += 1;
    });
    client.start();
    await waitFor(() => hellos === 1);
    for (const s of server.clients) s.close(1011, "server restart");
    await waitFor(() => hellos === 2);
    expect(states).toEqual(["connecting", "open", "reconnecting", "open"]);
    expect(client.stats.reconnects).toBe(1);
    expect(client.stats.lastError).toContain("1011");
  });

  it("keeps retrying while the server is away and connects when it is back", async () => {
    const port = (server.address() as AddressInfo).port;
    for (const s of server.clients) s.terminate();
    await new Promise<void>((resolve) => server.close(() => resolve()));
    const client = make();
    let hellos = 0;
    client.onMessage((m) => {
      if (m.type === "hello") hellos += 1;
    });
    client.start();
    await waitFor(() => client.stats.reconnects >= 3);
    expect(client.state).toBe("reconnecting");
    server = new WebSocketServer({ host: "127.0.0.1", port });
    server.on("connection", (sock) => sock.send(HELLO));
    await waitFor(() => hellos === 1);
    expect(client.state).toBe("open");
  });

  it("asks for threshold frames on open and when toggled, and remembers it across reconnects", async () => {
    const client = make({ threshold: true });
    client.start();
    await waitFor(() => received.length === 1);
    expect(JSON.parse(received[0])).toEqual({ type: "subscribe", threshold: true });
    client.setThreshold(false);
    await waitFor(() => received.length === 2);
    expect(JSON.parse(received[1])).toEqual({ type: "subscribe", threshold: false });
    client.setThreshold(true);
    await waitFor(() => received.length === 3);
    for (const s of server.clients) s.close(1001, "going away");
    await waitFor(() => received.length === 4);
    expect(JSON.parse(received[3])).toEqual({ type: "subscribe", threshold: true });
  });

  it("pings while open", async () => {
    const client = make({ pingIntervalMs: 100 });
    client.start();
    await waitFor(() => received.some((r) => JSON.parse(r).type === "ping"), 2000);
  });

  it("drops a silent socket and reconnects", async () => {
    const client = make({ staleAfterMs: 200, pingIntervalMs: 0 });
    let hellos = 0;
    client.onMessage((m) => {
      if (m.type === "hello") hellos += 1;
    });
    client.start();
    // the server says hello and then nothing: the client must not wait forever
    await waitFor(() => hellos >= 2, 3000);
    expect(client.stats.lastError).toContain("no message");
  });

  it("stop() closes and never reconnects", async () => {
    const client = make();
    client.start();
    await waitFor(() => client.state === "open");
    client.stop();
    await waitFor(() => server.clients.size === 0);
    await new Promise((r) => setTimeout(r, 150));
    expect(client.state).toBe("stopped");
    expect(server.clients.size).toBe(0);
  });

  it("computes a capped exponential backoff and refuses bad options", () => {
    const client = new WsClient({ url: "ws://x", minDelayMs: 100, maxDelayMs: 1000 });
    expect([0, 1, 2, 3, 4, 50].map((a) => client.backoffMs(a))).toEqual([100, 200, 400, 800, 1000, 1000]);
    expect(() => new WsClient({ url: "ws://x", minDelayMs: 0 })).toThrowError(RangeError);
    expect(() => new WsClient({ url: "ws://x", minDelayMs: 10, maxDelayMs: 5 })).toThrowError(RangeError);
  });

  it("sends the token as the first message of each socket, never in the URL", async () => {
    let token: string | null = "first-token";
    const client = make({ auth: () => token, threshold: true });
    client.start();
    await waitFor(() => received.length >= 2);
    expect(JSON.parse(received[0])).toEqual({ type: "auth", token: "first-token" });
    expect(JSON.parse(received[1])).toEqual({ type: "subscribe", threshold: true });
    token = "second-token";
    received.length = 0;
    client.restart();
    await waitFor(() => received.length >= 1);
    expect(JSON.parse(received[0])).toEqual({ type: "auth", token: "second-token" });
    for (const s of server.clients) expect(s.protocol).toBe("");
  });

  it("remembers the server's close code (4401: the token is wrong)", async () => {
    server.removeAllListeners("connection");
    server.on("connection", (sock) => sock.close(4401, "The operator token is wrong."));
    const client = make();
    client.start();
    await waitFor(() => client.stats.lastCloseCode === 4401);
    expect(client.stats.lastError).toContain("4401");
  });

  it("builds the /ws URL from the page location", () => {
    expect(wsUrlFor({ protocol: "http:", host: "127.0.0.1:8000" })).toBe("ws://127.0.0.1:8000/ws");
    expect(wsUrlFor({ protocol: "https:", host: "gcs.local" })).toBe("wss://gcs.local/ws");
  });

  it("uses the URL function at each connect", async () => {
    let calls = 0;
    const client = make({
      url: () => {
        calls += 1;
        return url;
      },
    });
    client.start();
    await waitFor(() => client.state === "open");
    for (const s of server.clients) s.close(1012, "again");
    await waitFor(() => calls === 2 && client.state === "open");
  });
});
