// The operator token: typed (or pasted) into the dashboard, kept in localStorage, and
// sent only in the Authorization header and as the WebSocket's first message. Never in
// a URL: URLs end up in logs and the browser's history. A token the server refused is
// not offered again until a new one is set.

export interface KeyValueStore {
  getItem(key: string): string | null;
  setItem(key: string, value: string): void;
  removeItem(key: string): void;
}

const KEY = "visland.token";

/**
 * The address without any `token` parameter (query or hash), or null when it has none.
 * The dashboard never takes a token from its address; it only removes one left there.
 */
export function withoutTokenInAddress(href: string): string | null {
  const url = new URL(href);
  let changed = false;
  for (const key of [...url.searchParams.keys()]) {
    if (key.trim().toLowerCase() === "token") {
      url.searchParams.delete(key);
      changed = true;
    }
  }
  if (url.hash.length > 1) {
    const hash = new URLSearchParams(url.hash.slice(1));
    for (const key of [...hash.keys()]) {
      if (key.trim().toLowerCase() === "token") {
        hash.delete(key);
        changed = true;
      }
    }
    if (changed) {
      const rest = hash.toString();
      url.hash = rest ? `#${rest}` : "";
    }
  }
  return changed ? url.toString() : null;
}

export class TokenKeeper {
  private value: string | null;
  private refused = false;
  private readonly listeners = new Set<(token: string | null) => void>();

  constructor(private readonly storage: KeyValueStore | null) {
    this.value = safeGet(storage);
  }

  get(): string | null {
    return this.value;
  }

  /** The token to offer the server: none once it said this one is wrong. */
  usable(): string | null {
    return this.refused ? null : this.value;
  }

  /** The server said the token is wrong: stop offering it until a new one is set. */
  markRefused(): void {
    this.refused = true;
  }

  get isRefused(): boolean {
    return this.refused && this.value !== null;
  }

  set(token: string | null): void {
    const clean = token?.trim() || null;
    this.value = clean;
    this.refused = false;
    try {
      if (clean) this.storage?.setItem(KEY, clean);
      else this.storage?.removeItem(KEY);
    } catch {
      // storage may be disabled (private mode): the token stays for this page only
    }
    for (const cb of this.listeners) cb(clean);
  }

  /** Call `cb(token)` whenever a token is set or cleared; returns the remover. */
  onChange(cb: (token: string | null) => void): () => void {
    this.listeners.add(cb);
    return () => this.listeners.delete(cb);
  }
}

function safeGet(storage: KeyValueStore | null): string | null {
  try {
    return storage?.getItem(KEY)?.trim() || null;
  } catch {
    return null;
  }
}
