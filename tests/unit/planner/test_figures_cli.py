"""`handover-study figures planner`: writes the three planner figures and names the optimum."""

from __future__ import annotations

import re

import matplotlib.image as mpimg

from services.studies.cli import main


def test_figures_cli_writes_three_pngs_and_prints_the_figure3_optimum(tmp_path, capsys):
    assert main(["figures", "planner", "--out", str(tmp_path / "figs")]) == 0
    for name in ("figure3", "findings", "robot"):
        img = mpimg.imread(tmp_path / "figs" / f"planner_{name}.png")
        assert img.shape[0] > 200 and img.shape[1] > 200 and img.std() > 0.01  # not a blank canvas
    out = capsys.readouterr().out
    m = re.search(r"x = ([+-][0-9.]+) cm, z = ([0-9.]+) cm", out)
    assert m, out
    # The Figure 3 optimum lies between the two bodies and above the table (thesis Figure 3).
    assert abs(float(m.group(1))) < 30.0 and 20.0 < float(m.group(2)) < 100.0
