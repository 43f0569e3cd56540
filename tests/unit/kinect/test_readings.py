"""A simulated Kinect frame's depth is made at its first read, and is the same whenever it is
read and whether or not other frames were read (`robot_sim.kinect.readings`)."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import DepthImage
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import KinectScenario, KinectSim
from services.tracker.pointcloud import depth_frame_from_message

HOME = np.array(RIGHT_ARM_HOME_RAD)
#: The receiver reaches from t = 0.1 s to 0.4 s: frames 3 to 12 of 30 Hz move the body.
REACH = KinectScenario(hand_target_base_m=(0.75, -0.26, 0.05), reach_start_s=0.1, reach_duration_s=0.3)


def _steps(sim: KinectSim, n: int) -> list:
    """n frames at 30 Hz with the arm moving every third frame (the scene changes often)."""
    return [sim.step(k / 30.0, HOME + (0.01 * (k // 3))) for k in range(n)]


@pytest.mark.parametrize("noise", [True, False])
def test_frames_read_late_or_out_of_order_equal_frames_read_at_once(noise):
    scenario = REACH if noise else KinectScenario(**{**REACH.__dict__, "depth_noise": False})
    eager_sim, lazy_sim = KinectSim(seed=4, scenario=scenario), KinectSim(seed=4, scenario=scenario)
    eager = [f.depth_fields["depth_mm"] for f in (eager_sim.step(k / 30.0, HOME + (0.01 * (k // 3)))
                                                  for k in range(14))]
    lazy = _steps(lazy_sim, 14)
    order = [13, 2, 7, 7, 0, 12, 5]  # late, backwards, twice
    for k in order:
        assert lazy[k].depth_fields["depth_mm"] == eager[k], k
    assert len(set(eager)) > 5  # the frames differ: reading the wrong one would show


def test_a_frame_nobody_reads_is_never_rendered_nor_drawn():
    sim = KinectSim(seed=2, scenario=REACH)
    frames = _steps(sim, 12)
    assert sim.depth.cast == 0 and sim.depth.reused == 0  # no render at all
    assert not any(f.readings.made for f in frames)
    frames[-1].readings.metres()
    assert frames[-1].readings.made and not frames[-2].readings.made
    assert sim.depth.cast > 0


def test_a_frame_keeps_its_inputs_when_the_caller_changes_its_arrays_later():
    eager_sim, lazy_sim = KinectSim(seed=1, scenario=REACH), KinectSim(seed=1, scenario=REACH)
    q, obj = HOME.copy(), np.array([0.75, -0.3, 0.0])
    want = eager_sim.step(0.0, q, object_position_m=obj).readings.payload
    frame = lazy_sim.step(0.0, q, object_position_m=obj)
    q += 0.3  # the caller reuses its arrays for the next frame
    obj[1] += 0.2
    assert frame.readings.payload == want


def test_a_frames_noise_does_not_depend_on_which_frames_were_read():
    reads_all, reads_one = KinectSim(seed=8, scenario=REACH), KinectSim(seed=8, scenario=REACH)
    all_frames = _steps(reads_all, 9)
    payloads = [f.readings.payload for f in all_frames]
    assert _steps(reads_one, 9)[8].readings.payload == payloads[8]
    assert len(set(payloads)) == 9  # fresh noise every frame


def test_the_skeleton_does_not_depend_on_whether_the_depth_was_read():
    reads, skips = KinectSim(seed=3, scenario=REACH), KinectSim(seed=3, scenario=REACH)
    for k in range(10):
        a, b = reads.step(k / 30.0, HOME), skips.step(k / 30.0, HOME)
        a.readings.payload
        assert a.skeleton_fields == b.skeleton_fields, k


def test_metres_are_bit_for_bit_the_trackers_decoding_of_the_payload():
    clean_sim = KinectSim(seed=6, scenario=KinectScenario(depth_noise=False))
    noisy_sim = KinectSim(seed=6, scenario=KinectScenario(depth_dropout_fraction=0.05))
    for k, (clean, noisy) in enumerate(zip(_steps(clean_sim, 4), _steps(noisy_sim, 4))):
        metres = {}
        for name, frame in (("clean", clean), ("noisy", noisy)):
            metres[name] = frame.readings.metres()  # read first, before the payload
            message = DepthImage(seq=k, stamp_ns=0, source="t", **frame.depth_fields)
            decoded = depth_frame_from_message(message, 0.0).depth_m
            assert metres[name].dtype == decoded.dtype == np.float32
            np.testing.assert_array_equal(metres[name], decoded)  # NaN where NaN, equal elsewhere
        # The dropouts (k = 0) read as NaN: 5 % of the pixels that have a reading without noise.
        seen = ~np.isnan(metres["clean"])
        dropped = np.isnan(metres["noisy"])[seen].mean()
        assert 0.04 < dropped < 0.06, k
