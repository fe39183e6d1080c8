"""An H ringed in its own paint, cut from its ring where the blur joined them.

From afar the gap between an H's tips and the ring around it (the ICAO circle's
0.25 m; a white ring on an orange disc) blurs shut: the threshold makes the two one
region, round, that no H's shape matches. Where a reference's H has such a ring
(`Reference.ring_cut`), each round region of the mask is cut at the radius between
the H's tips and the ring's inside (the region's ellipse scaled down to it), and
what of that region lies within is offered as a candidate of its own. The cut
clips nothing of an H that far: its sides are then fitted to the channel's edges as
any candidate's are.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.reference import Reference
from pipeline.shapes import Region, ellipse_misfit

MIN_RING_SOLIDITY = 0.9  # a ring's outline encloses its inside: a round, solid region
MAX_RING_MISFIT = 0.1  # 90 % of its outline this near its ellipse (of its radius)
MIN_CUT_SPAN_PX = 8.0  # the H cut out at least this wide (`candidates.MIN_H_SPAN_PX`)


def cut_from_rings(found: list[Region], mask: np.ndarray, reference: Reference) -> list[Region]:
    """The H's cut from the rings among ``found`` (regions of ``mask``), where a ring
    holds one joined to it; none where ``reference`` has no ring around its H."""
    cut = reference.ring_cut
    if cut is None:
        return []
    out = []
    for region in found:
        if region.span * cut < MIN_CUT_SPAN_PX or region.solidity < MIN_RING_SOLIDITY:
            continue
        inner = _cut(region, mask, cut)
        if inner is not None:
            out.append(inner)
    return out


def _cut(region: Region, mask: np.ndarray, cut: float) -> Region | None:
    """What of ``region`` lies within its ellipse scaled by ``cut``: its largest part
    there, when the region is round and that part is joined to its ring."""
    outline = region.contour.reshape(-1, 1, 2).astype(np.float32)
    if len(outline) < 5:
        return None
    ellipse = cv2.fitEllipse(outline)
    if ellipse_misfit(region.contour, ellipse) > MAX_RING_MISFIT:
        return None
    x, y, w, h = region.box
    patch = mask[y : y + h, x : x + w]
    # (the region's own pixels: the mask's part its outline bounds, traced from it)
    _, labels = cv2.connectedComponents((patch > 0).astype(np.uint8), connectivity=8)
    px, py = region.contour[0] - (x, y)
    own = labels == labels[py, px]
    (cx, cy), (a, b), angle = ellipse
    within = np.zeros(patch.shape, np.uint8)
    cv2.ellipse(within, ((cx - x, cy - y), (a * cut, b * cut), angle), 1, thickness=-1)
    inner = (own & (within > 0)).astype(np.uint8)
    if not inner.any():
        return None  # (the ring alone: an H inside is a region of its own)
    contours, _ = cv2.findContours(inner, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    largest = max(contours, key=cv2.contourArea)
    area = float(cv2.contourArea(largest))
    if area <= 0:
        return None
    # (positively oriented, as `shapes.regions` gives them)
    pts = largest.reshape(-1, 2)
    if cv2.contourArea(largest, oriented=True) < 0:
        pts = pts[::-1]
    return Region(pts + np.array([x, y], np.int32), area)
