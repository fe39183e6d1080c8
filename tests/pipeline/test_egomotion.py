"""Differential planar ego-motion: exact recovery, the two solutions, degenerate motions,
input checks, and a benchmark run."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from pipeline import Camera
from pipeline.egomotion import (
    egomotion_from_flow,
    estimate_egomotion,
    hat,
    image_flow,
    planar_essential,
)
from pipeline.egomotion_bench import main as bench_main

E3 = np.array([0.0, 0.0, 1.0])
CAM = Camera.from_fov(640, 480, 60.0)
# An H-like set of corners on the pad (metres, pad frame z = 0).
PAD = np.array(
    [
        [-0.14, 0.14],
        [-0.07, 0.14],
        [-0.07, 0.03],
        [0.07, 0.03],
        [0.07, 0.14],
        [0.14, 0.14],
        [0.14, -0.14],
        [0.07, -0.14],
        [0.07, -0.03],
        [-0.07, -0.03],
        [-0.07, -0.14],
        [-0.14, -0.14],
    ]
)


def flow(q: np.ndarray, w: np.ndarray, vd: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Exact image velocities (eq. 6.15) of normalised points q."""
    B = hat(w) + np.outer(vd, n)
    return -np.array([(np.eye(3) - np.outer(p, E3)) @ B @ p for p in q])


def points_on_plane(rng: np.random.Generator, n: np.ndarray, d: float, count: int = 8):
    """Normalised images of ``count`` points of the plane n.X = d in front of the camera."""
    q = np.column_stack([rng.uniform(-0.4, 0.4, (count, 2)), np.ones(count)])
    q = q[q @ n > 0.2]
    return q


def rotation(w: np.ndarray) -> np.ndarray:
    R, _ = cv2.Rodrigues(np.asarray(w, float).reshape(3, 1))
    return R


def track(
    c0: np.ndarray, v_pad: np.ndarray, R0: np.ndarray, w_cam: np.ndarray, times: np.ndarray
) -> np.ndarray:
    """Pixels of PAD seen by a camera at c0 + v t with attitude R0 expm(w t)."""
    frames = []
    for t in times:
        R = R0 @ rotation(w_cam * t)
        X = (np.column_stack([PAD, np.zeros(len(PAD))]) - (c0 + v_pad * t)) @ R
        uv = X @ CAM.K.T
        frames.append(uv[:, :2] / uv[:, 2:])
    return np.array(frames)


LOOK_DOWN = np.diag([1.0, -1.0, -1.0])  # camera x = pad x, camera y = -pad y, z down


def test_the_seed_system_has_rank_8_and_b_plus_identity_fits_as_well() -> None:
    rng = np.random.default_rng(0)
    n = np.array([0.1, -0.2, 1.0]) / np.linalg.norm([0.1, -0.2, 1.0])
    q = points_on_plane(rng, n, 2.0)
    w, vd = np.array([0.2, -0.1, 0.3]), np.array([0.3, 0.2, -0.1])
    q_dot = flow(q, w, vd, n)
    # the seed says B is unique; B + c I explains the flow equally well
    q_dot_shifted = flow(q, w, vd, n) + 0.0
    B = hat(w) + np.outer(vd, n)
    again = -np.array([(np.eye(3) - np.outer(p, E3)) @ (B + 0.7 * np.eye(3)) @ p for p in q])
    assert np.allclose(again, q_dot_shifted)
    # and the normalised estimate is the physical B
    assert np.allclose(planar_essential(q, q_dot), B, atol=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_both_physical_solutions_come_out_and_the_prior_picks_the_true_one(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = rng.normal(size=3) * 0.2 + E3
    n /= np.linalg.norm(n)
    w = rng.normal(size=3) * 0.3
    vd = rng.normal(size=3) * 0.5
    q = points_on_plane(rng, n, 2.0)
    q_dot = flow(q, w, vd, n)
    blind = egomotion_from_flow(q, q_dot)
    assert blind.ambiguous and blind.alternative is not None
    candidates = [
        (blind.v_over_d, blind.normal),
        (blind.alternative.v_over_d, blind.alternative.normal),
    ]
    assert any(
        np.allclose(c[0], vd, atol=1e-7) and np.allclose(c[1], n, atol=1e-7) for c in candidates
    )
    chosen = egomotion_from_flow(
        q, q_dot, normal_prior=n + rng.normal(size=3) * 0.05, distance_m=2.0
    )
    assert not chosen.ambiguous
    assert np.allclose(chosen.angular_velocity, w, atol=1e-7)
    assert np.allclose(chosen.v_over_d, vd, atol=1e-7)
    assert np.allclose(chosen.normal, n, atol=1e-7)
    assert np.allclose(chosen.velocity, 2.0 * vd, atol=1e-6)
    assert chosen.residual < 1e-9
    # the other solution explains the image flow exactly as well
    other = chosen.alternative
    assert other is not None and not np.allclose(other.normal, n, atol=1e-3)
    assert np.allclose(flow(q, other.angular_velocity, other.v_over_d, other.normal), q_dot)


def test_a_known_rotation_removes_the_ambiguity() -> None:
    rng = np.random.default_rng(7)
    n = np.array([0.2, 0.1, 1.0]) / np.linalg.norm([0.2, 0.1, 1.0])
    w, vd = np.array([-0.2, 0.25, 0.1]), np.array([0.4, -0.3, 0.05])
    q = points_on_plane(rng, n, 3.0)
    ego = egomotion_from_flow(q, flow(q, w, vd, n), angular_velocity=w)
    assert ego.method == "known_rotation" and not ego.ambiguous and ego.alternative is None
    assert np.allclose(ego.v_over_d, vd, atol=1e-7) and np.allclose(ego.normal, n, atol=1e-7)


@pytest.mark.parametrize("known_rotation", [False, True])
def test_a_known_normal_needs_only_three_points(known_rotation: bool) -> None:
    rng = np.random.default_rng(3)
    n = np.array([0.0, 0.1, 1.0]) / np.linalg.norm([0.0, 0.1, 1.0])
    w, vd = np.array([0.1, 0.05, -0.2]), np.array([0.2, 0.1, -0.3])
    q = points_on_plane(rng, n, 2.0)[: 4 if not known_rotation else 2]
    ego = egomotion_from_flow(
        q, flow(q, w, vd, n), normal=n, angular_velocity=w if known_rotation else None
    )
    assert ego.method == ("known_rotation_and_normal" if known_rotation else "known_normal")
    assert np.allclose(ego.v_over_d, vd, atol=1e-7)
    assert np.allclose(ego.angular_velocity, w, atol=1e-7)


def test_no_motion_gives_zero_and_no_normal() -> None:
    q = points_on_plane(np.random.default_rng(1), E3, 2.0)
    ego = egomotion_from_flow(q, np.zeros_like(q), distance_m=2.0)
    assert np.allclose(ego.angular_velocity, 0) and np.allclose(ego.velocity, 0)
    assert ego.normal is None and not ego.ambiguous
    prior = np.array([0.0, 0.6, 0.8])
    assert np.allclose(egomotion_from_flow(q, np.zeros_like(q), normal_prior=prior).normal, prior)


def test_pure_rotation_has_no_translation_and_an_unobservable_normal() -> None:
    q = points_on_plane(np.random.default_rng(2), E3, 2.0)
    w = np.array([0.3, -0.2, 0.5])
    ego = egomotion_from_flow(q, flow(q, w, np.zeros(3), E3))
    assert np.allclose(ego.angular_velocity, w, atol=1e-9)
    assert np.allclose(ego.v_over_d, 0, atol=1e-9)
    assert ego.normal is None and ego.alternative is None


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_translation_along_the_normal_has_a_single_solution(sign: float) -> None:
    n = np.array([0.1, 0.0, 1.0]) / np.linalg.norm([0.1, 0.0, 1.0])
    q = points_on_plane(np.random.default_rng(4), n, 2.0)
    vd = sign * 0.4 * n  # descending onto (or climbing away from) the pad
    ego = egomotion_from_flow(q, flow(q, np.zeros(3), vd, n))
    assert not ego.ambiguous and ego.alternative is None
    assert np.allclose(ego.v_over_d, vd, atol=1e-7) and np.allclose(ego.normal, n, atol=1e-7)
    assert np.allclose(ego.angular_velocity, 0, atol=1e-7)


def test_tracked_corners_give_the_camera_velocity_in_metres_per_second() -> None:
    # 3 m over the pad, tilted 8 degrees, turning, moving 1.2 m/s: three frames at 15 fps
    R0 = LOOK_DOWN @ rotation([0.1, -0.08, 0.0])
    v_pad = np.array([1.0, -0.6, -0.2])
    w_cam = np.array([0.15, -0.1, 0.3])
    c0 = np.array([0.05, -0.1, 3.0])
    times = np.array([-1, 0, 1]) / 15.0
    px = track(c0, v_pad, R0, w_cam, times)
    normal = -R0[2, :]
    ego = estimate_egomotion(
        px, times, CAM, angular_velocity=w_cam, normal=normal, distance_m=float(c0[2])
    )
    truth = R0.T @ v_pad
    assert np.linalg.norm(ego.velocity - truth) < 0.01  # the straight-line fit's O(dt^2)
    blind = estimate_egomotion(px, times, CAM, normal_prior=normal, distance_m=float(c0[2]))
    assert np.linalg.norm(blind.velocity - truth) < 0.05
    assert np.linalg.norm(blind.angular_velocity - w_cam) < 0.05
    assert math.degrees(math.acos(min(1.0, float(blind.normal @ normal)))) < 1.0
    assert ego.time_s == pytest.approx(0.0)


def test_image_flow_removes_lens_distortion() -> None:
    cam = Camera(640, 480, CAM.K, np.array([-0.2, 0.05, 0.0, 0.0, 0.0]))
    times = np.array([0.0, 0.1, 0.2])
    px = track(np.array([0.0, 0.0, 2.0]), np.array([0.5, 0.0, 0.0]), LOOK_DOWN, np.zeros(3), times)
    distorted = np.array(
        [
            cv2.projectPoints(
                np.column_stack(
                    [
                        cv2.undistortPoints(f.reshape(-1, 1, 2), CAM.K, None).reshape(-1, 2),
                        np.ones(len(f)),
                    ]
                ),
                np.zeros(3),
                np.zeros(3),
                cam.K,
                cam.dist,
            )[0].reshape(-1, 2)
            for f in px
        ]
    )
    q, q_dot, t_ref = image_flow(distorted, times, cam)
    q0, q_dot0, _ = image_flow(px, times, CAM)
    assert np.allclose(q, q0, atol=1e-5) and np.allclose(q_dot, q_dot0, atol=1e-4)
    assert t_ref == pytest.approx(0.1)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"corners_px": np.zeros((1, 12, 2))}, "corners_px"),
        ({"corners_px": np.zeros((3, 12))}, "corners_px"),
        ({"corners_px": np.full((3, 12, 2), np.nan)}, "corners_px"),
        ({"times_s": np.array([0.0, 0.2, 0.1])}, "times_s"),
        ({"times_s": np.array([0.0, 0.1])}, "times_s"),
        ({"camera": "cam"}, "camera"),
        ({"normal": [0.0, 0.0, 0.0]}, "normal"),
        ({"normal": [0.0, 0.0, -1.0]}, "normal"),
        ({"normal_prior": [1.0, np.nan, 0.0]}, "normal_prior"),
        ({"angular_velocity": [1.0, 2.0]}, "angular_velocity"),
        ({"distance_m": -1.0}, "distance_m"),
        ({"corners_px": np.ones((3, 3, 2)) + np.arange(3)[:, None, None]}, "at least 4"),
    ],
)
def test_bad_input_names_the_parameter(kwargs: dict, name: str) -> None:
    times = np.array([0.0, 0.1, 0.2])
    args = {
        "corners_px": track(
            np.array([0.0, 0.0, 2.0]), np.array([0.3, 0.0, 0.0]), LOOK_DOWN, np.zeros(3), times
        ),
        "times_s": times,
        "camera": CAM,
    }
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        estimate_egomotion(args.pop("corners_px"), args.pop("times_s"), args.pop("camera"), **args)


def test_noise_degrades_gracefully_with_gyro_and_attitude() -> None:
    # 6 m up, 0.5 px of corner noise, 15 fps: the known-rotation-and-normal estimate
    # stays within the bar (0.05 m/s + 5 % of speed) in the median.
    rng = np.random.default_rng(11)
    times = np.array([-1, 0, 1]) / 15.0
    errors, allowances = [], []
    for _ in range(60):
        v_pad = np.append(rng.uniform(-1.5, 1.5, 2), rng.uniform(-0.1, 0.1))
        w_cam = rng.normal(size=3) * 0.2
        px = track(np.array([0.0, 0.0, 6.0]), v_pad, LOOK_DOWN, w_cam, times)
        px += rng.normal(0, 0.5, px.shape)
        gyro = w_cam + rng.normal(0, 0.005, 3)
        ego = estimate_egomotion(px, times, CAM, angular_velocity=gyro, normal=E3, distance_m=6.0)
        err = LOOK_DOWN @ (ego.velocity - LOOK_DOWN.T @ v_pad)
        errors.append(float(np.linalg.norm(err[:2])))
        allowances.append(0.05 + 0.05 * float(np.linalg.norm(v_pad)))
    assert np.median(np.array(errors) - np.array(allowances)) <= 0


def test_result_serialises() -> None:
    q = points_on_plane(np.random.default_rng(5), E3, 2.0)
    ego = egomotion_from_flow(q, flow(q, np.array([0.1, 0, 0]), np.array([0.2, 0, 0]), E3))
    data = json.loads(json.dumps(ego.to_dict()))
    assert data["method"] == "planar_essential" and len(data["v_over_d"]) == 3


def test_the_benchmark_prints_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_main(["--samples", "5", "--rendered", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    cell = out["projected"]["altitude_m (15 fps, 0.5 px, 3 frames)"]["6.0"]
    assert cell["samples"] == 5
    assert set(cell) >= {"known_rotation_and_normal", "planar_essential", "pose_differencing"}
    assert "rendered" in out
