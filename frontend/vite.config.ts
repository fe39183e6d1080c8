// Vite builds the dashboard into dist/, which the server serves at /.
// In development (`npm run dev`) API and WebSocket calls go to a server on :8000.
import { defineConfig } from "vitest/config";

const server = process.env.VISLAND_SERVER ?? "http://127.0.0.1:8000";

export default defineConfig({
  base: "./",
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
