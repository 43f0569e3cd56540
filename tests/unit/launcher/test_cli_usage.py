"""handover-up refuses unusable command-line values with one line and exit 2, before it
starts anything (no router, no service, no recording folder)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

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


def test_a_niced_critical_service_is_refused_by_handover_up_before_anything_starts(tmp_path):
    """The nice check is the launcher's (services/launcher/checks.py), made before anything starts."""
    sim = (Path(__file__).resolve().parents[3] / "deploy" / "sim.toml").read_text()
    bad = tmp_path / "niced.toml"
    bad.write_text(sim.replace('[services.planner]\nmodule = "services.planner"',
                               '[services.planner]\nmodule = "services.planner"\nnice = 5', 1))
    assert "nice = 5" in bad.read_text()
    out = _up("--profile", str(bad), "--recording-dir", str(tmp_path / "rec"))
    assert out.returncode == 2, out.stderr + out.stdout
    assert "services.planner.nice = 5, but the supervisor watches planner as critical" in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "started" not in out.stdout
    assert not (tmp_path / "rec").exists()


@pytest.mark.parametrize("side", ["listen", "connect"])
def test_an_off_loopback_zenoh_override_is_refused_before_anything_starts(tmp_path, side):
    """The loopback rule holds over the whole Zenoh config, overrides included (issue 17)."""
    sim = (Path(__file__).resolve().parents[3] / "deploy" / "sim.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(sim + f'\n[bus.zenoh.{side}]\nendpoints = ["tcp/0.0.0.0:7999"]\n')
    out = _up("--profile", str(bad), "--recording-dir", str(tmp_path / "rec"))
    assert out.returncode == 2, out.stderr + out.stdout
    assert f"[bus.zenoh.{side}] bus endpoint 'tcp/0.0.0.0:7999' is not on loopback" in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "started" not in out.stdout
    assert not (tmp_path / "rec").exists()


def test_a_profile_with_two_simulated_kinects_is_refused_before_anything_starts(tmp_path):
    """The default profile renders the Kinect in the tracker; adding the stand-alone Kinect
    service too would put two bodies on perception/skeleton."""
    sim = (Path(__file__).resolve().parents[3] / "deploy" / "sim.toml").read_text()
    assert 'sensor = "sim"' in sim
    both = tmp_path / "both.toml"
    both.write_text(sim + '\n[services.kinect]\nmodule = "services.sim_kinect"\n'
                    '[services.kinect.config]\nscene = "handover"\n')
    out = _up("--profile", str(both), "--recording-dir", str(tmp_path / "rec"))
    assert out.returncode == 2, out.stderr + out.stdout
    assert "tracker and kinect would both render a simulated Kinect" in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "started" not in out.stdout
    assert not (tmp_path / "rec").exists()  # nothing made


def test_skeleton_publishers_of_the_shipped_profiles():
    from services.launcher.core import skeleton_publishers
    from services.runtime.profile import load_profile_file

    assert skeleton_publishers(load_profile_file("sim").services) == ["tracker"]
    assert skeleton_publishers(load_profile_file("multihost").services) == []
