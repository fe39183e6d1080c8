"""The attitude hint a vehicle would give: gravity in the camera frame, a little off.

ArduCopter's attitude estimate and a camera mount's calibration are good to
about half a degree each; the hint is the truth turned by ``noise_deg`` about a
random axis, seeded per frame so that every detector run sees the same one.
"""

from __future__ import annotations

import numpy as np

NOISE_DEG = 0.7  # attitude estimate and mount together, one standard deviation


def gravity_hint(R_pad_cam: np.ndarray, seed: list[int], noise_deg: float = NOISE_DEG):
    """Down in the camera frame for a camera at ``R_pad_cam`` over a level pad, with noise.

    >>> g = gravity_hint(np.eye(3) @ np.diag([1.0, -1.0, -1.0]), [0, 1], noise_deg=0.0)
    >>> g.round(6).tolist()
    [0.0, 0.0, 1.0]
    """
    down = np.asarray(R_pad_cam, float).T @ np.array([0.0, 0.0, -1.0])
    rng = np.random.default_rng(seed)
    tilt = np.radians(noise_deg) * rng.standard_normal(2)
    # Lean the vector by the two small angles, across it.
    a = np.cross(down, [1.0, 0.0, 0.0])
    if np.linalg.norm(a) < 0.1:
        a = np.cross(down, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(down, a)
    g = down + tilt[0] * a + tilt[1] * b
    return g / np.linalg.norm(g)
