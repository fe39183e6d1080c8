// Vite builds the dashboard into dist/, which the server serves at /.
// In development (`npm run dev`) API and WebSocket calls go to a server on :8000.
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import type { Plugin } from "vite";
import { defineConfig } from "vitest/config";

// The API docs (/docs, /redoc) must work offline: their scripts and styles come from
// the pinned npm packages, copied into dist/docs-assets/ and served by the station.
const require = createRequire(import.meta.url);
const DOCS_ASSETS: [string, string][] = [
  ["swagger-ui-dist/swagger-ui-bundle.js", "swagger-ui-bundle.js"],
  ["swagger-ui-dist/swagger-ui.css", "swagger-ui.css"],
  ["swagger-ui-dist/favicon-32x32.png", "favicon-32x32.png"],
  ["redoc/bundles/redoc.standalone.js", "redoc.standalone.js"],
];

const REDOC_LOGO_CDN = "https://cdn.redoc.ly/redoc/logo-mini.svg";
const REDOC_LOGO =
  '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 16 16"><rect width="16" height="16" rx="3" fill="#0ea5e9"/></svg>';

function docsAssets(): Plugin {
  return {
    name: "visland-docs-assets",
    apply: "build",
    generateBundle() {
      for (const [from, name] of DOCS_ASSETS) {
        let source: string | Buffer = readFileSync(require.resolve(from));
        if (name === "redoc.standalone.js") {
          // ReDoc's footer logo is the one thing it fetches from a CDN: ours instead.
          source = source.toString("utf8").replaceAll(REDOC_LOGO_CDN, "/docs-assets/redoc-logo.svg");
        }
        this.emitFile({ type: "asset", fileName: `docs-assets/${name}`, source });
      }
      this.emitFile({ type: "asset", fileName: "docs-assets/redoc-logo.svg", source: REDOC_LOGO });
    },
  };
}

const server = process.env.VISLAND_SERVER ?? "http://127.0.0.1:8000";

export default defineConfig({
  base: "./",
  plugins: [docsAssets()],
  build: {
    outDir: "dist",
    emptyOutDir: true,
    target: "es2022",
    sourcemap: true,
  },
  server: {
    host: "127.0.0.1",
    proxy: {
      "/api": server,
      "/ws": { target: server.replace(/^http/, "ws"), ws: true },
    },
  },
  test: {
    include: ["tests/**/*.test.ts"],
    environment: "node",
    testTimeout: 5000,
  },
});
