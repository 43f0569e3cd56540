"""Simulated Kinect: ray casting, depth quantisation, back-projection, skeleton errors."""

from __future__ import annotations

import numpy as np
import pytest

from robot_sim.kinect.camera import KinectCamera, look_at_rotation
from robot_sim.kinect.depth import DepthRenderer, kinect_depth_mm
from handover_model.shapes import Box, Capsule, ray_box, ray_capsule
from robot_sim.kinect.skeleton_model import HAND_INDEX, SkeletonErrorModel, SkeletonErrorParams
from services.tracker.pointcloud import DepthFrame, backproject


def test_ray_capsule_matches_sphere_and_cylinder_by_hand():
    origin = np.zeros(3)
    dirs = np.array([[0.0, 0.0, 1.0], [0.0, 0.05, 1.0], [0.0, 0.5, 1.0]])
    sphere = Capsule(np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 2.0]), 0.1)
    t = ray_capsule(origin, dirs, sphere)
    assert t[0] == pytest.approx(1.9)
    # Ray (0, 0.05 s, s): |(0, 0.05 s, s - 2)| = 0.1 → 1.0025 s² − 4 s + 3.99 = 0.
    a, b, c = 1.0025, -4.0, 3.99
    assert t[1] == pytest.approx((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a))
    assert np.isinf(t[2])
    # A horizontal cylinder along x at z = 2: the straight ray hits its top surface at 1.9.
    cyl = Capsule(np.array([-1.0, 0.0, 2.0]), np.array([1.0, 0.0, 2.0]), 0.1)
    assert ray_capsule(origin, dirs[:1], cyl)[0] == pytest.approx(1.9)
    box = Box(np.array([-0.5, -0.5, 3.0]), np.array([0.5, 0.5, 3.2]))
    assert ray_box(origin, dirs[:1], box)[0] == pytest.approx(3.0)


def _capsule_by_parts(origin, dirs, capsule):
    """Reference: the smallest forward entry into either end sphere or the finite cylinder,
    each solved on its own (a slower formulation than `ray_capsule`'s)."""
    def sphere(centre):
        oc = origin - centre
        a, b, c = np.sum(dirs * dirs, -1), dirs @ oc, oc @ oc - capsule.radius_m**2
        h = b * b - a * c
        t = (-b - np.sqrt(np.maximum(h, 0.0))) / a
        return np.where((h >= 0) & (t > 0), t, np.inf)

    axis = capsule.b_m - capsule.a_m
    length = np.linalg.norm(axis)
    u = axis / length
    oa = origin - capsule.a_m
    d_perp = dirs - np.outer(dirs @ u, u)
    o_perp = oa - (oa @ u) * u
    a, b, c = np.sum(d_perp**2, -1), d_perp @ o_perp, o_perp @ o_perp - capsule.radius_m**2
    h = b * b - a * c
    t_cyl = (-b - np.sqrt(np.maximum(h, 0.0))) / np.where(a > 0, a, 1.0)
    along = oa @ u + t_cyl * (dirs @ u)
    t_cyl = np.where((h >= 0) & (a > 0) & (t_cyl > 0) & (along > 0) & (along < length), t_cyl, np.inf)
    return np.minimum(np.minimum(sphere(capsule.a_m), sphere(capsule.b_m)), t_cyl)


def test_ray_capsule_matches_the_parts_on_random_rays_and_capsules():
    rng = np.random.default_rng(3)
    origin = np.array([0.1, -0.2, 0.3])
    dirs = rng.normal(size=(4000, 3)) * [0.4, 0.4, 1.0] + [0.0, 0.0, 1.0]
    dirs[:5] = [0.0, 0.0, 1.0]  # along the axis of the last capsules below (parallel rays)
    hits = 0
    for k in range(40):
        a = origin + rng.uniform([-1, -1, 0.5], [1, 1, 3])
        b = a + rng.normal(size=3) * 0.3 if k < 35 else a + [0.0, 0.0, 0.4]
        cap = Capsule(a, b, float(rng.uniform(0.02, 0.3)))
        if k >= 35:
            cap = Capsule(origin + [0.0, 0.0, 1.0 + 0.1 * k - 3.5], origin + [0.0, 0.0, 1.4 + 0.1 * k - 3.5], 0.05)
        want, got = _capsule_by_parts(origin, dirs, cap), ray_capsule(origin, dirs, cap)
        assert np.array_equal(np.isinf(want), np.isinf(got)), k
        fin = np.isfinite(want)
        hits += fin.sum()
        np.testing.assert_allclose(got[fin], want[fin], rtol=1e-9, atol=1e-12)
    assert hits > 2000  # the rays do hit


def test_static_background_renders_like_the_whole_scene():
    cam = KinectCamera()
    renderer = DepthRenderer(cam)
    table = Box(np.array([0.5, -0.6, -0.2]), np.array([1.2, 0.2, -0.15]))
    leg = Capsule(np.array([0.6, -0.5, -0.9]), np.array([0.6, -0.5, -0.2]), 0.03)
    arm = Capsule(np.array([0.8, -0.3, 0.1]), np.array([0.9, -0.1, 0.3]), 0.05)
    obj = Box(np.array([0.7, -0.3, -0.15]), np.array([0.76, -0.24, -0.05]))
    whole = renderer.render([leg, arm], [table, obj], floor_z_m=-0.93)
    static = renderer.render([leg], [table], floor_z_m=-0.93)
    moving = renderer.render([arm], [obj], background=static)
    np.testing.assert_array_equal(moving, whole)
    assert np.isfinite(whole).mean() > 0.5 and not np.array_equal(moving, static)
    with pytest.raises(ValueError, match="background"):
        renderer.render([arm], background=static[:10])


def test_depth_is_quantised_like_a_kinect_v1():
    depth = np.full((2, 2), 2.0)
    mm = kinect_depth_mm(depth, None)
    # Disparity f·b/z = 571·0.075/2 = 21.4125 px → nearest 1/8 px = 21.375 → z = 2.00351 m.
    assert mm[0, 0] == 2004
    assert kinect_depth_mm(np.full((1, 1), 0.3), None)[0, 0] == 0  # under the 0.5 m range
    assert kinect_depth_mm(np.full((1, 1), np.inf), None)[0, 0] == 0


def test_backprojection_recovers_a_rendered_plane_and_sphere():
    pos = np.array([0.0, 0.0, 1.0])
    cam = KinectCamera(position_m=pos, rotation=look_at_rotation(pos, np.array([2.0, 0.0, 0.0])))
    renderer = DepthRenderer(cam)
    centre = np.array([1.6, 0.1, 0.3])
    depth = renderer.render([Capsule(centre, centre, 0.15)], floor_z_m=-0.5)
    frame = DepthFrame(depth, cam.fx_px, cam.fy_px, cam.cx_px, cam.cy_px, cam.position_m, cam.rotation)
    points, valid = backproject(frame)
    pts = points[valid]
    on_sphere = np.abs(np.linalg.norm(pts - centre, axis=1) - 0.15) < 1e-4
    on_floor = np.abs(pts[:, 2] + 0.5) < 1e-4
    assert on_sphere.sum() > 200
    assert np.all(on_sphere | on_floor)  # every back-projected point lies on the known geometry


def test_skeleton_lags_by_the_latency_and_is_pulled_toward_the_robot_hand():
    params = SkeletonErrorParams(jitter_rms_range_m=(1e-9, 1e-9), pull_radius_m=0.25, pull_max=0.7)
    model = SkeletonErrorModel(params, np.random.default_rng(3))
    speed = 0.5
    far_tool = np.array([5.0, 0.0, 0.0])
    est = None
    for k in range(31):
        t = k / 30.0
        joints = np.zeros((15, 3))
        joints[:, 0] = speed * t
        _, est, _ = model.step(t, joints, far_tool)
    assert est[HAND_INDEX, 0] == pytest.approx(speed * (1.0 - model.latency_s), abs=1e-6)
    assert 0.10 <= model.latency_s <= 0.15
    # Robot hand 10 cm from a still hand: pulled by 0.7·(1 − 0.1/0.25) = 0.42 of the gap.
    model = SkeletonErrorModel(params, np.random.default_rng(4))
    tool = np.array([0.1, 0.0, 0.0])
    for k in range(10):
        _, est, conf = model.step(k / 30.0, np.zeros((15, 3)), tool)
    assert est[HAND_INDEX, 0] == pytest.approx(0.042, abs=1e-6)
    assert conf[HAND_INDEX] < 1.0


def test_jitter_has_the_requested_rms():
    params = SkeletonErrorParams(jitter_rms_range_m=(0.08, 0.08), pull_radius_m=0.01)
    model = SkeletonErrorModel(params, np.random.default_rng(0))
    errs = []
    for k in range(3000):
        _, est, _ = model.step(k / 30.0, np.zeros((15, 3)), np.array([9.0, 9.0, 9.0]))
        errs.append(np.linalg.norm(est, axis=1))
    rms = float(np.sqrt(np.mean(np.square(errs))))
    assert rms == pytest.approx(0.08, rel=0.1)
