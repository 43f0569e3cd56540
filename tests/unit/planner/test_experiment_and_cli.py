import json
from dataclasses import replace

import pytest

from services.planner.anthropometrics import FIGURE3_ACTOR, ROBOT_AS_HUMAN
from services.planner.cli import main
from services.planner.transfer_plan import DyadGeometry, plan_transfer
from services.studies.cli import main as study_main
from services.studies.planner.experiment import four_positions, heavy_light_positions


def test_four_positions_follow_section_2_5_1():
    for posture, dz in (("standing", -0.15), ("sitting", 0.15)):
        plan = plan_transfer(ROBOT_AS_HUMAN, replace(FIGURE3_ACTOR, posture=posture), 0.065,
                             DyadGeometry(giver_is_robot=True))
        p1, p2, p3, p4 = four_positions(plan)
        x, z = plan.position_task_m
        assert p1.position_task_m == pytest.approx((x, z))
        assert p2.position_task_m == pytest.approx((x - 0.15, z))  # farther from the receiver
        assert p3.position_task_m == pytest.approx((x + 0.15, z))
        assert p4.position_task_m == pytest.approx((x, z + dz))
        assert p1.feasible and p1.cost == pytest.approx(plan.cost)
        assert all(p1.cost <= c.cost for c in (p2, p3, p4))


def test_heavy_light_positions_use_the_heavy_mass_for_costs():
    sit = replace(FIGURE3_ACTOR, posture="sitting")
    g = DyadGeometry(giver_is_robot=True)
    heavy = plan_transfer(ROBOT_AS_HUMAN, sit, 0.335, g)
    light = plan_transfer(ROBOT_AS_HUMAN, sit, 0.065, g)
    p1, p2 = heavy_light_positions(heavy, light)
    assert p2.position_task_m == pytest.approx(light.position_task_m)
    assert p1.cost <= p2.cost  # P1 is the optimum for the object actually handed over


def test_cli_plan_prints_the_figure3_point_and_saves_the_figure(capsys, tmp_path):
    fig = tmp_path / "map.png"
    rc = main(["plan", "--giver", "figure3", "--receiver", "1.87,1.90,80", "--object-mass", "0.2",
               "--figure", str(fig), "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    expected = plan_transfer(FIGURE3_ACTOR, FIGURE3_ACTOR, 0.2)
    assert out["position_task_m"] == pytest.approx(expected.position_task_m, abs=1e-4)
    assert fig.stat().st_size > 10_000 and fig.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    "argv, words",
    [
        (["plan", "--receiver", "1.75,0.5,70"], "arm span"),
        (["plan", "--receiver", "1.75,1.75,-1"], "weight"),
        (["plan", "--receiver", "tall"], "HEIGHT_M"),
        (["plan", "--receiver", "1.75,1.75,70", "--object-mass", "-1"], "object mass"),
        (["plan", "--receiver", "1.75,1.75,70", "--separation", "3"], "do not overlap"),
    ],
)
def test_cli_bad_input_is_one_line_and_exit_2(argv, words, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1


def test_cli_experiment_lists_p1_to_p4(capsys):
    assert study_main(["experiment", "--receiver", "figure3", "--receiver-posture", "sitting"]) == 0
    out = capsys.readouterr().out
    assert "task 2 (receiver sitting)" in out
    for name in ("P1", "P2", "P3", "P4"):
        assert f"  {name}:" in out
