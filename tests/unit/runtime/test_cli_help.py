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
    ("services.studies.cli", ["--help"]),
    ("services.studies.cli", ["bench", "--help"]),
    ("services.studies.cli", ["oracle-tune", "--help"]),
    ("services.studies.cli", ["reproduce", "--help"]),
    ("services.studies.cli", ["failsafe", "--help"]),
    ("services.studies.cli", ["figures", "--help"]),
    ("services.studies.cli", ["experiment", "--help"]),
    ("services.studies.cli", ["record", "--help"]),
    ("services.studies.cli", ["evaluate", "--help"]),
    ("services.sim_kinect.cli", ["--help"]),
    ("services.supervisor.cli", ["--help"]),
    ("services.bridge.baxter.cli", ["--help"]),
    ("services.bridge.baxter.fake", ["--help"]),
    ("robot_sim.contact.cli", ["--help"]),
    ("services.studies.contact_command", ["--help"]),
    ("services.studies.contact_command", ["batch", "--help"]),
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


SUBCOMMAND_CLIS = ["services.motion.cli", "services.planner.cli", "services.recorder.cli", "services.tracker.cli",
                   "services.studies.cli"]


@pytest.mark.parametrize("module", SUBCOMMAND_CLIS)
def test_an_unknown_option_before_a_subcommand_is_named_not_taken_for_the_subcommand(module, capsys):
    """argparse takes `x` in `--replay x` for the subcommand and says "invalid choice: 'x'"."""
    with pytest.raises(SystemExit) as exit_info:
        importlib.import_module(module).main(["--no-such-option", "x"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("error: unrecognized option: --no-such-option (see --help)") and "\n" not in err
    with pytest.raises(SystemExit) as exit_info:
        importlib.import_module(module).main(["frobnicate"])  # a wrong subcommand is still said so
    assert exit_info.value.code == 2 and "invalid choice: 'frobnicate'" in capsys.readouterr().err
