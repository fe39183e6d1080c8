"""Visland's vision pipeline: pure functions from a frame to the pad's pose.

``from pipeline import Camera, Reference, process_frame``
"""

from pipeline.camera import Camera
from pipeline.frame import process_frame
from pipeline.reference import Reference
from pipeline.result import FrameResult, Pose

__all__ = ["Camera", "FrameResult", "Pose", "Reference", "process_frame"]
