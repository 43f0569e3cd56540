"""Object on the table from a simulated depth image (Kinect noise on)."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import DepthImage
from handover_model import scene
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import KinectScenario, KinectSim
from services.tracker.objects import detect_object
from services.tracker.pointcloud import depth_frame_from_message

#: Stated tolerance: centre within 2 cm, each extent within 2 cm.
TOL_M = 0.02


def _frame(object_position):
    sim = KinectSim(seed=11, scenario=KinectScenario(object_size_m=(0.08, 0.05, 0.15)))
    frame = sim.step(0.0, np.array(RIGHT_ARM_HOME_RAD), object_position_m=object_position)
    msg = DepthImage(seq=0, stamp_ns=0, source="test", **frame.depth_fields)
    return depth_frame_from_message(msg, 0.0)


@pytest.mark.parametrize("xy", [(0.72, -0.55), (0.55, -0.40), (0.60, -0.10)])
def test_object_found_within_tolerance(xy):
    centre = np.array([xy[0], xy[1], scene.TABLE_TOP_Z_M + 0.075])
    det = detect_object(_frame(centre), -scene.BASE_HEIGHT_ABOVE_FLOOR_M)
    assert det.found
    np.testing.assert_allclose(det.position_m, centre, atol=TOL_M)
    np.testing.assert_allclose(det.size_m, [0.08, 0.05, 0.15], atol=TOL_M)
    assert det.table is not None and det.table.c == pytest.approx(scene.TABLE_TOP_Z_M, abs=0.01)


def test_no_object_when_the_table_is_empty():
    det = detect_object(_frame(np.array([3.0, 3.0, -0.5])), -scene.BASE_HEIGHT_ABOVE_FLOOR_M)  # object off the table
    assert not det.found and det.reason
