"""Every command's --help says each default once, and never "(default: None)"."""

from __future__ import annotations

import importlib
import re

import pytest

COMMANDS = [
    ("services.launcher.cli", ["--help"]),
    ("services.bridge.cli", ["--help"]),
    ("services.recorder.cli", ["--help"]),
    ("services.planner.cli", ["--help"]),
    ("services.motion.cli", ["--help"]),
    ("services.motion.cli", ["plan", "--help"]),
    ("services.tracker.cli", ["--help"]),
    ("services.gripper.cli", ["--help"]),
    ("services.gripper.cli_bench", ["--help"]),
    ("services.sim_kinect.cli", ["--help"]),
    ("services.supervisor.cli", ["--help"]),
    ("services.bridge.baxter.cli", ["--help"]),
    ("services.bridge.baxter.fake", ["--help"]),
    ("robot_sim.contact.cli", ["--help"]),
]


@pytest.mark.parametrize(("module", "argv"), COMMANDS, ids=[f"{m} {' '.join(a)}" for m, a in COMMANDS])
def test_help_states_each_default_once(module, argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        importlib.import_module(module).main(argv)
    assert exit_info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())  # unwrap argparse's line breaks
    assert "usage:" in text
    assert "(default: None)" not in text
    options = re.split(r"\s(?=--?[a-z])", text)
    twice = [o for o in options if o.lower().count("default") > 1 and "(default:" in o]
    assert twice == [], f"defaults said twice: {twice}"
