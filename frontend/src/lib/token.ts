// The operator token: taken once from the page URL (?token= or #token=, then removed
// from the address bar so it is not left in the history) and kept in localStorage.

export interface KeyValueStore {
  getItem(key: string): string | null;
  setItem(key: string, value: string): void;
  removeItem(key: string): void;
}

const KEY = "visland.token";

/** Pull a token out of a URL; returns it and the URL without it. */
export function extractToken(href: string): { token: string | null; cleaned: string } {
  const url = new URL(href);
  let token = url.searchParams.get("token");
  if (token !== null) url.searchParams.delete("token");
  if (url.hash.startsWith("#")) {
    const hash = new URLSearchParams(url.hash.slice(1));
    const fromHash = hash.get("token");
    if (fromHash !== null) {
      token = token ?? fromHash;
      hash.delete("token");
      const rest = hash.toString();
      url.hash = rest ? `#${rest}` : "";
    }
  }
  token = token?.trim() || null;
  return { token, cleaned: url.toString() };
}

export class TokenKeeper {
  private value: string | null;

  constructor(private readonly storage: KeyValueStore | null) {
    this.value = safeGet(storage);
  }

  get(): string | null {
    return this.value;
  }

  set(token: string | null): void {
    const clean = token?.trim() || null;
    this.value = clean;
    try {
      if (clean) this.storage?.setItem(KEY, clean);
      else this.storage?.removeItem(KEY);
    } catch {
      // storage may be disabled (private mode): the token stays for this page only
    }
  }
}

function safeGet(storage: KeyValueStore | null): string | null {
  try {
    return storage?.getItem(KEY) ?? null;
  } catch {
    return null;
  }
}
