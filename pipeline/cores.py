"""One core for the vision: OpenCV's and the BLAS's thread pools cut to one thread.

The pipeline's matrix products are small. A BLAS that spreads them over every core
spends more time waiting for its threads than computing when the machine is busy: the
shape match of a cluttered frame (120 x 1600 by 1600 x 670) took 70-300 ms with two
threads against 15-35 ms with one, on this project's 2-core machine under load.
"""

from __future__ import annotations

import cv2
from threadpoolctl import threadpool_limits


def use_one_core() -> None:
    """For the whole process: OpenCV and the BLAS (numpy's products) on one thread."""
    cv2.setNumThreads(1)
    threadpool_limits(1, user_api="blas")
