"""The cached depth pipeline (static scene cast once, moving primitives cast only when they
move, buffered quantisation) gives exactly the images of the full ray cast of every frame."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model import scene
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import KinectScenario, KinectSim
from robot_sim.kinect.block_cast import BlockCaster
from robot_sim.kinect.camera import KinectCamera
from robot_sim.kinect.depth import DepthRenderer, kinect_depth_mm
from robot_sim.kinect.quantise import DepthQuantiser
from handover_model.shapes import Box, Capsule, ray_box, ray_capsule

HOME = np.array(RIGHT_ARM_HOME_RAD)


@pytest.fixture(scope="module")
def sim() -> KinectSim:
    return KinectSim(seed=5, scenario=KinectScenario(depth_noise=False))


def _random_inputs(sim: KinectSim, rng: np.random.Generator) -> tuple[dict, np.ndarray, np.ndarray]:
    """Joints of the receiver reaching somewhere around the table (within and beyond reach:
    the upper body leans), an arm posture around home, an object on or above the table."""
    shoulder = sim.body.joints(sim.body.rest_hand_m)["right_shoulder"]
    hand = shoulder + rng.uniform([-0.9, -0.3, -0.7], [0.1, 0.3, 0.2])
    q = HOME + rng.uniform(-0.9, 0.9, 7)
    obj = np.asarray(scene.OBJECT_PICK_BASE_M) + rng.uniform([-0.2, -0.2, 0.0], [0.3, 0.2, 0.5])
    return sim.body.joints(hand), q, obj


def test_cached_render_equals_the_full_ray_cast_over_random_scenes(sim):
    rng = np.random.default_rng(11)
    joints, q, obj = _random_inputs(sim, rng)
    moved = 0
    for k in range(120):
        # Change all inputs, or one of them, or none: tiles are reused, re-cast or both.
        what = k % 5
        new_joints, new_q, new_obj = _random_inputs(sim, rng)
        joints = new_joints if what in (0, 1) else joints
        q = new_q if what in (0, 2) else q
        obj = new_obj if what in (0, 3) else obj
        got = sim.depth.render(*sim.moving_shapes(joints, q, obj))
        want = sim.reference_depth_m(joints, q, obj)
        assert np.array_equal(got, want), f"frame {k}: {(got != want).sum()} pixels differ"
        assert sim.depth.changed == (what != 4 or k == 0)
        moved += int(np.sum(got < sim.depth.background_m))
    assert moved > 120 * 2000  # the moving shapes do cover the image (~2000+ pixels a frame)
    assert sim.depth.reused > 500 and sim.depth.cast > 500


def test_block_caster_equals_ray_capsule_bit_for_bit():
    cam = KinectCamera()
    renderer = DepthRenderer(cam)
    caster = BlockCaster(cam.position_m, renderer.rays, renderer.dd)
    rng = np.random.default_rng(2)
    centre_ray = renderer.rays[120, 160]
    capsules = []
    for k in range(60):
        a = cam.position_m + rng.uniform([0.3, -1.0, -1.5], [1.5, 1.0, 0.0])
        b = a + rng.normal(size=3) * 0.3
        if k % 10 == 0:
            b = a.copy()  # a sphere
        if k % 10 == 1:
            b = a + 0.4 * centre_ray  # the axis along a camera ray: parallel rays
        capsules.append(Capsule(a, b, float(rng.uniform(0.01, 0.2))))
    hits = 0
    for capsule, rect in zip(capsules, renderer.capsule_rects(capsules), strict=True):
        if rect is None:
            continue
        u0, u1, v0, v1 = rect
        want = ray_capsule(cam.position_m, renderer.rays[v0:v1, u0:u1], capsule, renderer.dd[v0:v1, u0:u1])
        got = caster.capsule(capsule, rect)
        assert np.array_equal(got, want)
        hits += int(np.isfinite(want).sum())
    assert hits > 20000


def test_pixel_rectangles_hold_every_hit():
    cam = KinectCamera()
    renderer = DepthRenderer(cam)
    rng = np.random.default_rng(4)
    capsules = [Capsule(a, a + rng.normal(size=3) * 0.4, float(rng.uniform(0.02, 0.3)))
                for a in cam.position_m + rng.uniform([0.2, -1.5, -1.8], [2.0, 1.5, 0.3], (80, 3))]
    boxes = [Box(c - s, c + s) for c, s in zip(cam.position_m + rng.uniform([0.3, -1, -1.5], [2, 1, 0], (20, 3)),
                                                rng.uniform(0.02, 0.3, (20, 3)), strict=True)]
    full_rects = 0
    pairs = [(c, r, ray_capsule(cam.position_m, renderer.rays, c)) for c, r in
             zip(capsules, renderer.capsule_rects(capsules), strict=True)]
    pairs += [(b, r, ray_box(cam.position_m, renderer.rays, b)) for b, r in
              zip(boxes, renderer.box_rects(boxes), strict=True)]
    for shape, rect, full in pairs:
        inside = np.zeros(full.shape, bool)
        if rect is not None:
            u0, u1, v0, v1 = rect
            inside[v0:v1, u0:u1] = True
            full_rects += rect == (0, cam.width_px, 0, cam.height_px)
        assert not np.any(np.isfinite(full) & ~inside), shape
    assert full_rects < len(pairs) // 4  # the rectangles are not simply the whole image
    behind = Capsule(cam.position_m - 2.0 * renderer.rays[120, 160], cam.position_m - renderer.rays[120, 160], 0.1)
    assert renderer.capsule_rects([behind]) == [None]


@pytest.mark.parametrize("noise", [True, False])
def test_quantiser_gives_the_bytes_and_draws_of_kinect_depth_mm(noise):
    rng = np.random.default_rng(8)
    quantiser = DepthQuantiser((24, 32), dropout_fraction=0.05)
    depth = rng.uniform(0.2, 5.0, (24, 32))
    depth[rng.random((24, 32)) < 0.2] = np.inf
    g_new, g_old = np.random.default_rng(3), np.random.default_rng(3)
    for k in range(6):
        if k in (2, 4):
            depth = depth * 1.01  # a new ideal image; otherwise the same one again
        got = quantiser.quantise(depth, g_new if noise else None, changed=k in (0, 2, 4))
        want = kinect_depth_mm(depth, g_old if noise else None, 0.05 if noise else 0.0)
        assert got == want.astype("<u2").tobytes()
        assert np.count_nonzero(want) > 300
    assert g_new.bit_generator.state == g_old.bit_generator.state  # same draws, same order
    with pytest.raises(ValueError, match="quantiser"):
        quantiser.quantise(depth[:10], None)


def test_kinect_frames_equal_the_reference_pipeline_with_noise():
    sim = KinectSim(seed=9, scenario=KinectScenario(hand_target_base_m=(0.75, -0.26, 0.05), reach_start_s=0.1,
                                                    reach_duration_s=0.3))
    q = HOME.copy()
    payloads = set()
    for k in range(16):
        t_s = k / 30.0
        q = q + (0.02 if k % 4 == 0 else 0.0)
        joints = sim.body.joints(sim.true_hand(t_s))
        rng = sim.noise_rng(k)  # the draws that the frame will make
        want = kinect_depth_mm(sim.reference_depth_m(joints, q, scene.OBJECT_PICK_BASE_M), rng,
                               sim.scenario.depth_dropout_fraction)
        frame = sim.step(t_s, q)
        np.testing.assert_array_equal(frame.depth_mm, want)
        payloads.add(frame.depth_fields["depth_mm"])
    assert len(payloads) == 16  # fresh noise every frame, even when nothing moved
