"""Ctrl-C under `run_main`: a service stops normally (exit 0, nothing said); a one-shot
subcommand is interrupted (one line, exit 130), so that a script does not take it for done."""

from __future__ import annotations

import subprocess
import sys

import pytest

PROBE = """
import argparse, sys
from services.runtime.cli import run_main
def run(args):
    raise KeyboardInterrupt
command = None if sys.argv[1] == "-" else sys.argv[1]
raise SystemExit(run_main(run, argparse.Namespace(command=command, service_name="probe")))
"""


@pytest.mark.parametrize("command, code, said", [
    ("-", 0, ""),
    ("run", 0, ""),
    ("inspect", 130, "probe inspect: interrupted"),
    ("screenshot", 130, "probe screenshot: interrupted"),
])
def test_ctrl_c_stops_a_service_and_interrupts_a_one_shot_command(command, code, said):
    done = subprocess.run([sys.executable, "-c", PROBE, command], capture_output=True, text=True, timeout=60)
    assert done.returncode == code, done.stderr
    assert done.stderr.strip() == said
    assert done.stdout == ""
