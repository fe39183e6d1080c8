// Attitude indicator (artificial horizon): sky/ground split rotated by roll and
// shifted by pitch, a pitch ladder every 10 degrees, a roll scale and the heading.

import { COLORS } from "./dom";

export function drawAttitude(
  g: CanvasRenderingContext2D,
  size: number,
  rollDeg: number | null,
  pitchDeg: number | null,
  headingDeg: number | null,
): void {
  const r = size / 2;
  g.save();
  g.clearRect(0, 0, size, size);
  g.beginPath();
  g.arc(r, r, r - 2, 0, Math.PI * 2);
  g.clip();
  const known = rollDeg !== null && pitchDeg !== null;
  const roll = ((rollDeg ?? 0) * Math.PI) / 180;
  const pitch = pitchDeg ?? 0;
  const pxPerDeg = size / 80; // +-40 degrees of pitch visible
  g.translate(r, r);
  g.rotate(-roll);
  g.translate(0, pitch * pxPerDeg);
  g.fillStyle = known ? "#1e5a8a" : "#2a3340";
  g.fillRect(-size * 2, -size * 4, size * 4, size * 4);
  g.fillStyle = known ? "#6b4226" : "#222a33";
  g.fillRect(-size * 2, 0, size * 4, size * 4);
  g.strokeStyle = "#e5e7eb";
  g.lineWidth = 2;
  g.beginPath();
  g.moveTo(-size * 2, 0);
  g.lineTo(size * 2, 0);
  g.stroke();
  g.lineWidth = 1;
  g.font = `${Math.max(8, Math.round(size / 22))}px ui-monospace, monospace`;
  g.fillStyle = "#e5e7eb";
  g.textBaseline = "middle";
  for (let p = -30; p <= 30; p += 10) {
    if (p === 0) continue;
    const y = -p * pxPerDeg;
    const half = (Math.abs(p) % 20 === 0 ? 0.22 : 0.14) * size;
    g.beginPath();
    g.moveTo(-half, y);
    g.lineTo(half, y);
    g.stroke();
    g.fillText(String(p), half + 4, y);
  }
  g.restore();

  // roll scale and pointer (fixed to the aircraft)
  g.save();
  g.translate(r, r);
  g.strokeStyle = "#e5e7eb";
  g.lineWidth = 1.5;
  for (const a of [-60, -45, -30, -20, -10, 0, 10, 20, 30, 45, 60]) {
    const t = ((a - 90) * Math.PI) / 180;
    const inner = r - (a % 30 === 0 ? 14 : 9);
    g.beginPath();
    g.moveTo(Math.cos(t) * inner, Math.sin(t) * inner);
    g.lineTo(Math.cos(t) * (r - 3), Math.sin(t) * (r - 3));
    g.stroke();
  }
  g.rotate(-roll);
  g.fillStyle = COLORS.warn;
  g.beginPath();
  g.moveTo(0, -r + 15);
  g.lineTo(-6, -r + 25);
  g.lineTo(6, -r + 25);
  g.closePath();
  g.fill();
  g.restore();

  // aircraft symbol
  g.save();
  g.translate(r, r);
  g.strokeStyle = COLORS.warn;
  g.lineWidth = 3;
  g.beginPath();
  g.moveTo(-size * 0.3, 0);
  g.lineTo(-size * 0.1, 0);
  g.lineTo(-size * 0.05, size * 0.05);
  g.moveTo(size * 0.3, 0);
  g.lineTo(size * 0.1, 0);
  g.lineTo(size * 0.05, size * 0.05);
  g.stroke();
  g.fillStyle = COLORS.warn;
  g.fillRect(-2, -2, 4, 4);
  g.restore();

  // heading
  g.save();
  g.fillStyle = "rgba(0,0,0,0.6)";
  g.fillRect(r - 26, size - 22, 52, 16);
  g.fillStyle = "#e5e7eb";
  g.font = "11px ui-monospace, monospace";
  g.textAlign = "center";
  g.textBaseline = "middle";
  g.fillText(headingDeg === null ? "HDG —" : `${String(((Math.round(headingDeg) % 360) + 360) % 360).padStart(3, "0")}°`, r, size - 14);
  g.restore();
  g.beginPath();
  g.arc(r, r, r - 1.5, 0, Math.PI * 2);
  g.strokeStyle = "#334155";
  g.lineWidth = 2;
  g.stroke();
  if (!known) {
    g.fillStyle = COLORS.muted;
    g.font = "12px system-ui, sans-serif";
    g.textAlign = "center";
    g.fillText("no attitude", r, r - 20);
    g.textAlign = "left";
  }
}
