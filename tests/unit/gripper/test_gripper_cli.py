"""Analysis CLI and reproduction outputs."""

from __future__ import annotations

import math

import pytest

from services.gripper.controllers.fail_safe import FS_PRESETS
from services.studies.cli import main
from services.studies.gripper import analysis as A
from services.studies.gripper import reproduce
from services.studies.gripper.claims import claims_table


def test_fst_cli_prints_the_library_value(capsys):
    assert main(["failsafe", "fst", "--phi-deg", "20", "--preset", "FS1"]) == 0
    out = capsys.readouterr().out
    expected = A.start_force_threshold_n(math.radians(20), FS_PRESETS["FS1"])
    assert f"F_ST = {expected:8.4f} N" in out


def test_conditions_cli(capsys):
    assert main(["failsafe", "conditions", "--preset", "FS-sim-g5", "--max-pull-n"]) == 0
    out = capsys.readouterr().out
    assert "F_margin/β = 4.0000 m/s²" in out and "holds" in out


def test_bad_input_one_line_error(capsys):
    assert main(["failsafe", "fst", "--mass-kg", "-1"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("handover-study failsafe: error:") and err.count("\n") == 1


def test_reproduction_writes_recordings_and_table(tmp_path):
    claims, written = reproduce.reproduce(["FS-sim-g5"], img_dir=None, rrd_dir=tmp_path)
    rrds = sorted(p.name for p in written)
    assert rrds == [f"gripper_fig{n}_g5.rrd" for n in (20, 21, 22, 23)]
    assert all((tmp_path / name).stat().st_size > 1000 for name in rrds)
    by_thesis = {c.thesis: c for c in claims}
    assert by_thesis["γ = 5 gives F_ST(0) < 1 N"].agree == "yes"
    assert by_thesis["overshoot FS1 < FS3 < FS2"].agree == "yes"
    table = claims_table(claims)
    assert table.count("\n") == len(claims) + 2


@pytest.mark.long
def test_reproduction_pngs(tmp_path):
    assert main(["reproduce", "--preset", "FS-sim-g5", "--img-dir", str(tmp_path), "--no-rrd",
                "--table", str(tmp_path / "t.md")]) == 0
    assert (tmp_path / "gripper_fig20_g5.png").stat().st_size > 10_000
