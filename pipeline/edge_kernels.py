"""The edge fits' inner loops, compiled (``pipeline.jit``): where a projected side's
edge lies, the homography's Gauss-Newton steps, the pose's, and the share of a
model's sides found on a picture's edges.

Each fit measures a few hundred points a few times per frame: written as numpy
expressions, each step was some forty calls on small arrays, whose overhead took
most of a frame's time.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.jit import compiled, solve

MIN_DROP = 4.0  # an edge: levels dropping at least this much over half a frame pixel
STEP_PX = 0.5  # between the samples across an edge
MAX_REACH_PX = 8.0  # the farthest a side's edge is looked for
BORDER_PX = 2.0  # points this near the image's border (3 px on the far side) are not measured
SUPPORT_PX = 0.75  # an edge this near where a side is put counts as found
GIVE_UP_STEPS = 3  # (see homography_steps' give_up_below)
# `edge_offsets`' centroid of the drops around the steepest:
WEIGHT_FLOOR = 0.2  # of the steepest drop: those above it weigh by their excess
TAIL_SHARE = 0.1  # of the steepest drop: where the drops around it end
MAX_TAIL = 6  # samples each side of the steepest at most


@compiled
def _bilinear(img, x, y):
    """``img`` at (x, y), bilinear, the border replicated (as cv2.remap's BORDER_REPLICATE)."""
    h, w = img.shape
    fx, fy = math.floor(x), math.floor(y)
    ax, ay = x - fx, y - fy
    x0 = min(max(int(fx), 0), w - 1)
    x1 = min(max(int(fx) + 1, 0), w - 1)
    y0 = min(max(int(fy), 0), h - 1)
    y1 = min(max(int(fy) + 1, 0), h - 1)
    top = img[y0, x0] * (1.0 - ax) + img[y0, x1] * ax
    bottom = img[y1, x0] * (1.0 - ax) + img[y1, x1] * ax
    return top * (1.0 - ay) + bottom * ay


@compiled
def _across(img, px, py, nx, ny, first, values):
    """``img`` at ``len(values)`` points every ``STEP_PX`` along (nx, ny) from ``first``
    pixels off (px, py), bilinear (as `_bilinear`, without its clamps where all lie
    inside: most do, and the clamps were a fifth of the edge fits' time)."""
    h, w = img.shape
    last = first + (len(values) - 1) * STEP_PX
    xa, xb, ya, yb = px + first * nx, px + last * nx, py + first * ny, py + last * ny
    if not (
        min(xa, xb) >= 0.0 and max(xa, xb) < w - 1 and min(ya, yb) >= 0.0 and max(ya, yb) < h - 1
    ):
        for k in range(len(values)):
            t = first + k * STEP_PX
            values[k] = _bilinear(img, px + t * nx, py + t * ny)
        return
    for k in range(len(values)):
        t = first + k * STEP_PX
        x, y = px + t * nx, py + t * ny
        x0, y0 = int(x), int(y)  # (>= 0: the floor)
        ax, ay = x - x0, y - y0
        top = img[y0, x0] * (1.0 - ax) + img[y0, x0 + 1] * ax
        bottom = img[y0 + 1, x0] * (1.0 - ax) + img[y0 + 1, x0 + 1] * ax
        values[k] = top * (1.0 - ay) + bottom * ay


@compiled
def in_view(x, y, h, w):
    """Whether a point lies far enough inside an h x w image to be measured."""
    return x > BORDER_PX and y > BORDER_PX and x < w - BORDER_PX - 1 and y < h - BORDER_PX - 1


@compiled
def edge_offsets(img, proj, normal, search, min_drop, centroid=False):
    """Signed distance along each normal from each projected point to the image's
    edge (bright to dark along the normal), sub-pixel, looked for within ``search``
    pixels; and whether one was found.

    The image is sampled every ``STEP_PX`` across the point; the edge is where the
    level drops most between two samples (more than ``min_drop``: ``MIN_DROP`` on the
    frame's own pixels, less on an enlarged view's), refined by a parabola through
    the drops around it. A drop at the end of the search is not an edge found (it
    may lie further out).

    The parabola locks to the pixel grid: across a side along the rows or columns,
    linear interpolation's drops come in equal pairs within a pixel, and the vertex
    lands up to 0.39 px off by the edge's phase alone (at any other angle the phases
    vary along the side and average out). ``centroid`` places the edge at the
    centroid of the drops around the steepest instead (`_drops_centroid`): within
    0.03-0.15 px at every phase, but with a noise of its own that the detection's
    thresholds were not tuned for; `pipeline.measure` uses it for the pose alone.
    """
    n = proj.shape[0]
    h, w = img.shape
    reach = min(search, MAX_REACH_PX)
    half = math.floor(reach / STEP_PX + 1e-6)
    count = 2 * half + 1
    first = -(half + MAX_TAIL) * STEP_PX  # (of the buffers, which hold the tails too)
    delta = np.zeros(n)
    ok = np.zeros(n, np.bool_)
    values = np.empty(count + 2 * MAX_TAIL)
    drops = np.empty(count + 2 * MAX_TAIL - 1)
    lo, hi = MAX_TAIL, MAX_TAIL + count - 1  # the searched samples
    for i in range(n):
        px, py = proj[i, 0], proj[i, 1]
        nx, ny = normal[i, 0], normal[i, 1]
        _across(img, px, py, nx, ny, first + lo * STEP_PX, values[lo : hi + 1])
        best = lo
        for k in range(lo, hi):
            drops[k] = values[k] - values[k + 1]
            if drops[k] > drops[best]:
                best = k
        found = lo < best < hi - 1 and drops[best] > min_drop and in_view(px, py, h, w)
        if centroid:
            at = _drops_centroid(img, px, py, nx, ny, first, values, drops, best, lo, hi)
        else:
            kk = min(max(best, lo + 1), hi - 2)
            g0, g1, g2 = drops[kk - 1], drops[kk], drops[kk + 1]
            den = g0 - 2.0 * g1 + g2
            sub = 0.5 * (g0 - g2) / den if abs(den) > 1e-9 else 0.0
            at = kk + min(max(sub, -0.5), 0.5)
        delta[i] = first + (at + 0.5) * STEP_PX
        ok[i] = found
    return delta, ok


@compiled
def _drops_centroid(img, px, py, nx, ny, first, values, drops, best, lo, hi):
    """Where (in drops' indices) the centroid of the drops around ``best`` lies: those
    over ``WEIGHT_FLOOR`` of the steepest weigh by their excess, out to where they
    fall to ``TAIL_SHARE`` of it and at most ``MAX_TAIL`` samples each side (sampled
    beyond the search, ``lo``..``hi``, where needed); taken twice, the second time
    around the first's centroid (a blurred edge's drops lean to one side of the
    steepest)."""
    floor = TAIL_SHARE * drops[best]
    weigh_above = WEIGHT_FLOOR * drops[best]
    top = len(drops)
    centre = best
    at = float(best)
    for _ in range(2):
        a = centre
        while a > 0 and centre - a < MAX_TAIL:
            if a - 1 < lo:
                lo -= 1
                t = first + lo * STEP_PX
                values[lo] = _bilinear(img, px + t * nx, py + t * ny)
                drops[lo] = values[lo] - values[lo + 1]
            if drops[a - 1] <= floor:
                break
            a -= 1
        b = centre
        while b < top - 1 and b - centre < MAX_TAIL:
            if b + 2 > hi:
                hi += 1
                t = first + hi * STEP_PX
                values[hi] = _bilinear(img, px + t * nx, py + t * ny)
                drops[hi - 1] = values[hi - 1] - values[hi]
            if drops[b + 1] <= floor:
                break
            b += 1
        mass = 0.0
        moment = 0.0
        for k in range(a, b + 1):
            weight = drops[k] - weigh_above
            if weight > 0.0:
                mass += weight
                moment += weight * k
        if mass > 0.0:
            at = moment / mass
        centre = min(max(round(at), lo), hi - 1)
    return at


@compiled
def _apply(H, x, y):
    d = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    return (H[0, 0] * x + H[0, 1] * y + H[0, 2]) / d, (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / d


@compiled
def _normals(pa, pb, bright, polygon, curved, usable, min_side_px):
    """Per side of a model whose ends lie at ``pa``/``pb`` in the image: its unit
    normal from the bright side of its edge to the dark side, and whether it is
    measured (``usable``, and long enough in the image; a piece of a curve needs 1 px).
    None is measured when an end lies at no finite pixel."""
    s = pa.shape[0]
    n_poly = 0
    for j in range(s):
        n_poly = max(n_poly, polygon[j] + 1)
    # Each polygon's orientation in the image tells which way is outward.
    area = np.zeros(n_poly)
    for j in range(s):
        area[polygon[j]] += pa[j, 0] * pb[j, 1] - pb[j, 0] * pa[j, 1]
    normal = np.zeros((s, 2))
    measured = np.zeros(s, np.bool_)
    for j in range(s):
        dx, dy = pb[j, 0] - pa[j, 0], pb[j, 1] - pa[j, 1]
        length = math.sqrt(dx * dx + dy * dy)
        if not math.isfinite(length):
            measured[:] = False
            return normal, measured
        orient = 1.0 if area[polygon[j]] > 0 else -1.0
        sign = orient if bright[j] else -orient
        shortest = 1.0 if curved[j] else min_side_px
        if usable[j] and length >= shortest and length > 0:
            measured[j] = True
            normal[j, 0] = sign * dy / length
            normal[j, 1] = -sign * dx / length
    return normal, measured


@compiled
def _side_normals(a_m, b_m, bright, polygon, clearance_m, curved, H, min_clearance_px, min_side_px):
    """`_normals` of a model put in the image by the homography ``H``; a side is
    usable when it lies at least ``min_clearance_px`` from a side alongside it."""
    s = a_m.shape[0]
    pa = np.empty((s, 2))
    pb = np.empty((s, 2))
    usable = np.empty(s, np.bool_)
    for j in range(s):
        pa[j, 0], pa[j, 1] = _apply(H, a_m[j, 0], a_m[j, 1])
        pb[j, 0], pb[j, 1] = _apply(H, b_m[j, 0], b_m[j, 1])
        len_m = max(math.hypot(b_m[j, 0] - a_m[j, 0], b_m[j, 1] - a_m[j, 1]), 1e-12)
        len_px = math.hypot(pb[j, 0] - pa[j, 0], pb[j, 1] - pa[j, 1])
        usable[j] = clearance_m[j] * len_px / len_m >= min_clearance_px
    return _normals(pa, pb, bright, polygon, curved, usable, min_side_px)


@compiled
def _matmul3(A, B):
    C = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                C[i, j] += A[i, k] * B[k, j]
    return C


@compiled
def _dot(a, b):
    acc = 0.0
    for k in range(a.shape[0]):
        acc += a[k] * b[k]
    return acc


@compiled
def _side_medians(r, side):
    """For each residual, the median of its side's residuals: the residuals ordered by
    side once (a pass per side over all of them made the fit of a ringed pad, whose
    sides are a few hundred, 1.4 times as slow with a deformation)."""
    n = len(r)
    out = np.empty(n)
    order = np.argsort(side, kind="mergesort")
    start = 0
    while start < n:
        j = side[order[start]]
        end = start + 1
        while end < n and side[order[end]] == j:
            end += 1
        mine = order[start:end]
        out[mine] = np.median(r[mine])
        start = end
    return out


@compiled
def _mad(x):
    return 1.4826 * np.median(np.abs(x - np.median(x)))


@compiled
def homography_steps(
    img,
    a_m,
    b_m,
    bright,
    polygon,
    clearance_m,
    curved,
    pts_side,
    pts_t,
    deform_a,
    deform_b,
    deform_sigma,
    Tm,
    Tp,
    h0,
    iterations,
    search_px,
    sides_alike,
    min_clearance_px,
    min_side_px,
    damping,
    min_drop,
    give_up_below,
    centroid,
):
    """The Gauss-Newton steps of ``pipeline.homography_fit.fit_homography`` on the
    normalised homography ``h0`` (8 entries, pad coordinates through ``Tm``, pixels
    through ``Tp``) and, with it, K deformations of the model: side j's ends move by
    ``deform_a[j] @ p`` and ``deform_b[j] @ p`` (S x 2 x K, metres per unit of p), each
    p_k held near 0 by ``deform_sigma[k]`` (K = 0: none). The samples lie at ``pts_t``
    along their sides (``pts_side``). Returns, after the step that found the most of
    the sides' edges, (h, p, rms of the inliers, per side the share of its seen
    samples on an edge (nan: none seen)), and whether a step was taken at all. A fit
    that has found less than ``give_up_below`` of its sides after ``GIVE_UP_STEPS``
    steps stops there. ``centroid``: see `edge_offsets`."""
    s = a_m.shape[0]
    n = pts_side.shape[0]
    kd = deform_sigma.shape[0]
    npar = 8 + kd
    ih, iw = img.shape
    sm = Tm[0, 0]  # Tm scales pad metres by sm and shifts them
    sp = Tp[0, 0]  # Tp scales pixels by sp and shifts them
    Tp_inv = np.array(
        [[1.0 / sp, 0.0, -Tp[0, 2] / sp], [0.0, 1.0 / sp, -Tp[1, 2] / sp], [0.0, 0.0, 1.0]]
    )
    h = h0.copy()
    p = np.zeros(kd)
    Hn = np.empty((3, 3))
    found = np.full(s, np.nan)
    # The step after which most of the sides' edges are found: on a small H, whose
    # stroke ends have a few samples each, later steps may wander along a flat
    # valley and lose a few of them.
    best_h, best_p, best_rms, best_found = h0.copy(), p.copy(), -1.0, found.copy()
    best_support = -1.0
    a = np.empty((s, 2))
    b = np.empty((s, 2))
    proj = np.empty((n, 2))
    normal = np.empty((n, 2))
    J_all = np.empty((n, npar))
    use = np.empty(n, np.bool_)
    for it in range(iterations):
        for k in range(8):
            Hn[k // 3, k % 3] = h[k]
        Hn[2, 2] = 1.0
        H = _matmul3(_matmul3(Tp_inv, Hn), Tm)
        search = max(1.5, search_px / 2.0**it)
        for j in range(s):
            for c in range(2):
                a[j, c] = a_m[j, c] + _dot(deform_a[j, c], p)
                b[j, c] = b_m[j, c] + _dot(deform_b[j, c], p)
        side_n, measured = _side_normals(
            a, b, bright, polygon, clearance_m, curved, H, min_clearance_px, min_side_px
        )
        m = 0
        for i in range(n):
            j = pts_side[i]
            use[i] = measured[j]
            if not use[i]:
                continue
            m += 1
            t = pts_t[i]
            X, Y = _apply(Tm, a[j, 0] + t * (b[j, 0] - a[j, 0]), a[j, 1] + t * (b[j, 1] - a[j, 1]))
            wd = h[6] * X + h[7] * Y + 1.0
            u = (h[0] * X + h[1] * Y + h[2]) / wd
            v = (h[3] * X + h[4] * Y + h[5]) / wd
            proj[i, 0] = (u - Tp[0, 2]) / sp
            proj[i, 1] = (v - Tp[1, 2]) / sp
            nx, ny = side_n[j, 0], side_n[j, 1]
            normal[i, 0], normal[i, 1] = nx, ny
            # d(normal . projection) / dh, in pixels.
            J_all[i, 0] = nx * X / wd / sp
            J_all[i, 1] = nx * Y / wd / sp
            J_all[i, 2] = nx / wd / sp
            J_all[i, 3] = ny * X / wd / sp
            J_all[i, 4] = ny * Y / wd / sp
            J_all[i, 5] = ny / wd / sp
            J_all[i, 6] = -(nx * u + ny * v) * X / wd / sp
            J_all[i, 7] = -(nx * u + ny * v) * Y / wd / sp
            # ... and by the deformations, through where the sample lies on the pad.
            gx = (nx * (h[0] - u * h[6]) + ny * (h[3] - v * h[6])) / wd * sm / sp
            gy = (nx * (h[1] - u * h[7]) + ny * (h[4] - v * h[7])) / wd * sm / sp
            for k in range(kd):
                dx = (1.0 - t) * deform_a[j, 0, k] + t * deform_b[j, 0, k]
                dy = (1.0 - t) * deform_a[j, 1, k] + t * deform_b[j, 1, k]
                J_all[i, 8 + k] = gx * dx + gy * dy
        if m == 0:
            return best_h, best_p, -1.0, found, False
        idx = np.nonzero(use)[0]
        delta, ok = edge_offsets(img, proj[idx], normal[idx], search, min_drop, centroid)
        good = np.nonzero(ok)[0]
        if len(good) < 10:
            return best_h, best_p, -1.0, found, False
        r = -delta[good]
        if kd:
            # A side the model draws off by a stroke's change lies off as a whole:
            # each side's residuals are judged around their own median.
            r = r - _side_medians(r, pts_side[idx[good]])
        inl = good[np.abs(r - np.median(r)) <= max(0.5, 3.0 * _mad(r))]
        if len(inl) < 10:
            return best_h, best_p, -1.0, found, False
        per_side = np.zeros(s)
        if sides_alike:
            for q in inl:
                per_side[pts_side[idx[q]]] += 1.0
        A = np.zeros((npar, npar))
        g = np.zeros(npar)
        total = 0.0
        for q in inl:
            ri = -delta[q]
            wi = 1.0 if abs(ri) <= 0.5 else 0.5 / max(abs(ri), 1e-9)
            if sides_alike:
                wi /= per_side[pts_side[idx[q]]]
            total += wi
            row = J_all[idx[q]]
            for c in range(npar):
                g[c] -= wi * row[c] * ri
                for e in range(c, npar):
                    A[c, e] += wi * row[c] * row[e]
        for c in range(npar):
            for e in range(c):
                A[c, e] = A[e, c]
        for c in range(8):
            A[c, c] += damping * A[c, c] + 1e-12
        # The deformations held near none: a side's worth of weight per sigma.
        per = total / s
        for k in range(kd):
            A[8 + k, 8 + k] += per / deform_sigma[k] ** 2 + 1e-12
            g[8 + k] -= per * p[k] / deform_sigma[k] ** 2
        step, solved = solve(A, g)
        if not solved:
            return best_h, best_p, -1.0, found, False
        h = h + step[:8]
        p = p + step[8:]
        acc = 0.0
        for q in inl:
            e = -delta[q] + _dot(J_all[idx[q]], step)
            acc += e * e
        fitted = math.sqrt(acc / len(inl))
        # Where each edge lies after this step: the support, without measuring again.
        seen_n = np.zeros(s)
        hit_n = np.zeros(s)
        for q in range(len(idx)):
            i = idx[q]
            if not in_view(proj[i, 0], proj[i, 1], ih, iw):
                continue
            j = pts_side[i]
            seen_n[j] += 1.0
            if ok[q] and abs(delta[q] - _dot(J_all[i], step)) <= SUPPORT_PX:
                hit_n[j] += 1.0
        total = 0.0
        sides = 0
        for j in range(s):
            found[j] = hit_n[j] / seen_n[j] if seen_n[j] > 0 else np.nan
            if seen_n[j] > 0:
                total += found[j]
                sides += 1
        support = total / sides if sides else 0.0
        if support >= best_support:
            best_h, best_p, best_rms, best_found = h.copy(), p.copy(), fitted, found.copy()
            best_support = support
        if it > 0 and np.max(np.abs(step[:8])) < 0.05 * sp:  # under ~0.05 px anywhere
            break
        if it + 1 == GIVE_UP_STEPS and best_support < give_up_below:
            break
    return best_h, best_p, best_rms, best_found, best_rms >= 0.0


@compiled
def side_support(
    img, a_m, b_m, bright, polygon, clearance_m, curved, pts_m, pts_side, H, min_clearance_px,
    min_side_px, min_drop,
):  # fmt: skip
    """Per side of a model put in the image by ``H``, the share of its samples in view
    that sit on an edge within ``SUPPORT_PX`` of it (nan: none in view or measured)."""
    s = a_m.shape[0]
    ih, iw = img.shape
    found = np.full(s, np.nan)
    side_n, measured = _side_normals(
        a_m, b_m, bright, polygon, clearance_m, curved, H, min_clearance_px, min_side_px
    )
    idx = np.nonzero(measured[pts_side])[0]
    proj = np.empty((len(idx), 2))
    normal = np.empty((len(idx), 2))
    for q in range(len(idx)):
        i = idx[q]
        proj[q, 0], proj[q, 1] = _apply(H, pts_m[i, 0], pts_m[i, 1])
        normal[q] = side_n[pts_side[i]]
    delta, ok = edge_offsets(img, proj, normal, 1.5, min_drop)
    seen_n = np.zeros(s)
    hit_n = np.zeros(s)
    for q in range(len(idx)):
        if not in_view(proj[q, 0], proj[q, 1], ih, iw):
            continue
        j = pts_side[idx[q]]
        seen_n[j] += 1.0
        if ok[q] and abs(delta[q]) <= SUPPORT_PX:
            hit_n[j] += 1.0
    for j in range(s):
        if seen_n[j] > 0:
            found[j] = hit_n[j] / seen_n[j]
    return found


@compiled
def pose_step(
    img, pa, pb, bright, polygon, curved, usable, pts_side, proj, jac, search, min_side_px,
    min_drop, centroid,
):  # fmt: skip
    """One Gauss-Newton step of ``pipeline.edgefit.fit_edges``: the model's sides lie
    at ``pa``/``pb`` in the image, its samples at ``proj`` with ``jac`` (N x 2 x 6) their
    derivatives by the pose (rvec, tvec); ``centroid``: see `edge_offsets`. Returns
    (step, rms of the inliers after it, inliers, sides they lie on, whether there were
    enough edges to take it)."""
    step = np.zeros(6)
    side_n, measured = _normals(pa, pb, bright, polygon, curved, usable, min_side_px)
    idx = np.nonzero(measured[pts_side])[0]
    normal = np.empty((len(idx), 2))
    for q in range(len(idx)):
        normal[q] = side_n[pts_side[idx[q]]]
    delta, ok = edge_offsets(img, proj[idx], normal, search, min_drop, centroid)
    good = np.nonzero(ok)[0]
    if len(good) < 12:
        return step, -1.0, 0, 0, False
    r = -delta[good]
    inl = good[np.abs(r - np.median(r)) <= max(0.5, 3.0 * _mad(r))]
    if len(inl) < 12:
        return step, -1.0, 0, 0, False
    J = np.empty((len(inl), 6))
    A = np.zeros((6, 6))
    g = np.zeros(6)
    sides = np.zeros(pa.shape[0], np.bool_)
    for k in range(len(inl)):
        q = inl[k]
        i = idx[q]
        sides[pts_side[i]] = True
        for a in range(6):
            J[k, a] = normal[q, 0] * jac[i, 0, a] + normal[q, 1] * jac[i, 1, a]
        ri = -delta[q]
        # Huber weights keep a few wrong edge hits from pulling the pose.
        wi = 1.0 if abs(ri) <= 0.5 else 0.5 / max(abs(ri), 1e-9)
        for a in range(6):
            g[a] -= wi * J[k, a] * ri
            for b in range(a, 6):
                A[a, b] += wi * J[k, a] * J[k, b]
    for a in range(6):
        A[a, a] += 1e-9
        for b in range(a):
            A[a, b] = A[b, a]
    step, solved = solve(A, g)
    if not solved:
        return np.zeros(6), -1.0, 0, 0, False
    acc = 0.0
    for k in range(len(inl)):
        e = -delta[inl[k]] + _dot(J[k], step)
        acc += e * e
    return step, math.sqrt(acc / len(inl)), len(inl), int(sides.sum()), True


@compiled
def pose_support(
    img, pa, pb, bright, polygon, curved, usable, pts_side, proj, min_side_px, min_drop
):
    """Of the samples in view on the model's measured sides (see `pose_step`), the
    share that sit on an edge within ``SUPPORT_PX`` of where the pose puts them."""
    ih, iw = img.shape
    side_n, measured = _normals(pa, pb, bright, polygon, curved, usable, min_side_px)
    idx = np.nonzero(measured[pts_side])[0]
    normal = np.empty((len(idx), 2))
    for q in range(len(idx)):
        normal[q] = side_n[pts_side[idx[q]]]
    delta, ok = edge_offsets(img, proj[idx], normal, 1.5, min_drop)
    seen = 0
    hit = 0
    for q in range(len(idx)):
        i = idx[q]
        if in_view(proj[i, 0], proj[i, 1], ih, iw):
            seen += 1
            if ok[q] and abs(delta[q]) <= SUPPORT_PX:
                hit += 1
    return hit / seen if seen > 0 else 0.0
