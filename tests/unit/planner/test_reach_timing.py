import numpy as np
import pytest

from services.planner.errors import PlannerError
from services.planner.reach_timing import minimum_jerk_position, minimum_jerk_speed, reach_timing


def test_duration_depends_only_on_normalised_peak_velocity():
    a = reach_timing(0.3, 1.5)
    b = reach_timing(0.6, 1.5)
    assert a.duration_s == pytest.approx(b.duration_s) == pytest.approx(1.875 / 1.5)
    assert b.peak_speed_m_s == pytest.approx(2 * a.peak_speed_m_s) == pytest.approx(0.9)


def test_peak_speed_matches_the_numerically_differentiated_profile():
    d, v = 0.55, 1.6
    timing = reach_timing(d, v)
    t = np.linspace(0.0, timing.duration_s, 200001)
    x = d * minimum_jerk_position(t / timing.duration_s)
    speed = np.gradient(x, t)
    assert speed.max() == pytest.approx(timing.peak_speed_m_s, rel=1e-6)
    assert x[-1] == pytest.approx(d)
    # Normalised by the distance (area under the speed curve), the peak is V_max.
    assert speed.max() / np.trapezoid(speed, t) == pytest.approx(v, rel=1e-5)
    np.testing.assert_allclose(np.gradient(minimum_jerk_position(t / timing.duration_s), t / timing.duration_s),
                               minimum_jerk_speed(t / timing.duration_s), atol=1e-6)


def test_speed_cap_lengthens_the_reach():
    capped = reach_timing(1.0, 2.0, max_peak_speed_m_s=0.5)
    assert capped.speed_capped and capped.peak_speed_m_s == 0.5
    assert capped.duration_s == pytest.approx(1.875 * 1.0 / 0.5)
    free = reach_timing(0.2, 2.0, max_peak_speed_m_s=0.5)
    assert not free.speed_capped and free.duration_s == pytest.approx(1.875 / 2.0)


@pytest.mark.parametrize("args", [(-0.1, 1.0), (0.3, 0.0), (0.3, -1.0), (0.3, 1.0, 0.0)])
def test_bad_timing_inputs_are_refused(args):
    with pytest.raises(PlannerError):
        reach_timing(*args)
