import { describe, expect, it } from "vitest";
import { extractToken, type KeyValueStore, TokenKeeper } from "../../src/lib/token";

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

describe("extractToken", () => {
  it("takes the token from the query and removes it", () => {
    expect(extractToken("http://127.0.0.1:8000/?token=abc123xyz&x=1")).toEqual({
      token: "abc123xyz",
      cleaned: "http://127.0.0.1:8000/?x=1",
    });
  });

  it("takes the token from the hash", () => {
    expect(extractToken("http://h/#token=zzz&tab=3")).toEqual({ token: "zzz", cleaned: "http://h/#tab=3" });
    expect(extractToken("http://h/#token=zzz")).toEqual({ token: "zzz", cleaned: "http://h/" });
  });

  it("gives null when there is none or it is blank", () => {
    expect(extractToken("http://h/?a=1")).toEqual({ token: null, cleaned: "http://h/?a=1" });
    expect(extractToken("http://h/?token=%20").token).toBeNull();
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
