"""The whole handover on the simulation clock (issue 20 item 1): `handover-up --clock sim`
twice with one seed gives the same episode step for step (motion goals, grip commands, joint
commands, the outcome), and a participant killed mid-episode is noticed: the clock goes on
without it and the supervisor stops."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from services.recorder.readback import read_component
from services.runtime.testing import free_tcp_port, kill_tree, run_launcher

pytestmark = pytest.mark.integration

#: What the determinism check compares: (entity, component) rows of the recording.
COMPARED = (
    ("/bus/motion/goal", "goal_id"), ("/bus/motion/goal", "position_base_m"),
    ("/bus/gripper/command", "grip_force_n"), ("/bus/gripper/command", "mode"),
    ("/bus/robot/joint_command", "position_rad"), ("/bus/gripper/release", "pull_force_n"),
    ("/bus/supervisor/state", "phase"),
)


def _run(tmp_path: Path, run_id: str, *args: str, timeout_s: float = 120.0) -> tuple[int, str, Path]:
    code, out = run_launcher(["--clock", "sim", "--port", str(free_tcp_port()), "--recording-dir", str(tmp_path),
                              "--run-id", run_id, *args], timeout_s)
    return code, out, tmp_path / f"handover-{run_id}.rrd"


def _episode(path: Path) -> dict[str, list]:
    """The compared rows up to the episode's summary (simulated ns), and the summary."""
    summary = read_component(path, "/bus/supervisor/episode", "outcome")
    assert summary, f"no episode summary in {path}"
    end_ns = summary[-1][0]
    rows = {f"{e}:{c}": [r for r in read_component(path, e, c) if r[0] <= end_ns] for e, c in COMPARED}
    rows["summary"] = [read_component(path, "/bus/supervisor/episode", c)
                       for c in ("outcome", "peak_grip_force_n", "phase_durations_s", "transfer_point_base_m")]
    return rows


def test_one_seed_gives_the_same_episode_step_for_step(tmp_path):
    first_code, first_out, first = _run(tmp_path, "a", "--seed", "11")
    assert first_code == 0, first_out
    second_code, second_out, second = _run(tmp_path, "b", "--seed", "11")
    assert second_code == 0, second_out
    a, b = _episode(first), _episode(second)
    assert len(a["/bus/gripper/command:grip_force_n"]) > 100 and len(a["/bus/motion/goal:goal_id"]) >= 4
    assert a["/bus/supervisor/state:phase"][0][0] < 1_000_000_000  # simulated time: the run starts at 0
    for key in a:
        assert a[key] == b[key], f"{key} differs between two runs of one seed"
    assert "released" in str(a["summary"][0])


def _signal_mid_reach(tmp_path: Path, run_id: str, service: str, sig: signal.Signals) -> tuple[int, str]:
    """Run one sim-clock episode and send `sig` to `service` when the reach begins; (exit code,
    console). A stopped service is continued before the run is cleaned up."""
    cmd = [sys.executable, "-m", "services.launcher", "--clock", "sim", "--port", str(free_tcp_port()),
           "--recording-dir", str(tmp_path), "--run-id", run_id, "--seed", "5", "--verbose"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    victim = None
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 90.0
        for line in proc.stdout:
            lines.append(line)
            if victim is None and "episode 1: reach" in line:
                victim = next(c for c in psutil.Process(proc.pid).children(recursive=True)
                              if f"services.{service}" in " ".join(c.cmdline()))
                os.kill(victim.pid, sig)
            if time.monotonic() > deadline:
                break
        proc.wait(timeout=30)
    finally:
        if victim is not None and sig == signal.SIGSTOP and victim.is_running():
            os.kill(victim.pid, signal.SIGCONT)
        if proc.poll() is None:
            kill_tree(proc)
    out = "".join(lines)
    assert victim is not None, out
    return proc.returncode, out


def test_a_participant_killed_mid_episode_is_noticed_and_the_clock_goes_on(tmp_path):
    code, out = _signal_mid_reach(tmp_path, "k", "motion", signal.SIGKILL)
    assert code != 0, out
    # Whichever notices first: the supervisor's watchdog (in simulated time) or the launcher,
    # which sees its child die.
    assert ("PROTECTIVE_STOP: protective stop: motion: process gone" in out
            or "protective stop: motion was killed by SIGKILL" in out), out
    assert "stop: braking" in out, "the bridge brakes the arm"
    assert "simulation clock" not in out or "waited" not in out, "the clock must not wait for a dead participant"


def test_a_supervisor_stopped_mid_reach_is_silent_in_simulated_time_and_the_launcher_stops_the_arm(tmp_path):
    """The launcher's watch of the supervisor counts its silence in the stack's time: the clock
    goes on without a stopped (SIGSTOP) supervisor, and the watch stops the arm."""
    code, out = _signal_mid_reach(tmp_path, "s", "supervisor", signal.SIGSTOP)
    assert code != 0, out
    assert "no supervisor/state for" in out and "s of simulated time; the launcher stopped the arm" in out, out
    assert "stop: braking" in out, "the bridge brakes the arm"
