// The one WebSocket to the server: reconnects by itself with capped exponential
// backoff, tells text messages from binary frames, and notices a silent socket
// (the server sends telemetry at 10 Hz, so silence means a dead connection). The
// operator token, when there is one, is the first message on each socket (never in
// the URL); the server closes with 4401 (missing or wrong token) or 4408 (no auth
// message in time) when viewing needs it.

import {
  type BinaryFrame,
  parseBinaryFrame,
  parseServerMessage,
  ProtocolError,
  type ServerMessage,
} from "./protocol";

/** The part of the browser's WebSocket this client uses (the `ws` package fits too). */
export interface SocketLike {
  binaryType: string;
  readyState: number;
  send(data: string): void;
  close(code?: number, reason?: string): void;
  onopen: ((ev: unknown) => void) | null;
  onclose: ((ev: { code: number; reason: string }) => void) | null;
  onmessage: ((ev: { data: unknown }) => void) | null;
  onerror: ((ev: unknown) => void) | null;
}

export type SocketFactory = (url: string) => SocketLike;

export type ConnectionState = "idle" | "connecting" | "open" | "reconnecting" | "stopped";

export interface WsClientOptions {
  /** The URL, or a function giving it at each (re)connect. */
  url: string | (() => string);
  /** The token to send first on each socket (null: none), asked at each (re)connect. */
  auth?: () => string | null;
  factory?: SocketFactory;
  /** First reconnect delay; doubles up to maxDelayMs, reset when a socket opens. */
  minDelayMs?: number;
  maxDelayMs?: number;
  /** Send {"type": "ping"} this often while open (0 disables). */
  pingIntervalMs?: number;
  /** Close and reconnect when nothing arrived for this long (0 disables). */
  staleAfterMs?: number;
  /** Ask for threshold (mask) frames from the start. */
  threshold?: boolean;
}

export interface WsStats {
  messages: number;
  binaryFrames: number;
  protocolErrors: number;
  reconnects: number;
  lastError: string;
  /** The close code of the last socket that closed (0 before any). */
  lastCloseCode: number;
}

/** Close codes of the server's auth handshake. */
export const CLOSE_UNAUTHORIZED = 4401;
export const CLOSE_AUTH_TIMEOUT = 4408;

const OPEN = 1;

function defaultFactory(url: string): SocketLike {
  return new WebSocket(url) as unknown as SocketLike;
}

/** Where /ws lives for a page served from `location` (http -> ws, https -> wss). */
export function wsUrlFor(location: { protocol: string; host: string }): string {
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  return `${scheme}//${location.host}/ws`;
}

export class WsClient {
  readonly stats: WsStats = {
    messages: 0,
    binaryFrames: 0,
    protocolErrors: 0,
    reconnects: 0,
    lastError: "",
    lastCloseCode: 0,
  };
  private socket: SocketLike | null = null;
  private stateValue: ConnectionState = "idle";
  private attempts = 0;
  private reconnectTimer: ReturnType<typeof setTimeout> | null = null;
  private pingTimer: ReturnType<typeof setInterval> | null = null;
  private lastReceive = 0;
  private threshold: boolean;
  private readonly factory: SocketFactory;
  private readonly minDelayMs: number;
  private readonly maxDelayMs: number;
  private readonly pingIntervalMs: number;
  private readonly staleAfterMs: number;
  private readonly messageListeners = new Set<(msg: ServerMessage) => void>();
  private readonly binaryListeners = new Set<(frame: BinaryFrame) => void>();
  private readonly stateListeners = new Set<(state: ConnectionState) => void>();
  private readonly errorListeners = new Set<(error: ProtocolError) => void>();

  constructor(private readonly options: WsClientOptions) {
    this.factory = options.factory ?? defaultFactory;
    this.minDelayMs = options.minDelayMs ?? 250;
    this.maxDelayMs = options.maxDelayMs ?? 5000;
    this.pingIntervalMs = options.pingIntervalMs ?? 5000;
    this.staleAfterMs = options.staleAfterMs ?? 10000;
    this.threshold = options.threshold ?? false;
    if (!(this.minDelayMs > 0) || !(this.maxDelayMs >= this.minDelayMs)) {
      throw new RangeError("minDelayMs must be > 0 and maxDelayMs >= minDelayMs");
    }
  }

  get state(): ConnectionState {
    return this.stateValue;
  }

  onMessage(cb: (msg: ServerMessage) => void): () => void {
    this.messageListeners.add(cb);
    return () => this.messageListeners.delete(cb);
  }

  onBinary(cb: (frame: BinaryFrame) => void): () => void {
    this.binaryListeners.add(cb);
    return () => this.binaryListeners.delete(cb);
  }

  onState(cb: (state: ConnectionState) => void): () => void {
    this.stateListeners.add(cb);
    return () => this.stateListeners.delete(cb);
  }

  onProtocolError(cb: (error: ProtocolError) => void): () => void {
    this.errorListeners.add(cb);
    return () => this.errorListeners.delete(cb);
  }

  /** Open the socket (no-op when already running). */
  start(): void {
    if (this.stateValue !== "idle" && this.stateValue !== "stopped") return;
    this.attempts = 0;
    this.connect();
  }

  /** Close for good: no reconnect until start() again. */
  stop(): void {
    this.clearTimers();
    this.setState("stopped");
    const socket = this.socket;
    this.socket = null;
    if (socket) {
      detach(socket);
      try {
        socket.close(1000, "client stopped");
      } catch {
        // already closing: nothing to do
      }
    }
  }

  /** Close the socket and open a new one now (e.g. to authenticate with a new token). */
  restart(): void {
    if (this.stateValue === "idle" || this.stateValue === "stopped") return;
    this.stop();
    this.start();
  }

  /** Ask for (or stop) threshold mask frames; remembered across reconnects. */
  setThreshold(on: boolean): void {
    this.threshold = on;
    this.send({ type: "subscribe", threshold: on });
  }

  /** The delay before reconnect attempt number `attempt` (0-based). */
  backoffMs(attempt: number): number {
    return Math.min(this.maxDelayMs, this.minDelayMs * 2 ** Math.min(attempt, 20));
  }

  private send(message: Record<string, unknown>): boolean {
    const socket = this.socket;
    if (!socket || socket.readyState !== OPEN) return false;
    try {
      socket.send(JSON.stringify(message));
      return true;
    } catch (error) {
      this.stats.lastError = String(error);
      return false;
    }
  }

  private connect(): void {
    this.reconnectTimer = null;
    this.setState(this.attempts === 0 ? "connecting" : "reconnecting");
    const url = typeof this.options.url === "function" ? this.options.url() : this.options.url;
    let socket: SocketLike;
    try {
      socket = this.factory(url);
    } catch (error) {
      this.stats.lastError = String(error);
      this.scheduleReconnect();
      return;
    }
    socket.binaryType = "arraybuffer";
    this.socket = socket;
    socket.onopen = () => {
      if (this.socket !== socket) return;
      this.attempts = 0;
      this.lastReceive = Date.now();
      // First message: the token (the server waits for it when viewing needs it).
      const token = this.options.auth?.() ?? null;
      if (token) this.send({ type: "auth", token });
      this.setState("open");
      if (this.threshold) this.send({ type: "subscribe", threshold: true });
      this.startPing();
    };
    socket.onmessage = (ev) => {
      if (this.socket !== socket) return;
      this.lastReceive = Date.now();
      this.receive(ev.data);
    };
    socket.onerror = () => {
      // onclose follows and reconnects; keep a note for the status line
      this.stats.lastError = "WebSocket error";
    };
    socket.onclose = (ev) => {
      if (this.socket !== socket) return;
      this.socket = null;
      detach(socket);
      this.stats.lastCloseCode = ev.code;
      if (ev.code !== 1000 && ev.code !== 1005) {
        this.stats.lastError = `closed with code ${ev.code}${ev.reason ? `: ${ev.reason}` : ""}`;
      }
      this.scheduleReconnect();
    };
  }

  private receive(data: unknown): void {
    try {
      if (typeof data === "string") {
        const msg = parseServerMessage(data);
        this.stats.messages += 1;
        for (const cb of this.messageListeners) safeCall(cb, msg);
      } else if (data instanceof ArrayBuffer || data instanceof Uint8Array) {
        const frame = parseBinaryFrame(data);
        this.stats.binaryFrames += 1;
        for (const cb of this.binaryListeners) safeCall(cb, frame);
      } else {
        throw new ProtocolError("message of unexpected data type");
      }
    } catch (error) {
      if (!(error instanceof ProtocolError)) throw error;
      this.stats.protocolErrors += 1;
      this.stats.lastError = error.message;
      for (const cb of this.errorListeners) safeCall(cb, error);
    }
  }

  private scheduleReconnect(): void {
    this.clearTimers();
    if (this.stateValue === "stopped") return;
    const delay = this.backoffMs(this.attempts);
    this.attempts += 1;
    this.stats.reconnects += 1;
    this.setState("reconnecting");
    this.reconnectTimer = setTimeout(() => this.connect(), delay);
  }

  private startPing(): void {
    if (this.pingTimer) clearInterval(this.pingTimer);
    const tick = Math.max(
      100,
      Math.min(this.pingIntervalMs || Infinity, this.staleAfterMs || Infinity, 1000),
    );
    let sincePing = 0;
    this.pingTimer = setInterval(() => {
      const socket = this.socket;
      if (!socket) return;
      if (this.staleAfterMs > 0 && Date.now() - this.lastReceive > this.staleAfterMs) {
        // silent socket: drop it and reconnect rather than wait for TCP to notice
        this.socket = null;
        detach(socket);
        this.stats.lastError = `no message for ${this.staleAfterMs} ms`;
        try {
          socket.close(4000, "stale");
        } catch {
          // closing a broken socket may throw: it is gone either way
        }
        this.scheduleReconnect();
        return;
      }
      sincePing += tick;
      if (this.pingIntervalMs > 0 && sincePing >= this.pingIntervalMs) {
        sincePing = 0;
        this.send({ type: "ping" });
      }
    }, tick);
  }

  private clearTimers(): void {
    if (this.reconnectTimer) clearTimeout(this.reconnectTimer);
    if (this.pingTimer) clearInterval(this.pingTimer);
    this.reconnectTimer = null;
    this.pingTimer = null;
  }

  private setState(state: ConnectionState): void {
    if (state === this.stateValue) return;
    this.stateValue = state;
    for (const cb of this.stateListeners) safeCall(cb, state);
  }
}

function detach(socket: SocketLike): void {
  socket.onopen = null;
  socket.onmessage = null;
  socket.onerror = null;
  socket.onclose = null;
}

function safeCall<T>(cb: (value: T) => void, value: T): void {
  try {
    cb(value);
  } catch (error) {
    // one faulty widget must not stop the others from hearing the message
    console.error("listener failed", error);
  }
}
