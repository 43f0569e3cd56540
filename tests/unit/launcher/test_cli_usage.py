"""handover-up refuses unusable command-line values with one line and exit 2, before it
starts anything (no router, no service, no recording folder)."""

from __future__ import annotations

import subprocess
import sys

import pytest


def _up(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "services.launcher", "--job", "none", *args],
                          capture_output=True, text=True, timeout=60, cwd=cwd)


@pytest.mark.parametrize(("args", "says"), [
    (("--recording-dir", "/proc/nope"), "--recording-dir '/proc/nope': cannot write a recording there"),
    (("--episodes", "-5"), "--episodes must be within 0–100000"),
    (("--seed", "-1"), "--seed must be within"),
    (("--port", "70000"), "--port '70000' must be a port number"),
    (("--alive-timeout-s", "0"), "--alive-timeout-s must be within"),
])
def test_a_bad_value_exits_2_with_one_line_and_starts_nothing(args, says):
    out = _up(*args)
    assert out.returncode == 2, out.stderr + out.stdout
    assert says in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert "started" not in out.stdout and "router" not in out.stdout, out.stdout


def test_a_recording_dir_that_is_a_file_is_refused(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    out = _up("--recording-dir", str(blocker / "sub"))
    assert out.returncode == 2 and "cannot write a recording there" in out.stderr, out.stderr
    assert blocker.read_text() == "x"
