"""Line charts drawn with OpenCV (no plotting library): panels stacked into a PNG."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

PALETTE = [(200, 90, 30), (40, 140, 40), (40, 40, 200), (150, 60, 150), (20, 150, 200)]
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_INK = (40, 40, 40)
_GRID = (225, 225, 225)

Series = dict[str, tuple[Sequence[float], Sequence[float | None]]]


def nice_ticks(lo: float, hi: float, count: int = 6) -> list[float]:
    """Round tick values (steps of 1, 2 or 5 times a power of ten) covering [lo, hi].

    >>> nice_ticks(0.0, 1.0)
    [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    """
    if not math.isfinite(lo) or not math.isfinite(hi) or hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / max(count - 1, 1)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    start = math.floor(lo / step + 1e-9) * step
    ticks = []
    v = start
    while v <= hi + step * 1e-6:
        ticks.append(round(v, 10))
        v += step
    return ticks


def _label(v: float) -> str:
    return f"{v:g}" if abs(v) < 1e5 else f"{v:.0e}"


def line_panel(
    series: Series,
    *,
    title: str,
    xlabel: str,
    ylabel: str,
    ylim: tuple[float, float] | None = None,
    log_y: bool = False,
    hlines: Sequence[tuple[float, str]] = (),
    size: tuple[int, int] = (760, 340),
) -> np.ndarray:
    """One chart: a line with markers per series (None values leave gaps), a legend."""
    w, h = size
    left, right, top, bottom = 70, 150, 34, 46
    img = np.full((h, w, 3), 255, np.uint8)
    xs_all = [float(x) for xs, _ in series.values() for x in xs]
    ys_all = [float(y) for _, ys in series.values() for y in ys if y is not None]
    if log_y:  # zeros and negatives have no place on a log axis (they leave gaps)
        ys_all = [y for y in ys_all if y > 0]
    ys_all += [v for v, _ in hlines]
    fy = (lambda v: math.log10(max(v, 1e-12))) if log_y else (lambda v: v)
    x0, x1 = (min(xs_all), max(xs_all)) if xs_all else (0.0, 1.0)
    if ylim is not None:
        y0, y1 = fy(ylim[0]), fy(ylim[1])
    elif ys_all:
        y0, y1 = min(map(fy, ys_all)), max(map(fy, ys_all))
        if not log_y:
            y0 = min(y0, 0.0)
    else:
        y0, y1 = 0.0, 1.0
    if x1 <= x0:
        x1 = x0 + 1.0
    if y1 <= y0:
        y1 = y0 + 1.0
    if ylim is None:  # a margin so that no point sits on the frame
        pad = 0.06 * (y1 - y0)
        y0, y1 = (y0 if y0 == 0.0 and not log_y else y0 - pad), y1 + pad
    pw, ph = w - left - right, h - top - bottom

    def to_px(x: float, y: float) -> tuple[int, int]:
        u = left + (x - x0) / (x1 - x0) * pw
        v = top + ph - (fy(y) - y0) / (y1 - y0) * ph
        return round(u), round(min(max(v, top - 4), top + ph + 4))

    for t in nice_ticks(x0, x1):
        if x0 - 1e-9 <= t <= x1 + 1e-9:
            u = to_px(t, 10**y0 if log_y else y0)[0]
            cv2.line(img, (u, top), (u, top + ph), _GRID, 1)
            cv2.putText(img, _label(t), (u - 12, top + ph + 18), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    if log_y:  # decades, and 2 and 5 times them when the axis spans few decades
        steps = (1, 2, 5) if y1 - y0 < 2.5 else (1,)
        decades = range(math.floor(y0), math.ceil(y1) + 1)
        yticks = [m * 10.0**k for k in decades for m in steps]
    else:
        yticks = nice_ticks(y0, y1)
    for t in yticks:
        if y0 - 1e-9 <= fy(t) <= y1 + 1e-9:
            v = to_px(x0, t)[1]
            cv2.line(img, (left, v), (left + pw, v), _GRID, 1)
            cv2.putText(img, _label(t), (4, v + 4), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    cv2.rectangle(img, (left, top), (left + pw, top + ph), _INK, 1)
    for value, name in hlines:
        v = to_px(x0, value)[1]
        cv2.line(img, (left, v), (left + pw, v), (120, 120, 120), 1, cv2.LINE_AA)
        cv2.putText(img, name, (left + 4, v - 4), _FONT, 0.4, (90, 90, 90), 1, cv2.LINE_AA)
    for k, (name, (xs, ys)) in enumerate(series.items()):
        colour = PALETTE[k % len(PALETTE)]
        run: list[tuple[int, int]] = []
        for x, y in zip(xs, ys, strict=True):
            if y is None or (log_y and y <= 0):
                if len(run) > 1:
                    cv2.polylines(img, [np.array(run)], False, colour, 2, cv2.LINE_AA)
                run = []
                continue
            p = to_px(float(x), float(y))
            run.append(p)
            cv2.circle(img, p, 3, colour, -1, cv2.LINE_AA)
        if len(run) > 1:
            cv2.polylines(img, [np.array(run)], False, colour, 2, cv2.LINE_AA)
        ly = top + 16 + 20 * k
        cv2.line(img, (w - right + 12, ly - 4), (w - right + 36, ly - 4), colour, 2, cv2.LINE_AA)
        cv2.putText(img, name, (w - right + 42, ly), _FONT, 0.45, _INK, 1, cv2.LINE_AA)
    cv2.putText(img, title, (left, 22), _FONT, 0.55, _INK, 1, cv2.LINE_AA)
    cv2.putText(img, xlabel, (left + pw // 2 - 40, h - 10), _FONT, 0.45, _INK, 1, cv2.LINE_AA)
    cv2.putText(img, ylabel, (w - right + 12, top + ph), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    return img


def scatter_panel(
    groups: dict[str, np.ndarray],
    *,
    title: str,
    xlabel: str,
    ylabel: str,
    size: tuple[int, int] = (520, 480),
) -> np.ndarray:
    """Points (N x 2 per group), equal axes, a legend."""
    w, h = size
    left, right, top, bottom = 60, 140, 34, 46
    img = np.full((h, w, 3), 255, np.uint8)
    pts = np.vstack([g for g in groups.values() if len(g)]) if groups else np.zeros((0, 2))
    lo = pts.min(axis=0) if len(pts) else np.zeros(2)
    hi = pts.max(axis=0) if len(pts) else np.ones(2)
    span = float(max((hi - lo).max(), 1e-9)) * 1.1
    mid = (lo + hi) / 2
    pw, ph = w - left - right, h - top - bottom
    s = min(pw, ph) / span

    def to_px(p: np.ndarray) -> tuple[int, int]:
        return round(left + pw / 2 + (p[0] - mid[0]) * s), round(top + ph / 2 - (p[1] - mid[1]) * s)

    cv2.rectangle(img, (left, top), (left + pw, top + ph), _INK, 1)
    for k, (name, g) in enumerate(groups.items()):
        colour = PALETTE[k % len(PALETTE)]
        for p in g:
            cv2.circle(img, to_px(p), 2, colour, -1, cv2.LINE_AA)
        ly = top + 16 + 20 * k
        cv2.circle(img, (w - right + 20, ly - 4), 4, colour, -1, cv2.LINE_AA)
        cv2.putText(img, name, (w - right + 32, ly), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    cv2.putText(img, title, (left, 22), _FONT, 0.55, _INK, 1, cv2.LINE_AA)
    cv2.putText(img, xlabel, (left + pw // 2 - 30, h - 10), _FONT, 0.45, _INK, 1, cv2.LINE_AA)
    cv2.putText(img, ylabel, (4, top - 6), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    return img


def save(path: str | Path, panels: Sequence[np.ndarray]) -> str:
    """Stack panels vertically (padded to the widest) and write a PNG; returns the path."""
    width = max(p.shape[1] for p in panels)
    white = (255, 255, 255)
    rows = [
        cv2.copyMakeBorder(p, 0, 0, 0, width - p.shape[1], cv2.BORDER_CONSTANT, value=white)
        for p in panels
    ]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), np.vstack(rows)):
        raise ValueError(f"plot: cannot write {path}")
    return str(path)
