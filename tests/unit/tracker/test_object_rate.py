"""Object detection at full rate only while somebody reads the object (issue 16): the
supervisor's phase decides, a tracker without a supervisor keeps the full rate, and a switch
to the full rate detects on the next frame that is due."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import DepthImage
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import ArmGeometry, KinectScenario, KinectSim
from services.tracker.config import TrackerConfig, config_from_dict
from services.tracker.core import SUPERVISOR_STATE_FRESH_S, TrackerPipeline, object_wanted
from services.tracker.errors import TrackerConfigError
from services.tracker.pointcloud import depth_frame_from_message


@pytest.fixture(scope="module")
def arm():
    return ArmGeometry()


@pytest.fixture(scope="module")
def depth_frame(arm):
    sim = KinectSim(seed=3, scenario=KinectScenario(), arm_geometry=arm)
    frame = sim.step(0.0, np.array(RIGHT_ARM_HOME_RAD))
    return depth_frame_from_message(DepthImage(seq=0, stamp_ns=0, source="sim", **frame.depth_fields), 0.0)


def _detections(pipe: TrackerPipeline, frame, frames: int) -> list[int]:
    """The (1-based) frames of the next `frames` depth frames on which a detection ran."""
    ran = []
    for k in range(frames):
        pipe.on_depth(frame)
        if pipe.detect_object() is not None:
            ran.append(k + 1)
    return ran


@pytest.mark.parametrize("phase, age_s, wanted", [
    (None, 0.0, True),                                   # no supervisor heard: full rate
    ("locate", 0.0, True),                               # the supervisor reads the object now
    ("locate", 0.9, True),
    ("idle", 0.0, False), ("pick", 0.5, False), ("reach", 0.0, False), ("transfer", 0.0, False),
    ("retract", 0.0, False), ("done", 0.0, False), ("protective_stop", 0.0, False),
    ("idle", SUPERVISOR_STATE_FRESH_S + 0.01, True),     # a silent supervisor says nothing any more
    ("reach", 5.0, True),
])
def test_the_object_is_wanted_only_while_located_or_when_no_supervisor_speaks(phase, age_s, wanted):
    assert object_wanted(phase, age_s) is wanted


def test_full_rate_by_default_and_rest_rate_when_not_wanted(arm, depth_frame):
    full = TrackerPipeline(TrackerConfig(), arm)
    assert _detections(full, depth_frame, 31) == [1, 4, 7, 10, 13, 16, 19, 22, 25, 28, 31]
    rest = TrackerPipeline(TrackerConfig(), arm)
    rest.set_object_wanted(False)
    assert _detections(rest, depth_frame, 46) == [1, 16, 31, 46]


def test_a_switch_to_full_rate_detects_on_the_next_due_frame(arm, depth_frame):
    pipe = TrackerPipeline(TrackerConfig(object_rest_every_n_depth_frames=20), arm)
    pipe.set_object_wanted(False)
    assert _detections(pipe, depth_frame, 10) == [1]        # frame 1, then resting
    pipe.set_object_wanted(True)                             # 10 frames since: due at once
    assert _detections(pipe, depth_frame, 7) == [1, 4, 7]
    pipe.set_object_wanted(False)
    assert _detections(pipe, depth_frame, 25) == [20]        # 20 frames after the last due one


def test_the_rest_rate_is_never_faster_than_the_full_rate(arm, depth_frame):
    """A profile that slows the full rate below the default rest rate stays valid (the rest
    rate is then the full rate); a rest rate outside 1..1000 is refused in one line."""
    pipe = TrackerPipeline(config_from_dict({"object_every_n_depth_frames": 20}), arm)
    pipe.set_object_wanted(False)
    assert _detections(pipe, depth_frame, 41) == [1, 21, 41]
    for bad in (0, 1001):
        with pytest.raises(TrackerConfigError, match="object_rest_every_n_depth_frames must be in 1..1000"):
            config_from_dict({"object_rest_every_n_depth_frames": bad})


def test_every_object_phase_is_a_phase_of_the_supervisor():
    from typing import get_args

    from bus_schema.messages.supervisor import SupervisorPhase
    from services.tracker.core import OBJECT_PHASES

    assert set(OBJECT_PHASES) <= set(get_args(SupervisorPhase))
