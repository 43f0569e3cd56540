"""`handover-study sweep` (services/studies/gripper/sweep*.py): the grid's parsing and its errors,
the sweep's figures against the law (a hold of almost nothing drops the objects of the receivers
who let go), the same episodes at every point (a point with the controller's own values equals
the reference run), the CSV / table / plot / docs region, and the checkpoint's resume."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from services.gripper.errors import GripperError
from services.studies.cli import main as study_main
from services.studies.gripper import sweep
from services.studies.gripper.populations import population
from services.studies.gripper.sweep import run_sweep
from services.studies.gripper.sweep_grid import grid_points, parse_axis

SLOW = population("wide", ["slow"])  # one gripper class at 25 Hz: the cheapest episodes


def test_range_is_log_spaced_where_the_search_box_says_so():
    axis = parse_axis("hold_per_weight=2:18:3", "SG")
    assert axis.log and axis.values == pytest.approx((2.0, 6.0, 18.0))
    lin = parse_axis("release_share=0.1:0.5:5", "SG")
    assert not lin.log and lin.values == pytest.approx((0.1, 0.2, 0.3, 0.4, 0.5))
    assert parse_axis("hold_per_weight=2:18:3:lin", "SG").values == pytest.approx((2.0, 10.0, 18.0))
    assert parse_axis("release_share=0.1:1:2:log", "SG").log
    assert parse_axis("max_hold_force_n=30,10,20", "SG-tuned-d3").values == (30.0, 10.0, 20.0)  # as given
    assert parse_axis("max_hold_force_n=25", "SG").values == (25.0,)


@pytest.mark.parametrize(("spec", "message"), [
    ("hold=1:2:3", "SG has no parameter 'hold'"),
    ("hold_per_weight", "expected NAME=LO:HI:N"),
    ("hold_per_weight=5:2:3", "LO must be below HI"),
    ("hold_per_weight=2:5:0", "N must be >= 1"),
    ("hold_per_weight=2:5:-4", "N must be >= 1"),
    ("hold_per_weight=2:5:x", "not a whole number"),
    ("hold_per_weight=a:5:3", "'a' is not a number"),
    ("hold_per_weight=2:5:3:cubic", "not log or lin"),
    ("release_share=0:0.5:3:log", "needs LO > 0"),
    ("hold_per_weight=2:5", "LO:HI:N or LO:HI:N:log|lin"),
    ("hold_per_weight=2,2", "repeated"),
    ("hold_per_weight=nan,3", "not a finite number"),
    ("hold_per_weight=1:2:5000", "at most 200"),
])
def test_bad_axis_is_one_clear_error(spec, message):
    with pytest.raises(GripperError, match=message.replace("(", r"\(").replace("|", r"\|")):
        parse_axis(spec, "SG")


def test_grid_is_every_combination_and_refuses_what_the_controller_refuses():
    axes = [parse_axis("hold_per_weight=2,4", "SG"), parse_axis("max_hold_force_n=10,20,30", "SG")]
    points = grid_points("SG", axes)
    assert len(points) == 6 and points[0] == {"hold_per_weight": 2.0, "max_hold_force_n": 10.0}
    assert points[-1] == {"hold_per_weight": 4.0, "max_hold_force_n": 30.0}
    with pytest.raises(GripperError, match="max_hold_force_n=0.5"):
        grid_points("SG", [parse_axis("max_hold_force_n=0.5,10", "SG")])  # below the minimum hold
    with pytest.raises(GripperError, match="one or two"):
        grid_points("SG", axes + [parse_axis("release_share=0.2,0.3", "SG")])
    with pytest.raises(GripperError, match="twice"):
        grid_points("SG", axes[:1] * 2)


def test_cli_bad_input_exits_2_with_one_line(capsys, tmp_path):
    for argv in (["--param", "nope=1:2:3"], ["--param", "hold_per_weight=3:2:4"], ["--param", "hold_per_weight=2,3",
                 "-n", "0"], ["--param", "hold_per_weight=2,3", "--doc", str(tmp_path / "missing.md")]):
        try:
            code = study_main(["sweep", *argv, "--out", str(tmp_path / "o")])
        except SystemExit as exc:  # argparse's own checks (-n 0)
            code = exc.code
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "error" in err, (argv, err)
    assert not (tmp_path / "o").exists()  # nothing written


def test_a_weak_hold_drops_the_letting_go_receivers_objects():
    result = run_sweep("SG", grid_points("SG", [parse_axis("hold_per_weight=0.02,5.5,15", "SG")]), 48, seed=3,
                       dist=SLOW, population="wide", chunk_size=48, references=(), workers=1, show_progress=False)
    weak, own_value, strong = result.points
    own = result.references[0]
    assert [r.label for r in result.references] == ["SG (own)"]
    assert weak.drop_rate_by_behaviour["dropping"] >= 0.85 and weak.drop_rate > 2 * own.drop_rate
    assert weak.drop_rate >= own_value.drop_rate >= strong.drop_rate  # monotone in the hold
    # The same episodes at every point: the grid point at SG's own value IS the reference run.
    assert own_value.drops == own.drops and own_value.overshoot_p95_n == own.overshoot_p95_n
    assert own_value.episodes == weak.episodes == 48 and own.taking_episodes == weak.taking_episodes
    lo, hi = weak.drop_ci
    assert lo < weak.drop_rate < hi and 0 <= lo and hi <= 1


def test_cli_writes_csv_table_plot_and_doc_region_and_resumes(tmp_path, monkeypatch, capsys):
    doc = tmp_path / "page.md"
    doc.write_text("# Page\n\n<!-- gripper-sweep:begin -->\nold\n<!-- gripper-sweep:end -->\n\nafter\n")
    calls = []
    real = sweep.evaluate
    monkeypatch.setattr(sweep, "evaluate", lambda *a, **k: calls.append(1) or real(*a, **k))
    argv = ["sweep", "--param", "hold_per_weight=0.02,5.5", "--param", "max_hold_force_n=20,40", "-n", "24",
            "--grippers", "slow", "--workers", "1", "--out", str(tmp_path / "out"), "--checkpoint",
            str(tmp_path / "ckpt"), "--img-dir", str(tmp_path / "img"), "--doc", str(doc), "--no-progress"]
    assert study_main(argv) == 0
    assert len(calls) == 4 + 2  # 4 grid points and 2 references, one chunk each
    rows = list(csv.DictReader((tmp_path / "out" / "sweep.csv").open()))
    assert [r["kind"] for r in rows] == ["point"] * 4 + ["reference"] * 2
    drops = np.array([float(r["drop_rate"]) for r in rows[:4]])
    assert drops[:2].min() > drops[2:].max()  # hold 0.02 × weight drops more, whatever the cap
    assert all(float(r["drop_ci_low"]) <= float(r["drop_rate"]) <= float(r["drop_ci_high"]) for r in rows)
    table = (tmp_path / "out" / "table.md").read_text()
    assert table.count("\n") == 2 + 6 and "*HI*" in table
    plot = tmp_path / "img" / "sweep_SG_hold_per_weight_x_max_hold_force_n.png"
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = doc.read_text()
    assert "\nold\n" not in text and "--grippers slow" in text and "](img/" in text
    assert text.endswith("<!-- gripper-sweep:end -->\n\nafter\n")
    first = (tmp_path / "out" / "sweep.csv").read_text()
    assert "episodes/s" in capsys.readouterr().out
    assert study_main(argv) == 0 and len(calls) == 6  # resumed: nothing run again
    assert (tmp_path / "out" / "sweep.csv").read_text() == first
    assert "resumed from" in capsys.readouterr().out
    other = [a if a != "hold_per_weight=0.02,5.5" else "hold_per_weight=0.02,6" for a in argv]
    assert study_main(other) == 2 and "other arguments" in capsys.readouterr().err  # not this checkpoint's grid


def test_an_interrupted_sweep_resumes_with_only_the_unfinished_tasks(tmp_path, monkeypatch, capsys):
    real, calls = sweep.evaluate, []

    def failing_third(*a, **k):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("worker lost")
        return real(*a, **k)

    argv = ["sweep", "--param", "hold_per_weight=0.02,5.5", "-n", "24", "--grippers", "slow", "--workers", "1",
            "--no-plot", "--no-progress", "--checkpoint", str(tmp_path / "ckpt")]
    monkeypatch.setattr(sweep, "evaluate", failing_third)
    assert study_main([*argv, "--out", str(tmp_path / "a")]) == 1  # 2 of the 4 tasks finished, then one failed
    assert "worker lost" in capsys.readouterr().err and not (tmp_path / "a").exists()
    calls.clear()
    monkeypatch.setattr(sweep, "evaluate", lambda *a, **k: calls.append(1) or real(*a, **k))
    assert study_main([*argv, "--out", str(tmp_path / "a")]) == 0 and len(calls) == 2  # only the unfinished two
    assert study_main([*argv[:-2], "--out", str(tmp_path / "b")]) == 0  # the same sweep without a checkpoint
    a, b = ((tmp_path / d / "sweep.csv").read_text() for d in ("a", "b"))
    assert a == b
