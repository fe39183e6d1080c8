"""Differential planar ego-motion: the camera's motion from the pad's image velocities.

The dissertation's section 6.3.5 (after Shakernia et al. and Ma, Soatto, Kosecka and
Sastry). A camera moves with linear velocity ``v`` and angular velocity ``w`` (both in
its own frame: OpenCV, x right, y down, z forward) over a static plane ``n^T X = d``
(``n`` the unit normal pointing from the camera to the plane, ``d > 0`` the camera's
distance to it). A point ``X`` of the plane moves, in the camera frame, as

    dX/dt = -(w^ + v n^T / d) X = -B X                     (eq. 6.13, 6.14)

and its image ``q = X / Z`` (normalised coordinates, ``q_3 = 1``) as

    dq/dt = -(I - q e3^T) B q.                               (eq. 6.15)

Each point gives two equations linear in the nine entries of ``B``. What the seed
leaves out, and gets wrong: ``(I - q e3^T) q = 0``, so ``B`` and ``B + c I`` give the
same image velocities for every ``c``: the stacked system has rank at most 8 (never 9),
and ``B`` is recovered only up to ``c I``, not uniquely. The physical ``B`` is picked by
its structure: ``B + B^T = (v n^T + n v^T) / d`` has eigenvalues
``(v.n +- |v|) / d`` and ``0``, so ``c`` is the shift that makes the middle eigenvalue
of the symmetric part zero. ``B + B^T`` then gives ``{v/d, n}`` up to a swap of the two
(two physical solutions once the plane is required to lie in front of the camera);
``w^ = B - v n^T / d``. The swap is settled by a normal known beforehand (the previous
estimate, or the pad's pose), or disappears when ``w`` is known (a gyro).

Image velocities come from the pad's corners tracked over two or more consecutive
frames: a straight line fitted per coordinate, evaluated at the frames' mean time.

Three ways to use what else is known, each a linear least-squares problem:

- nothing else (``B``, eight unknowns): ``w``, ``v/d`` and ``n``, two solutions;
- the angular velocity (gyro): ``v n^T / d = B - w^`` is rank one, so ``v/d`` and ``n``
  come out unique;
- the plane normal (pose or attitude): the unknowns are ``w`` and ``v/d`` (six), or
  only ``v/d`` (three) when the angular velocity is known too.

Over a narrow field of view a sideways translation and a rotation move the image
almost alike (their flows differ only in terms quadratic in the image coordinates),
so the more is known, the better conditioned the problem: see ``pipeline.egomotion_bench``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.camera import Camera

_E3 = np.array([0.0, 0.0, 1.0])
_EPS = 1e-12


@dataclass(frozen=True, eq=False)
class EgoSolution:
    """One physical solution: angular velocity (rad/s), ``v/d`` (1/s), plane normal."""

    angular_velocity: np.ndarray
    v_over_d: np.ndarray
    normal: np.ndarray | None


@dataclass(frozen=True, eq=False)
class EgoMotion:
    """The camera's motion over the pad plane, in the camera frame at ``time_s``.

    Attributes
    ----------
    angular_velocity : ndarray, shape (3,)
        rad/s (given or estimated).
    v_over_d : ndarray, shape (3,)
        Linear velocity divided by the distance to the plane (1/s).
    normal : ndarray, shape (3,) or None
        Unit normal from the camera towards the plane (given or estimated); None
        when nothing says it: no translation and no normal given.
    velocity : ndarray, shape (3,) or None
        Linear velocity in m/s when ``distance_m`` was given, else None.
    distance_m : float or None
        The distance to the plane used for ``velocity``.
    alternative : EgoSolution or None
        The other physical solution when two exist (unknown rotation and normal).
    ambiguous : bool
        Two solutions exist and nothing given chose between them (``normal_prior``).
    method : str
        ``"planar_essential"`` (rotation and normal unknown), ``"known_rotation"``,
        ``"known_normal"`` or ``"known_rotation_and_normal"``.
    residual : float
        RMS of the image-velocity residual (normalised units per second).
    time_s : float
        The instant the estimate refers to (the frames' mean time).
    """

    angular_velocity: np.ndarray
    v_over_d: np.ndarray
    normal: np.ndarray | None
    velocity: np.ndarray | None
    distance_m: float | None
    alternative: EgoSolution | None
    ambiguous: bool
    method: str
    residual: float
    time_s: float

    def to_dict(self) -> dict:
        def vec(a: np.ndarray | None) -> list[float] | None:
            return None if a is None else [float(x) for x in a]

        return {
            "angular_velocity": vec(self.angular_velocity),
            "v_over_d": vec(self.v_over_d),
            "normal": vec(self.normal),
            "velocity": vec(self.velocity),
            "distance_m": self.distance_m,
            "alternative": None
            if self.alternative is None
            else {
                "angular_velocity": vec(self.alternative.angular_velocity),
                "v_over_d": vec(self.alternative.v_over_d),
                "normal": vec(self.alternative.normal),
            },
            "ambiguous": self.ambiguous,
            "method": self.method,
            "residual": float(self.residual),
            "time_s": float(self.time_s),
        }


# --------------------------------------------------------------------------- helpers


def hat(w: np.ndarray) -> np.ndarray:
    """The skew-symmetric matrix of ``w``: ``hat(w) @ x == np.cross(w, x)``.

    >>> hat(np.array([1.0, 2.0, 3.0])) @ np.array([0.0, 0.0, 1.0])
    array([ 2., -1.,  0.])
    """
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _vee(m: np.ndarray) -> np.ndarray:
    a = 0.5 * (m - m.T)
    return np.array([a[2, 1], a[0, 2], a[1, 0]])


def _vector(value: object, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return arr


def _unit(value: object, name: str) -> np.ndarray:
    arr = _vector(value, name)
    norm = float(np.linalg.norm(arr))
    if norm < 1e-9:
        raise ValueError(f"{name} must not be the zero vector")
    return arr / norm


def image_flow(
    corners_px: np.ndarray, times_s: np.ndarray, camera: Camera
) -> tuple[np.ndarray, np.ndarray, float]:
    """Normalised image points and their velocities from tracked corners.

    Parameters
    ----------
    corners_px : ndarray, shape (T, N, 2)
        The same N corners (same order) in T >= 2 consecutive frames, pixels.
    times_s : ndarray, shape (T,)
        Capture times, strictly increasing.
    camera : Camera
        Intrinsics (lens distortion is removed first).

    Returns
    -------
    q : ndarray, shape (N, 3)
        Normalised points ``(x, y, 1)`` at the mean time.
    q_dot : ndarray, shape (N, 3)
        Their velocities ``(dx/dt, dy/dt, 0)`` per second (a straight-line fit).
    t_ref : float
        The mean time.
    """
    if not isinstance(camera, Camera):
        raise ValueError("camera must be a pipeline.Camera")
    pts = np.asarray(corners_px, dtype=np.float64)
    if pts.ndim != 3 or pts.shape[0] < 2 or pts.shape[2] != 2:
        raise ValueError(
            f"corners_px must have shape (T >= 2 frames, N corners, 2), got {pts.shape}"
        )
    if not np.all(np.isfinite(pts)):
        raise ValueError("corners_px must be finite (every corner seen in every frame)")
    t = np.asarray(times_s, dtype=np.float64)
    if t.shape != (pts.shape[0],) or not np.all(np.isfinite(t)):
        raise ValueError(f"times_s must hold {pts.shape[0]} finite times, got shape {t.shape}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("times_s must be strictly increasing")
    n_frames, n_pts = pts.shape[:2]
    und = camera.undistort_points(pts.reshape(-1, 2)).reshape(n_frames, n_pts, 2)
    K = camera.K
    xy = np.empty_like(und)
    xy[..., 0] = (und[..., 0] - K[0, 2] - K[0, 1] * (und[..., 1] - K[1, 2]) / K[1, 1]) / K[0, 0]
    xy[..., 1] = (und[..., 1] - K[1, 2]) / K[1, 1]
    t_ref = float(t.mean())
    dt = t - t_ref
    denom = float(dt @ dt)
    mean = xy.mean(axis=0)
    slope = np.tensordot(dt, xy - mean, axes=(0, 0)) / denom
    q = np.column_stack([mean, np.ones(n_pts)])
    q_dot = np.column_stack([slope, np.zeros(n_pts)])
    return q, q_dot, t_ref


def _check_flow(q: np.ndarray, q_dot: np.ndarray, minimum: int) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=np.float64)
    q_dot = np.asarray(q_dot, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 3 or not np.allclose(q[:, 2], 1.0):
        raise ValueError("q must have shape (N, 3) with q[:, 2] == 1 (normalised points)")
    if q_dot.shape != q.shape:
        raise ValueError(f"q_dot must have the shape of q {q.shape}, got {q_dot.shape}")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(q_dot))):
        raise ValueError("q and q_dot must be finite")
    if len(q) < minimum:
        raise ValueError(f"q: at least {minimum} points are needed here, got {len(q)}")
    return q, q_dot


# --------------------------------------------------------------------------- solvers


def planar_essential(q: np.ndarray, q_dot: np.ndarray) -> np.ndarray:
    """The differential planar essential matrix ``B`` (eq. 6.14) from image flow,
    normalised so that the middle eigenvalue of ``B + B^T`` is zero.

    >>> w, vd, n = np.array([0.1, -0.2, 0.05]), np.array([0.3, 0.1, -0.2]), _E3
    >>> B = hat(w) + np.outer(vd, n)
    >>> q = np.array([[x, y, 1.0] for x in (-0.2, 0.1, 0.3) for y in (-0.25, 0.2)])
    >>> q_dot = -np.array([(np.eye(3) - np.outer(p, _E3)) @ B @ p for p in q])
    >>> bool(np.allclose(planar_essential(q, q_dot), B))
    True
    """
    q, q_dot = _check_flow(q, q_dot, 4)
    G, rhs = _essential_system(q, q_dot)
    b, *_ = np.linalg.lstsq(G, rhs, rcond=None)
    B = b.reshape(3, 3)
    mid = np.linalg.eigvalsh(B + B.T)[1]
    return B - 0.5 * mid * np.eye(3)


def _essential_system(q: np.ndarray, q_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    # dx = -(B1.q - x B3.q), dy = -(B2.q - y B3.q): rows over vec(B) (row-major).
    n = len(q)
    G = np.zeros((2 * n, 9))
    G[0::2, 0:3] = -q
    G[0::2, 6:9] = q[:, :1] * q
    G[1::2, 3:6] = -q
    G[1::2, 6:9] = q[:, 1:2] * q
    rhs = np.empty(2 * n)
    rhs[0::2] = q_dot[:, 0]
    rhs[1::2] = q_dot[:, 1]
    return G, rhs


def _residual(q: np.ndarray, q_dot: np.ndarray, B: np.ndarray) -> float:
    pred = -np.einsum("nij,nj->ni", np.eye(3) - q[:, :, None] * _E3[None, None, :], q @ B.T)
    return float(np.sqrt(np.mean((pred[:, :2] - q_dot[:, :2]) ** 2)))


def _in_front(n: np.ndarray, q: np.ndarray) -> int:
    return int(np.sum(q @ n > 0))


def _orient(v_over_d: np.ndarray, n: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flip (v/d, n) together so that the plane lies in front of the camera."""
    if _in_front(n, q) * 2 < len(q):
        return -v_over_d, -n
    return v_over_d, n


def _decompose(B: np.ndarray, q: np.ndarray) -> list[EgoSolution]:
    """The physical solutions of a normalised ``B``, best-supported first."""
    S = B + B.T
    evals, evecs = np.linalg.eigh(S)  # ascending: s3 <= s2 ~ 0 <= s1
    s1, s3 = max(evals[2], 0.0), min(evals[0], 0.0)
    scale = max(1.0, float(np.abs(B).max()))
    if s1 - s3 <= 1e-12 * scale:  # no translation: the normal is not observable
        return [EgoSolution(_vee(B), np.zeros(3), None)]
    # a translation along the normal has one non-zero eigenvalue: the other is noise
    if -s3 < 1e-8 * s1:
        s3 = 0.0
    elif s1 < 1e-8 * -s3:
        s1 = 0.0
    u1, u3 = evecs[:, 2], evecs[:, 0]
    p = np.sqrt(s1 / 2.0) * u1
    r = np.sqrt(-s3 / 2.0) * u3
    out: list[tuple[int, EgoSolution]] = []
    for a, b in ((p + r, p - r), (p - r, p + r)):
        nb = float(np.linalg.norm(b))
        if nb < _EPS:
            continue
        vd, n = _orient(a * nb, b / nb, q)
        out.append((_in_front(n, q), EgoSolution(_vee(B - np.outer(vd, n)), vd, n)))
    # a translation along the normal makes the two coincide
    if len(out) == 2 and np.allclose(out[0][1].normal, out[1][1].normal, atol=1e-9):  # type: ignore[arg-type]
        out = out[:1]
    out.sort(key=lambda item: -item[0])
    return [sol for _, sol in out]


def _known_normal(
    q: np.ndarray, q_dot: np.ndarray, n: np.ndarray, w: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """Least squares for (w, v/d) or v/d given the normal (and the rotation)."""
    m = len(q)
    P = np.eye(3)[None, :, :] - q[:, :, None] * _E3[None, None, :]  # (I - q e3^T) per point
    qx = np.zeros((m, 3, 3))
    qx[:, 0, 1], qx[:, 0, 2] = -q[:, 2], q[:, 1]
    qx[:, 1, 0], qx[:, 1, 2] = q[:, 2], -q[:, 0]
    qx[:, 2, 0], qx[:, 2, 1] = -q[:, 1], q[:, 0]
    # dq = P [q]x w - (n.q) P v/d
    A_w = np.einsum("nij,njk->nik", P, qx)[:, :2, :].reshape(2 * m, 3)
    A_v = (-(q @ n)[:, None, None] * P)[:, :2, :].reshape(2 * m, 3)
    rhs = q_dot[:, :2].reshape(2 * m)
    if w is not None:
        vd, *_ = np.linalg.lstsq(A_v, rhs - A_w @ w, rcond=None)
        return w, vd
    x, *_ = np.linalg.lstsq(np.hstack([A_w, A_v]), rhs, rcond=None)
    return x[:3], x[3:]


def egomotion_from_flow(
    q: np.ndarray,
    q_dot: np.ndarray,
    *,
    angular_velocity: np.ndarray | None = None,
    normal: np.ndarray | None = None,
    normal_prior: np.ndarray | None = None,
    distance_m: float | None = None,
    time_s: float = 0.0,
) -> EgoMotion:
    """Ego-motion from normalised image points and their velocities.

    See :func:`estimate_egomotion` for the options; ``q`` (N x 3, ``q[:, 2] == 1``)
    and ``q_dot`` (N x 3, third column ignored) as :func:`image_flow` returns them.
    """
    w_known = None if angular_velocity is None else _vector(angular_velocity, "angular_velocity")
    n_known = None if normal is None else _unit(normal, "normal")
    prior = None if normal_prior is None else _unit(normal_prior, "normal_prior")
    if distance_m is not None and not (np.isfinite(distance_m) and distance_m > 0):
        raise ValueError(f"distance_m must be a finite number > 0, got {distance_m!r}")
    minimum = (
        2 if (n_known is not None and w_known is not None) else (3 if n_known is not None else 4)
    )
    q, q_dot = _check_flow(q, q_dot, minimum)
    alternative: EgoSolution | None = None
    ambiguous = False
    if n_known is not None:
        if _in_front(n_known, q) * 2 < len(q):
            raise ValueError("normal must point from the camera towards the plane (n . q > 0)")
        w, vd = _known_normal(q, q_dot, n_known, w_known)
        n_out: np.ndarray | None = n_known
        method = "known_normal" if w_known is None else "known_rotation_and_normal"
        B = hat(w) + np.outer(vd, n_known)
    else:
        B = planar_essential(q, q_dot)
        if w_known is not None:
            method = "known_rotation"
            M = B - hat(w_known)
            U, s, Vt = np.linalg.svd(M)
            if s[0] <= 1e-12 * max(1.0, float(np.abs(B).max())):
                w, vd, n_out = w_known, np.zeros(3), prior
            else:
                vd, n_out = _orient(U[:, 0] * s[0], Vt[0], q)
                w = w_known
        else:
            method = "planar_essential"
            solutions = _decompose(B, q)
            best = solutions[0]
            if len(solutions) == 2:
                if prior is not None:
                    scores = [float(s.normal @ prior) for s in solutions]  # type: ignore[operator]
                    if scores[1] > scores[0]:
                        solutions.reverse()
                else:
                    ambiguous = True
                best, alternative = solutions
            w, vd, n_out = best.angular_velocity, best.v_over_d, best.normal
            if n_out is None:
                n_out = prior
    velocity = None if distance_m is None else vd * float(distance_m)
    return EgoMotion(
        angular_velocity=w,
        v_over_d=vd,
        normal=n_out,
        velocity=velocity,
        distance_m=None if distance_m is None else float(distance_m),
        alternative=alternative,
        ambiguous=ambiguous,
        method=method,
        residual=_residual(q, q_dot, B),
        time_s=float(time_s),
    )


def estimate_egomotion(
    corners_px: np.ndarray,
    times_s: np.ndarray,
    camera: Camera,
    *,
    angular_velocity: np.ndarray | None = None,
    normal: np.ndarray | None = None,
    normal_prior: np.ndarray | None = None,
    distance_m: float | None = None,
) -> EgoMotion:
    """The camera's angular velocity, ``v/d`` and the pad's normal from tracked corners.

    Parameters
    ----------
    corners_px : ndarray, shape (T, N, 2)
        The pad's corners in T >= 2 consecutive frames (same corners, same order;
        N >= 4, or fewer when ``normal`` is given), pixels.
    times_s : ndarray, shape (T,)
        The frames' capture times, strictly increasing.
    camera : Camera
        The camera's intrinsics.
    angular_velocity : array_like, shape (3,), optional
        Known angular velocity in the camera frame (rad/s), e.g. the gyro rotated
        into the camera frame; removes the two-fold ambiguity.
    normal : array_like, shape (3,), optional
        Known unit normal of the pad plane in the camera frame, pointing from the
        camera to the plane (e.g. ``-R_pad_cam[2]`` of the pad's pose).
    normal_prior : array_like, shape (3,), optional
        Only chooses between the two solutions (e.g. the previous estimate).
    distance_m : float, optional
        Distance from the camera to the plane (the pose's altitude): gives the
        metric ``velocity``.

    Returns
    -------
    EgoMotion
        At the frames' mean time, in the camera frame.

    Raises
    ------
    ValueError
        Naming the parameter that is malformed.

    Examples
    --------
    A camera 2 m above the pad looking straight down, moving 0.5 m/s to image-right:

    >>> cam = Camera.from_fov(640, 480, 60.0)
    >>> pts = np.array([[x, y, 2.0] for x in (-0.2, 0.0, 0.25) for y in (-0.2, 0.15)])
    >>> v = np.array([0.5, 0.0, 0.0])
    >>> frames = [(pts - v * t) @ cam.K.T for t in (0.0, 1 / 15, 2 / 15)]
    >>> px = np.array([f[:, :2] / f[:, 2:] for f in frames])
    >>> ego = estimate_egomotion(px, np.array([0.0, 1 / 15, 2 / 15]), cam,
    ...                          normal_prior=[0, 0, 1], distance_m=2.0)
    >>> (np.round(ego.velocity, 3) + 0.0).tolist(), (np.round(ego.normal, 3) + 0.0).tolist()
    ([0.5, 0.0, 0.0], [0.0, 0.0, 1.0])
    """
    q, q_dot, t_ref = image_flow(corners_px, times_s, camera)
    return egomotion_from_flow(
        q,
        q_dot,
        angular_velocity=angular_velocity,
        normal=normal,
        normal_prior=normal_prior,
        distance_m=distance_m,
        time_s=t_ref,
    )
