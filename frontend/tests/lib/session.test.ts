import { describe, expect, it } from "vitest";
import { ApiError } from "../../src/lib/api";
import { keepViewCookie, type SessionApi } from "../../src/lib/session";
import { TokenKeeper } from "../../src/lib/token";

class FakeApi implements SessionApi {
  calls: string[] = [];
  constructor(private readonly status: number) {}
  request<T>(method: string, path: string): Promise<T> {
    this.calls.push(`${method} ${path}`);
    if (this.status === 200) return Promise.resolve({ view_cookie: true } as T);
    return Promise.reject(new ApiError(this.status, "The operator token is wrong; nothing was done."));
  }
}

const settle = () => new Promise((resolve) => setTimeout(resolve, 0));

describe("keepViewCookie", () => {
  it("asks for a view cookie when there is a token, and again for each new one", async () => {
    const tokens = new TokenKeeper(null);
    const api = new FakeApi(200);
    keepViewCookie(tokens, api);
    expect(api.calls).toEqual([]); // no token yet: nothing asked
    tokens.set("first-token");
    tokens.set("second-token");
    await settle();
    expect(api.calls).toEqual(["POST /api/session", "POST /api/session"]);
  });

  it("a refused token is offered no more until a new one is set", async () => {
    const tokens = new TokenKeeper(null);
    const api = new FakeApi(401);
    (globalThis as { document?: unknown }).document ??= { dispatchEvent: () => true };
    keepViewCookie(tokens, api);
    tokens.set("wrong-token");
    await settle();
    expect(tokens.usable()).toBeNull();
    expect(tokens.isRefused).toBe(true);
  });
});
