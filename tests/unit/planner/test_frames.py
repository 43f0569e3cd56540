import numpy as np
import pytest

from handover_model import scene
from services.planner.errors import PlannerError
from services.planner.frames import TaskPlaneFrame


def test_default_frame_is_the_shared_scene_mapping():
    f = TaskPlaneFrame()
    pts = np.array([[0.0, 0.0], [-0.1, 0.5], [0.3, -0.2]])
    np.testing.assert_allclose(f.task_to_base(pts), scene.task_to_base(pts))
    np.testing.assert_allclose(f.base_to_task(scene.task_to_base(pts)), pts)


def test_rotated_plane_by_hand():
    f = TaskPlaneFrame(origin_base_m=(1.0, 2.0, 0.5), x_axis_base_xy=(0.0, 2.0))  # task x = base +y
    np.testing.assert_allclose(f.task_to_base(np.array([0.3, 0.2])), [1.0, 2.3, 0.7])
    np.testing.assert_allclose(f.base_to_task(np.array([1.0, 2.3, 0.7])), [0.3, 0.2])
    assert f.offset_from_plane_m(np.array([0.8, 2.3, 0.7])) == pytest.approx(0.2)


@pytest.mark.parametrize("kw", [dict(x_axis_base_xy=(0.0, 0.0)), dict(origin_base_m=(0.0, np.nan, 0.0))])
def test_bad_frames_are_refused(kw):
    with pytest.raises(PlannerError):
        TaskPlaneFrame(**kw)
