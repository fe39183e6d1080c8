// The view cookie: with the token, the dashboard asks the server for a cookie that lets
// this browser's pictures and the 3D view (an <img>, an <iframe>: they cannot send the
// token) be seen while viewing needs the token. The cookie is not the token, is
// HttpOnly and SameSite=Strict, and never commands anything.

import { ApiError } from "./api";
import type { TokenKeeper } from "./token";

/** Something that can POST to the API with the token (the ApiClient). */
export interface SessionApi {
  request<T>(method: string, path: string, body?: unknown): Promise<T>;
}

/** Ask for a view cookie now (when there is a token) and whenever a new token is set. */
export function keepViewCookie(tokens: TokenKeeper, api: SessionApi): void {
  const open = (): void => {
    if (!tokens.get()) return;
    api.request("POST", "/api/session").catch((error: unknown) => {
      if (error instanceof ApiError && error.status === 401) {
        tokens.markRefused();
        document.dispatchEvent(new CustomEvent("visland:need-token"));
      }
      // other failures (server away): the next token change or reload tries again
    });
  };
  open();
  tokens.onChange(open);
}
