import { describe, expect, it } from "vitest";
import { type KeyValueStore, TokenKeeper, withoutTokenInAddress } from "../../src/lib/token";

class MemoryStore implements KeyValueStore {
  data = new Map<string, string>();
  getItem(k: string) {
    return this.data.get(k) ?? null;
  }
  setItem(k: string, v: string) {
    this.data.set(k, v);
  }
  removeItem(k: string) {
    this.data.delete(k);
  }
}

describe("withoutTokenInAddress", () => {
  it("removes a token from the query, never handing it out", () => {
    expect(withoutTokenInAddress("http://127.0.0.1:8000/?token=abc123xyz&x=1")).toBe("http://127.0.0.1:8000/?x=1");
    expect(withoutTokenInAddress("http://h/?TOKEN=a")).toBe("http://h/");
  });

  it("removes a token from the hash", () => {
    expect(withoutTokenInAddress("http://h/#token=zzz&tab=3")).toBe("http://h/#tab=3");
    expect(withoutTokenInAddress("http://h/#token=zzz")).toBe("http://h/");
  });

  it("gives null when there is none", () => {
    expect(withoutTokenInAddress("http://h/?a=1#b=2")).toBeNull();
    expect(withoutTokenInAddress("http://h/")).toBeNull();
  });
});

describe("TokenKeeper", () => {
  it("keeps the token in storage", () => {
    const store = new MemoryStore();
    const k = new TokenKeeper(store);
    expect(k.get()).toBeNull();
    k.set("  secret-1  ");
    expect(k.get()).toBe("secret-1");
    expect(new TokenKeeper(store).get()).toBe("secret-1");
    k.set("");
    expect(k.get()).toBeNull();
    expect(store.data.size).toBe(0);
  });

  it("stops offering a refused token until a new one is set, and tells listeners", () => {
    const k = new TokenKeeper(new MemoryStore());
    const seen: (string | null)[] = [];
    k.onChange((t) => seen.push(t));
    k.set("old-token");
    k.markRefused();
    expect(k.get()).toBe("old-token");
    expect(k.usable()).toBeNull();
    expect(k.isRefused).toBe(true);
    k.set("new-token");
    expect(k.usable()).toBe("new-token");
    expect(k.isRefused).toBe(false);
    expect(seen).toEqual(["old-token", "new-token"]);
  });

  it("works for this page when storage throws", () => {
    const broken: KeyValueStore = {
      getItem: () => {
        throw new Error("denied");
      },
      setItem: () => {
        throw new Error("denied");
      },
      removeItem: () => {
        throw new Error("denied");
      },
    };
    const k = new TokenKeeper(broken);
    expect(k.get()).toBeNull();
    k.set("abc");
    expect(k.get()).toBe("abc");
    expect(new TokenKeeper(null).get()).toBeNull();
  });
});
