"""Finding the pad's H in one view: candidates, their homographies, and the checks.

Every located H (``pipeline.candidates``) must then be clearly an H on a plain
board (edge support and shape overlap, the region against the band around
it), look like the reference picture around it (pattern and board), have no
stroke cut through, and pass the optional verifier. Those that do are offered
best shape first; the first whose pose can be measured is the pad's.
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from pipeline.camera import Camera
from pipeline.candidates import (
    MAX_LOCATED,
    MIN_BLOB_SEPARATION,
    MIN_EVIDENCE,
    MIN_FRAMED_EVIDENCE,
    MIN_H_AREA_PX,
    Located,
    blob_separation,
    candidates,
    locate,
)
from pipeline.homography_fit import apply_h, span_of
from pipeline.measure import MIN_MARKS_FOUND, pad_box_m, pad_marks
from pipeline.preprocess import Binarized
from pipeline.reference import Reference
from pipeline.ring_cut import cut_from_rings
from pipeline.shapes import Region, regions
from pipeline.strokes import MAX_NOTCH_FILL, cut_through, notch_fill, stroke_samples
from pipeline.template import compare, pad_pattern, pattern_box

MIN_TEMPLATE_NCC = 0.4  # with the reference picture around the H
BOARD_TOLERANCE = 0.2  # the board's brightness relative to the H's, against the reference's
# ... and with the pattern this sure (NCC): on the bench's real-world mix, true pads in
# overexposed views came to NCC 0.97-0.99 and 0.23-0.35 off; look-alikes, to 0.95 at most.
SURE_NCC, SURE_BOARD_TOLERANCE = 0.97, 0.4
# An H seen only weakly counts with the rest of its pad found around it; where that
# rest is its board's outline alone (four straight sides), the outline found nearly
# whole. Texture, tiles and printed patterns offer straight edges in every direction,
# and the whole pad's fit bends to reach half of a rim's: on the shared negatives seen
# through the photos bench's degradations (carpet noise, a printed marker's squares),
# faint H's of 5-16 px found 0.50-0.74 of a rim around them and were taken for pads;
# the altitude sweep's thin pads at 7-20 m, their H's as faint, found 0.85-1.0 of theirs.
MIN_RIM_FOUND = 0.8
SMALL_H_PX = 14.0  # an H this small counts only with the rest of its pad found
# ... by its edges, or by the whole pad's pattern (NCC): on the bench's far views
# (10-20 m), true pads' came to 0.69-0.92 (most over 0.78), clear look-alikes' (an H's
# evidence over MIN_EVIDENCE) to 0.72 at most.
MIN_PAD_NCC = 0.78
# An H is told from a smaller H of the reference's by what lies around it, out to this
# share of its size, matching the one's surroundings better by this much.
LESSER_CONTEXT, LESSER_MARGIN = 0.5, 0.05
BARE_H_PX = 32.0  # the same for a dark H on a plain light board (`_framed_below_px`)
# Evidence (candidates.Located.evidence) at which an H needs no check that it stands out
# from its board: on the bench, no look-alike or texture reaching it stood out less than
# 5.5 (the check's bar: 3), while pads under a shadow's edge reached it standing out 1.5-2.8.
SURE_EVIDENCE = 1.6
MAX_HUE = 0.3  # the board's chromaticity, L1 distance to the reference's
# Paint this bright (of 255) may have clipped, losing up to a third of its light: its
# board may then read up to CLIPPED_GAIN times brighter against it than on the picture.
# On the bench's views overexposed by a gain of 1.2-1.8, 388 of 400 pads were found
# against 356 (the ICAO pad's dark board reads 0.3-0.45 of its clipped paint), and no
# empty view was taken; an H painted on grass at 0.69 is not the ICAO pad (0.27). The
# paint's median reads a little under 255 where a shadow, blur or JPEG lowers some of
# its pixels: 243-244 on the real-world mix's overexposed, shadowed views of ICAO pads.
SATURATED_LUMA, CLIPPED_GAIN = 240.0, 1.5
# Marks smaller than this (frame pixels, or pixels of the view that refused them) are
# judged in every view.
REJUDGE_BELOW_PX = 24.0
# A first look (a coarse view) looks at marks at least this wide (its pixels): on the
# altitude sweep's 640 x 480 frames at 9-16 m, the H's of 7-9 of its pixels it fitted
# and turned down cost it 3-8 ms a frame; those of 12 px and more at 7 m, it takes.
FIRST_LOOK_MIN_SPAN_PX = 10.0


class CandidateVerifier(Protocol):
    """Checks a candidate's corner pattern (``pipeline.learn.Verifier`` is one)."""

    def accepts(self, corners_px: np.ndarray, contour_px: np.ndarray, camera: Camera) -> bool: ...


@dataclass
class Tally:
    """What the checks turned down in a frame, for the reason when nothing is found,
    and where: a mark turned down is not judged again when another threshold or a
    finer view of the frame shows it alike (see `Tally.judged`)."""

    shapes: int = 0
    located: int = 0
    unclear: int = 0
    unlike: int = 0
    unframed: int = 0
    broken: int = 0
    rejected: int = 0
    turned_down: list[np.ndarray] = field(default_factory=list)  # frame boxes x0 y0 x1 y1
    # (evidence, frame box) of the small marks refused in a view that was not enlarged
    small_refused: list[tuple[float, np.ndarray]] = field(default_factory=list)
    # (frame box, view scale, threshold) of every mark judged: judged again on the same
    # pixels with the same threshold, it would be judged the same
    seen: list[tuple[np.ndarray, float, str]] = field(default_factory=list)

    def reason(self, polarity: str) -> str:
        """Why no pad was found; ``polarity``: the reference's (the shapes looked at
        are of the H's shade, "bright" or "dark")."""
        if not self.shapes:
            return "no H-like shape in view"
        if self.rejected:  # (a board's H too, found where no H was located)
            return f"the verifier rejected {self.rejected} H-shaped mark(s)"
        if not self.located:
            return f"no H among {self.shapes} {polarity} shape(s)"
        for count, why in (
            (self.unclear, "{} H-shaped mark(s), none clearly an H on a plain board"),
            (self.unlike, "{} H-shaped mark(s) that do not look like the reference picture"),
            (self.unframed, "{} H-shaped mark(s) without the pad's board around them"),
            (self.broken, "{} H-shaped mark(s) with a stroke cut through"),
        ):
            if count:
                return why.format(count)
        return f"{self.located} H-shaped mark(s), but no pad's edges around them"

    def judged(self, box: np.ndarray) -> bool:
        """Whether a mark in ``box`` (frame pixels) was turned down already.

        A mark large enough to judge at the resolution it was seen at is judged the
        same on another threshold's mask or a finer view: its fit and checks work on
        the frame's levels, not on the mask. Smaller marks are judged again (a finer
        view is what they need)."""
        if _size(box) < REJUDGE_BELOW_PX:
            return False
        return _near_any(box, self.turned_down, 0.08)

    def seen_alike(self, box: np.ndarray, scale: float, method: str) -> bool:
        """Whether a mark in ``box`` was judged already on a view of the same ``scale``
        thresholded the same way (a window enlarged around a small mark, then the
        whole frame enlarged alike)."""
        alike = [b for b, at, how in self.seen if how == method and math.isclose(at, scale)]
        return _near_any(box, alike, 0.08)

    def turn_down(self, box: np.ndarray, scale: float = 1.0) -> None:
        """A mark in ``box`` (frame pixels) refused on a view of ``scale`` (its pixels a
        frame pixel): not judged again where it spanned ``REJUDGE_BELOW_PX`` there (a
        1280 x 720 frame's H of 24-30 px, 12-15 on the working view, its strokes a
        pixel and a half, was refused there and never looked at again at the frame's
        own resolution, where it was clear)."""
        if _size(box) * scale >= REJUDGE_BELOW_PX:
            self.turned_down.append(box)

    def refused(self, box: np.ndarray, evidence: float, enlarged: float) -> None:
        """A located mark refused: kept for a closer look when it was small and seen
        at the frame's own resolution or coarser."""
        if enlarged <= 1.0 and _size(box) < REJUDGE_BELOW_PX:
            self.small_refused.append((evidence, box))

    def closer_looks(self, count: int, looked: list[np.ndarray] | None = None) -> list[np.ndarray]:
        """The boxes of up to ``count`` distinct small refused marks, the likeliest H's
        (best evidence) first, none of them where a box of ``looked`` (marks looked at
        closer already) lies; they are added to ``looked``."""
        looked = [] if looked is None else looked
        picked: list[np.ndarray] = []
        for _, box in sorted(self.small_refused, key=lambda e: -e[0]):
            if len(picked) == count:
                break
            if not _near_any(box, looked, 0.25):
                picked.append(box)
                looked.append(box)
        return picked


@dataclass
class Stages:
    """Wall time per stage, in milliseconds."""

    timings: dict[str, float] = field(default_factory=dict)
    t: float = field(default_factory=time.perf_counter)

    def lap(self, name: str) -> None:
        now = time.perf_counter()
        self.timings[name] = self.timings.get(name, 0.0) + (now - self.t) * 1e3
        self.t = now


def _size(box: np.ndarray) -> float:
    """A box's (x0 y0 x1 y1) larger side."""
    return float(max(box[2] - box[0], box[3] - box[1]))


def _near_any(box: np.ndarray, boxes: list[np.ndarray], fraction: float) -> bool:
    """Whether one of ``boxes`` lies where ``box`` does: each corner within ``fraction``
    of its size (1.5 px at least)."""
    reach = max(1.5, fraction * _size(box))
    return any(float(np.abs(box - b).max()) <= reach for b in boxes)


def search(
    image: np.ndarray,
    channel: np.ndarray,
    reference: Reference,
    camera: Camera,
    *,
    method: str,
    verifier: CandidateVerifier | None,
    tally: Tally,
    stages: Stages,
    to_frame: np.ndarray,
    tracking: bool = False,
    enlarged: float = 1.0,
    first_look: bool = False,
    holes: list[Region] | None = None,
) -> tuple[Binarized, list[Region], Iterator[Located]]:
    """The view's binarized channel, its regions of the H's polarity, and the pad's
    H's it holds, best shape first, found as they are asked for (the caller stops
    at the first it can measure).

    ``image``: the view's image (BGR); ``channel``: the image on the reference's
    channel (`pipeline.preprocess.to_channel`); ``to_frame``: view pixels -> frame pixels
    (a scale and a shift). ``tracking``: the view is the window where the pad was
    a moment ago: an H found there that is clearly an H is the pad (a look-alike
    does not take its place between two frames), so the comparisons with the
    reference picture, there to turn down look-alikes at first sight, are
    skipped. ``enlarged``: how many view pixels a frame pixel became (an
    interpolated view holds no more detail: an H's size counts in the frame's pixels).
    ``first_look``: a coarse view searched before the working view, which judges
    again whatever this one turns down (its marks' detail may have merged away).
    ``holes``: where the boundaries of the mask's holes are appended (for a board the
    threshold left whole, see `pipeline.board_search.find_boards`).
    """
    binary = reference.binarize(channel, method)
    stages.lap("preprocess")
    area = float(channel.shape[0] * channel.shape[1])
    found = regions(binary.mask, min_area=MIN_H_AREA_PX, max_area=0.5 * area, holes=holes)
    tally.shapes += len(found)
    stages.lap("contours")
    hits = functools.partial(_hits, image=image, binary=binary, reference=reference,
                             camera=camera, verifier=verifier, tally=tally, stages=stages,
                             to_frame=to_frame, tracking=tracking, enlarged=enlarged,
                             first_look=first_look, method=method)  # fmt: skip

    def cut_hits() -> Iterator[Located]:
        # Then an H the blur joined to its ring, cut from it (asked for only when the
        # regions as they are hold no H). Where the cut falls is the view's: an H refused
        # so is judged again on a finer view (icao_circle's at 91 m, fitted 1.30 on the
        # working view, 1.46 on the doubled one).
        yield from hits(cut_from_rings(found, binary.mask, reference), lasting=False)

    return binary, found, itertools.chain(hits(found), cut_hits())


def _hits(
    found: list[Region],
    image: np.ndarray,
    binary: Binarized,
    reference: Reference,
    camera: Camera,
    verifier: CandidateVerifier | None,
    tally: Tally,
    stages: Stages,
    to_frame: np.ndarray,
    tracking: bool,
    enlarged: float,
    first_look: bool,
    method: str,
    lasting: bool = True,
) -> Iterator[Located]:
    # (what a first look turns down is not recorded: the working view judges it again)
    tally = Tally() if first_look else tally
    scale = 1.0 / float(to_frame[0, 0])  # (view pixels a frame pixel)

    def turn_down(box: np.ndarray) -> None:
        # (not ``lasting``: regions that are the view's making, judged again on the next)
        if lasting:
            tally.turn_down(box, scale)

    if first_look:
        # A first look is for a near pad's large H: smaller marks are judged on the
        # working view all the same.
        found = [r for r in found if r.span >= FIRST_LOOK_MIN_SPAN_PX]
    for cand in candidates(found, reference, MAX_LOCATED):
        contour = cand.region.contour
        box = apply_h(to_frame, np.array([contour.min(axis=0), contour.max(axis=0)])).ravel()
        if tally.judged(box) or tally.seen_alike(box, scale, method):
            continue
        if not tracking:  # (a tracking window's checks are fewer)
            tally.seen.append((box, scale, method))
        hit = locate(cand, binary, reference)
        stages.lap("corners")
        if hit is None:
            turn_down(box)
            continue
        tally.located += 1
        verdict = _check(hit, image, binary, reference, full=not tracking, enlarged=enlarged)
        stages.lap("check")
        if verdict:
            setattr(tally, verdict, getattr(tally, verdict) + 1)
            if verdict != "unclear":  # (the region's own levels: another mask may differ)
                turn_down(box)
            tally.refused(box, hit.evidence, enlarged)
            continue
        if verifier is not None:
            # Fitted corners: what the verifier sees does not depend on the threshold.
            accepted = verifier.accepts(hit.corners, contour, camera)
            stages.lap("verify")
            if not accepted:
                tally.rejected += 1
                turn_down(box)
                tally.refused(box, hit.evidence, enlarged)
                continue
        yield hit
    stages.lap("corners")


def _check(
    hit: Located,
    image: np.ndarray,
    binary: Binarized,
    reference: Reference,
    *,
    full: bool,
    enlarged: float = 1.0,
) -> str:
    """The name of the failed check (a ``Tally`` field), or "" when the H passes;
    without ``full``, only whether it is clearly an H on a plain board."""
    if hit.evidence < MIN_FRAMED_EVIDENCE:
        return "unclear"
    # (how much of the rest of the pad is found around the H: asked at most once)
    marks = functools.cache(functools.partial(_marks_found_around, hit, binary, reference))
    # (and whether the whole pad's pattern is found around it: asked at most once too)
    pattern = functools.cache(functools.partial(_pattern_around, hit, binary, reference))

    def framed() -> bool:
        return marks() >= MIN_MARKS_FOUND

    def rim_framed() -> bool:  # (a board's outline alone: nearly whole, see below)
        return marks() >= (MIN_MARKS_FOUND if reference.painted_marks else MIN_RIM_FOUND)

    view_span = span_of(hit.corners)
    span = view_span / enlarged

    def vouched() -> bool:  # (the pad's marks vouch for an H not small: see below)
        return span >= REJUDGE_BELOW_PX and framed()

    # Whether the region stands out from the board around it tells paint from a
    # blob of texture; an H whose sides and shape match this well is no such blob,
    # nor is one with the rest of its pad around it (a shadow band across the pad
    # with a motion blur over thin strokes left real H's standing out by 1.6-2.9 on
    # the bench's real-world mix). Not a small one (``REJUDGE_BELOW_PX``): it is
    # judged again on a finer view, where its fit is finer (taken at the frame's own
    # resolution, the altitude sweep's 640 x 480 pads at 20 m came 2.14 % off
    # against 1.96 %).
    if hit.evidence < SURE_EVIDENCE:
        stroke = reference.leg_fraction * view_span
        H_inv = np.linalg.inv(hit.fit.H)
        blob = blob_separation(
            binary.smooth,
            hit.candidate.region,
            stroke,
            lambda px: ~reference.is_paint(apply_h(H_inv, px)),
        )
        if not blob >= MIN_BLOB_SEPARATION and not vouched():
            return "unclear"
    if hit.evidence < MIN_EVIDENCE:
        # Strokes of 2 px or a motion blur leave an H's own evidence short of
        # MIN_EVIDENCE; it still counts when the rest of its pad is found around it
        # (which a look-alike mark on the floor has not): a board's outline alone,
        # nearly whole (``MIN_RIM_FOUND``).
        if not rim_framed():
            return "unclear"
    elif span < _framed_below_px(reference) and not (rim_framed() or pattern()):
        # A few pixels of H-shaped texture are everywhere: so small, the H is the
        # pad's only where the rest of the pad (its rim, bars, rings) is found too:
        # its marks' edges, or (the marks a pixel or two wide, their edges merged)
        # the whole pad's pattern. A board's outline alone, as for a faint H, nearly
        # whole: in carpet noise (the photos bench's negative neg_111, seed 5) an
        # H-shaped speck of 6 px, evidence 1.47, found 0.71 of the plain board's rim
        # around it; no pad of the benches' was lost.
        return "unframed"
    if not full:
        return ""
    seen = compare(
        image,
        binary.smooth,
        reference.template_pyramid,
        reference.channel_px_per_m,
        reference.corners_m,
        hit.fit.H,
        enlarged,
    )
    # nan (a patch too small to compare, a board too dark for a hue) passes.
    if seen.ncc < MIN_TEMPLATE_NCC:
        return "unlike"
    # A pad whose picture holds smaller H's in its paint (the letter H of a "HELIPAD"
    # beside its H) shows one wherever its H is hidden or spoilt, on the same board,
    # and taken for the H it puts the pad several times too far. Its surroundings tell
    # it, the letters beside it: over its box grown by half its size, the pattern's
    # correlation read 0.67-0.76 as the pad's H, 0.90-0.97 as the letter; the pad's
    # own H's read 0.03-0.5 better as the H. On probe pads with text by their H
    # ("HELIPAD" under it, "HOSPITAL" over it, "HELI" in large letters), their H
    # erased, letters passed every check above in 6, 1 and 12 of 30 views of the
    # real-world mix (9, 0 and 0 of 30 clean), posed 4-9 times too far; so checked, in
    # 0, 0 and 1. The pads themselves were posed right in 27, 23 and 23 of those 30
    # views, against 26, 24 and 23. Smaller copies of the H on the plain board (one in
    # each of a probe pad's corners) have the H's surroundings: where the two read
    # alike, a copy counts as the H only with the pad's marks found around it so, the
    # pad wholly in view. Its H erased, copies were taken in 3 of 30 clean views and 5
    # of 30 of the mix, against 23 and 20 (those of under 16 px: the rim such a copy
    # puts its pad at lies a few pixels off the pad's own, and is found); the pad was
    # posed right in 30 and 26, against 30 and 24.
    if reference.lesser_hs and _lesser_h_likelier(hit, binary, reference, framed):
        return "unlike"
    # Light that saturates the paint lifts the board's level against it; a pattern
    # that matches the reference's almost exactly around the H vouches for the board,
    # and so do the pad's other marks found around an H not small (as above; on the
    # real-world mix, glare or an exposure error lifted serif_octagon pads' boards
    # 0.21-0.27 over the picture's, 95-100 % of their marks found; an H on a floor has
    # no such marks around it).
    off = seen.board - seen.reference_board
    sure = seen.ncc >= SURE_NCC
    clipped = seen.paint >= SATURATED_LUMA
    # (a board within its tolerance only once the paint's clipping is allowed for)
    excused = clipped and off > BOARD_TOLERANCE
    if clipped and off > 0:
        # Overexposed paint clips: brighter than it reads, it makes its board read
        # brighter against it than it is (by up to the light it lost).
        off = max(0.0, seen.board - CLIPPED_GAIN * seen.reference_board)
    if seen.hue > MAX_HUE or abs(off) > SURE_BOARD_TOLERANCE:
        return "unframed"
    if abs(off) > BOARD_TOLERANCE and not (sure or vouched()):
        return "unframed"
    # So excused, the board is no evidence: an H painted on a lighter floor reads the
    # same. A pad with marks besides its H shows them, or its pattern (a probe design,
    # a ring and letters around its H: an H of 16 px on concrete, paint at 241, passed
    # in 1 of 60 empty views; no bench design's pad, nor the photos', was lost).
    if excused and reference.painted_marks and not (sure or framed() or pattern()):
        return "unframed"
    return paint_verdict(image, reference, hit.fit.H)


def paint_verdict(image: np.ndarray, reference: Reference, H: np.ndarray) -> str:
    """Whether the H that ``H`` (pad metres -> pixels of the view ``image``) puts in
    view is painted as an H is (`pipeline.strokes`): "broken" when a stroke is cut
    through, "unlike" when its notches are painted, else ""."""
    weights = reference.projection.weights
    samples = stroke_samples(reference.corners_m, H, reference.is_paint)
    if cut_through(image, weights, samples):
        return "broken"
    if notch_fill(image, weights, reference.notches, H) > MAX_NOTCH_FILL:
        return "unlike"
    return ""


def _marks_found_around(hit: Located, binary: Binarized, reference: Reference) -> float:
    """The share of the pad's other marks found around the located H, its homography
    refitted on them (`pipeline.measure.pad_marks`; 0 when they were not found)."""
    return pad_marks(hit.fit.H, reference, binary.smooth, any_size=True)[1]


def _lesser_h_likelier(
    hit: Located, binary: Binarized, reference: Reference, framed: Callable[[], bool]
) -> bool:
    """Whether the H is likelier one of the reference's smaller H's (`Reference.lesser_hs`,
    in either reading) than its H: what lies around it matches the picture around that
    one better, by ``LESSER_MARGIN``; or matches both well (``MIN_PAD_NCC``), within the
    margin, and the pad's marks are not found around it as its H (``framed``), the pad
    wholly in view."""
    own = _context_ncc(hit.fit.H, binary, reference, reference.corners_m)
    for S in reference.lesser_h_maps:
        # (were the H that one, the pad would lie where H S^-1 puts it)
        pad = hit.fit.H @ np.linalg.inv(S)
        other = _context_ncc(pad, binary, reference, apply_h(S, reference.corners_m))
        if other > own + LESSER_MARGIN:  # (nan, either: too little in view to tell)
            return True
        alike = min(own, other) >= MIN_PAD_NCC and abs(other - own) <= LESSER_MARGIN
        if alike and _pad_in_view(hit.fit.H, binary, reference) and not framed():
            return True
    return False


def _pad_in_view(H: np.ndarray, binary: Binarized, reference: Reference) -> bool:
    """Whether the whole pad lies in the view where ``H`` puts it."""
    h, w = binary.smooth.shape
    box = apply_h(H, pad_box_m(reference))
    return bool(np.all((box >= 0) & (box <= [w - 1, h - 1])))


def _context_ncc(
    H: np.ndarray, binary: Binarized, reference: Reference, corners_m: np.ndarray
) -> float:
    """The frame's channel against the reference's around an H of the reference
    (``corners_m``) put in the view by ``H``: over its box grown by ``LESSER_CONTEXT``
    of its size (nan when too little of it is in view, or too much)."""
    box = pattern_box(corners_m, LESSER_CONTEXT)
    return pad_pattern(
        binary.smooth, reference.template_pyramid, reference.channel_px_per_m, box, H
    )


def _framed_below_px(reference: Reference) -> float:
    """The H's span (frame pixels) under which the rest of its pad must be found."""
    return BARE_H_PX if _plain_light_board(reference) else SMALL_H_PX


def _plain_light_board(reference: Reference) -> bool:
    """Whether the pad is a dark H on a plain light board (no marks of the H's paint).

    Such a pad differs from the same H painted on a floor by its board alone. The
    board check does not see it (it reads the board's level against the brighter of
    board and H: here the board itself), nor does the whole pad's pattern (the H on
    a plain ground is the look-alike's too): on the bench's views at 8-22 m, dark H's
    painted on concrete passed every check up to 28 px, in 3-7 of 15 empty frames.
    Its board's rim is what tells them apart. (Reading the board against the H
    instead, those floors still came within its tolerance from afar.)
    """
    return reference.polarity == "dark" and not reference.painted_marks


def _pattern_around(hit: Located, binary: Binarized, reference: Reference) -> bool:
    """Whether the whole pad's pattern around a small H matches the reference's; never
    for a pad whose pattern is its H alone (no marks painted around it, nor a board:
    an H painted on grass), which would be the H vouching for itself. So small, an H of
    hairline strokes painted on the grass matched grass_paint's 0.78 and more: taken
    for the pad, 50 m away (its H 13 px), in 6 of a scene's 10 empty views, and once
    instead of the pad (that pad found in 13 of 20 views instead of 16)."""
    if reference.marks_model is None or _plain_light_board(reference):
        return False
    if not (reference.painted_marks or reference.board_is_outline):
        return False
    pattern = pad_pattern(
        binary.smooth,
        reference.template_pyramid,
        reference.channel_px_per_m,
        pad_box_m(reference),
        hit.fit.H,
    )
    return pattern >= MIN_PAD_NCC
