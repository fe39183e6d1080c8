"""Your own pad in the benches' scenes: a design drawn from a top-down picture of it.

The registered designs (`pipeline.render.DESIGNS`) are drawn from shapes; a user's pad
is a picture (the one uploaded as the station's reference, a rectified photo or a
drawing). ``python -m pipeline.bench --picture FILE --size M`` lays that picture on the
bench's floors, beside look-alikes painted in its H's colour and sized like its H, and
measures it as the bench measures a registered design (with ``--sweep``, how far away
and how tilted it is still found).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.picture import read_picture
from pipeline.reference import Reference
from pipeline.render import Design, DesignPicture, Scene, get_design, make_scene

TEXTURE_PX = 1024  # a larger picture is laid on the floor shrunk to this many pixels across


@dataclass(frozen=True, eq=False)
class PictureDesign:
    """What the benches ask of a design (as `pipeline.render.Design` answers it), for a
    pad known by its picture: ``image`` (BGR, top-down, cropped to the pad) ``size_m``
    wide; its H's 12 corners (pad metres), its paint's colour and whether the pad looks
    the same turned half round, as `Reference.from_image` reads them from the picture."""

    name: str
    image: np.ndarray
    size_m: float
    h_corners_m: np.ndarray
    h_size_m: float  # the H's extent (the larger of its width and height), metres
    h_bgr: tuple[float, float, float]
    symmetric: bool
    floors: tuple[str, ...] | None = None  # (any floor the bench lays pads on)

    @property
    def description(self) -> str:
        return f"the pad of the picture {self.name} ({self.size_m:g} m wide)"

    def draw(self, size_px: int | None = None) -> DesignPicture:
        """The picture (``size_px`` wide, its aspect kept), as `Design.draw` draws a design."""
        image = self.image if size_px is None else _to_width(self.image, int(size_px))
        return DesignPicture(image, None, self.size_m, self.h_corners_m, self.symmetric)

    def scene(
        self,
        rng: np.random.Generator | int,
        *,
        floor: str = "textured",
        lookalikes: int = 0,
        pad_visible: bool = True,
    ) -> Scene:
        """`make_scene` with the picture as the pad (see `Design.scene`)."""
        return make_scene(
            self.image,
            self.size_m,
            rng=rng,
            floor=floor,
            lookalikes=lookalikes,
            pad_visible=pad_visible,
            lookalike_bgr=self.h_bgr,
            h_size_m=self.h_size_m,
        )


PadDesign = Design | PictureDesign


def picture_design(path: str | Path, size_m: float) -> PictureDesign:
    """The design of the pad pictured in the file at ``path``, ``size_m`` wide; ValueError
    (saying why) when the file is no picture or no pad's H is found on it."""
    if not (isinstance(size_m, int | float) and np.isfinite(size_m) and size_m > 0):
        raise ValueError(f"the pad's size must be a positive number of metres, got {size_m!r}")
    image = read_picture(path)
    if image.shape[1] > TEXTURE_PX:
        image = _to_width(image, TEXTURE_PX)
    try:
        reference = Reference.from_image(image, float(size_m))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    return PictureDesign(
        name=f"picture:{Path(path).name}",
        image=image,
        size_m=float(size_m),
        h_corners_m=reference.corners_m.copy(),
        h_size_m=reference.h_size_m,
        h_bgr=reference.paint_bgr,
        symmetric=reference.symmetric,
    )


def _to_width(image: np.ndarray, width: int) -> np.ndarray:
    """``image`` resized to ``width`` pixels across, its aspect kept."""
    h, w = image.shape[:2]
    return cv2.resize(image, (width, max(1, round(width * h / w))), interpolation=cv2.INTER_AREA)


def design_of(design: str | PadDesign) -> PadDesign:
    """A registered design by its name, or the design given."""
    return get_design(design) if isinstance(design, str) else design
