"""Shapes the pipeline's tests draw."""

from __future__ import annotations

import numpy as np

# An 'H' (3 wide, 5 tall, 1-wide bars), counter-clockwise in math axes: 12 corners,
# 8 convex (90) and 4 concave (270).
H_OUTLINE = np.array(
    [
        (0, 0),
        (1, 0),
        (1, 2),
        (2, 2),
        (2, 0),
        (3, 0),
        (3, 5),
        (2, 5),
        (2, 3),
        (1, 3),
        (1, 5),
        (0, 5),
    ],
    float,
)
