import pytest

from services.planner.config import PlannerConfig, load_config
from services.planner.errors import PlannerError


def test_empty_table_gives_defaults_and_ints_are_accepted_for_floats():
    assert load_config({}) == PlannerConfig()
    cfg = load_config({"object_mass_kg": 1, "model": {"grid_resolution_m": 0.02}})
    assert cfg.object_mass_kg == 1.0 and cfg.model.grid_resolution_m == 0.02


@pytest.mark.parametrize(
    "table, words",
    [
        ({"object_mas_kg": 0.1}, "object_mas_kg"),
        ({"giver": {"arm_span_m": 0.4}}, "giver"),
        ({"model": {"object_load": "table"}}, "object_load"),
        ({"model": {"max_reach_fraction": 2.0}}, "max_reach_fraction"),
        ({"frame": {"x_axis_base_xy": [0.0, 0.0]}}, "x axis"),
        ({"timing": {"max_peak_speed_m_s": -1.0}}, "max_peak_speed"),
        ({"replan": {"republish_period_s": 0.0}}, "republish_period_s"),
        ({"object_mass_kg": "heavy"}, "object_mass_kg"),
    ],
)
def test_bad_config_is_refused_naming_the_key(table, words):
    with pytest.raises(PlannerError, match=words):
        load_config(table)
