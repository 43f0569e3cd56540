"""Config validation and the one-shot CLI."""

from __future__ import annotations

import numpy as np
import pytest

from services.motion.cli import main
from services.motion.config import MotionConfig
from services.motion.errors import MotionConfigError


def test_config_defaults_and_overrides():
    cfg = MotionConfig.from_dict({"rate_hz": 200.0, "workspace_min_m": [0.1, -1.0, -0.3]})
    assert cfg.period_s == pytest.approx(0.005)
    assert cfg.workspace_min_m == (0.1, -1.0, -0.3)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"rate_hz_typo": 1.0}, "unknown motion config key"),
        ({"rate_hz": -1.0}, "rate_hz must be finite and > 0"),
        ({"velocity_scale": 1.5}, "velocity_scale must be in (0, 1]"),
        ({"workspace_min_m": [2, 0, 0]}, "below workspace_max_m"),
        ({"ik_restarts": -1}, "ik_restarts must be an integer >= 0"),
        ({"servo_lag_s": 2.0}, "servo_lag_s must be in [0, 1]"),
    ],
)
def test_config_rejects_bad_values(table, message):
    pattern = message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[").replace("]", r"\]")
    with pytest.raises(MotionConfigError, match=pattern):
        MotionConfig.from_dict(table)


def test_cli_plan_prints_the_trajectory(capsys):
    rc = main(["plan", "--kind", "pick", "--to", "0.72", "-0.55", "-0.17", "--every", "0.5"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "pick goal reached" in out
    final = [line for line in out.splitlines() if line.startswith("final tool position")][0]
    xyz = np.array([float(v) for v in final.split("[")[1].rstrip("]").split(",")])
    assert np.linalg.norm(xyz - [0.72, -0.55, -0.17]) <= 1e-3


def test_cli_plan_unreachable_exits_2_with_one_line(capsys):
    rc = main(["plan", "--to", "2.0", "0.0", "0.0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and "outside the workspace" in err[0]
