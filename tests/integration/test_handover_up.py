"""handover-up end to end: bridge + recorder as real processes on a loopback bus; the quiet
console of a default run and the log files beside its recording."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

from bus_schema import topics
from services.recorder.readback import read_scalars
from services.launcher.logins import OBSERVER, login_profile
from services.runtime import ServiceNode
from services.runtime.profile import load_profile_file
from services.runtime.testing import free_tcp_port, loopback_profile, wait_until

pytestmark = pytest.mark.integration


def _launch(tmp_path, *args):
    port = free_tcp_port()
    cmd = [sys.executable, "-m", "services.launcher", "--port", str(port), "--recording-dir",
           str(tmp_path), "--run-id", "t", *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return proc, loopback_profile(port)


def _children(proc):
    try:
        return psutil.Process(proc.pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []


def _alive(pids):
    out = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                out.append(pid)
        except psutil.NoSuchProcess:
            pass
    return out


def _finish(proc, timeout=30):
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        for child in _children(proc):
            child.kill()
        proc.kill()
        out, _ = proc.communicate()
        pytest.fail(f"handover-up did not exit in {timeout} s:\n{out}")
    return out


def test_demo_moves_the_arm_and_the_recording_holds_the_motion(tmp_path):
    proc, profile = _launch(tmp_path, "--job", "demo", "--verbose")
    published: list = []
    node = None
    try:
        node = ServiceNode(OBSERVER, login_profile(profile, tmp_path, "t", OBSERVER), install_signal_handlers=False,
                           connect_timeout_s=20)
        node.open()
        states = node.subscribe(topics.JOINT_STATE, queue_size=100_000)
        out = _finish(proc, 60)
        published = [r.msg for r in states.drain()]
    finally:
        if node:
            node.close()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, out
    assert re.search(r"all \d+ services alive", out) and "summary:" in out and "final error" in out
    # --verbose: every service's lines on the console too, as in their log files.
    logs = tmp_path / "handover-t-logs"
    for name in ("bridge", "recorder"):
        relayed = [line for line in out.splitlines() if line.startswith(f"[{name}]")]
        assert any(" INFO " in line for line in relayed), f"no INFO line of {name} relayed:\n{out}"
        assert relayed[0].split("] ", 1)[1].strip() in (logs / f"{name}.log").read_text()
    assert f"logs of every service: {logs}/" in out and "--verbose prints them" not in out
    recording = tmp_path / "handover-t.rrd"
    assert recording.is_file()

    # The arm really moved: right_s0 swings by ~0.8 rad in the demo.
    s0 = np.array([m.position_rad[0] for m in published])
    assert np.ptp(s0) > 0.6

    # What was published is what was recorded, matched by the sender's stamp.
    series = read_scalars(recording, "/robot/joint_position")
    assert set(series) == {f"/robot/joint_position/{n}" for n in published[0].names}
    for j, name in enumerate(published[0].names):
        times, values = series[f"/robot/joint_position/{name}"]
        recorded = dict(zip(times.tolist(), values.tolist(), strict=True))
        matched = [(recorded[m.stamp_ns], m.position_rad[j]) for m in published if m.stamp_ns in recorded]
        missing = [i for i, m in enumerate(published) if m.stamp_ns not in recorded]
        assert len(matched) == len(published), (f"{name}: only {len(matched)}/{len(published)} recorded; "
                                                f"missing indices {missing[:20]}")
        rec_vals, pub_vals = np.array(matched).T
        assert np.array_equal(rec_vals, pub_vals)


def test_killing_the_bridge_is_reported_and_the_stack_stops(tmp_path):
    proc, profile = _launch(tmp_path, "--job", "none")
    try:
        assert wait_until(lambda: len(_children(proc)) >= 2, 20)
        bridge = None

        def find_bridge():
            nonlocal bridge
            for child in _children(proc):
                try:
                    if "services.bridge" in " ".join(child.cmdline()):
                        bridge = child
                        return True
                except psutil.NoSuchProcess:
                    pass
            return False

        assert wait_until(find_bridge, 20)
        time.sleep(2.0)  # let the stack come up fully
        pids = [c.pid for c in _children(proc)]
        bridge.send_signal(signal.SIGKILL)
        out = _finish(proc, 30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, out
    assert "bridge was killed by SIGKILL" in out
    assert "FAILURE" in out
    assert _alive(pids) == []


def test_ctrl_c_leaves_no_process_behind(tmp_path):
    proc, profile = _launch(tmp_path, "--job", "none")
    try:
        assert wait_until(lambda: len(_children(proc)) >= 2, 20)
        time.sleep(2.5)
        pids = [c.pid for c in _children(proc)]
        assert len(pids) >= 2
        proc.send_signal(signal.SIGINT)
        out = _finish(proc, 30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, out
    assert "SIGINT received: shutting down" in out
    # Quiet: one line for the services that stopped as asked; each one's line in launcher.log.
    assert re.search(r"\[launcher\] \d+ services stopped in [\d.]+ s \(each exited with code 0 on SIGINT\)", out), out
    launcher_log = (tmp_path / "handover-t-logs" / "launcher.log").read_text()
    assert "stopped bridge" in launcher_log and "stopped recorder" in launcher_log
    assert wait_until(lambda: _alive(pids) == [], 5.0), f"left behind: {_alive(pids)}"
    assert (tmp_path / "handover-t.rrd").is_file()


def test_launcher_reports_a_busy_port_in_one_line(tmp_path):
    port = free_tcp_port()
    profile = loopback_profile(port)
    from services.runtime.testing import BusRouter

    with BusRouter(profile):
        res = subprocess.run([sys.executable, "-m", "services.launcher", "--port", str(port), "--job", "check",
                              "--recording-dir", str(tmp_path)], capture_output=True, text=True, timeout=30)
    assert res.returncode == 2  # the port given is in use: a usage error (exit 2), with the way out named
    assert "cannot host the bus" in res.stdout + res.stderr and "--port auto" in res.stdout + res.stderr


def test_bad_arguments_exit_2_with_one_line():
    res = subprocess.run([sys.executable, "-m", "services.launcher", "--profile", "nope"],
                         capture_output=True, text=True, timeout=30)
    assert res.returncode == 2
    lines = [line for line in (res.stdout + res.stderr).splitlines() if line.strip()]
    assert len(lines) == 1 and "profile 'nope' not found" in lines[0]


def _thread_niceness(pid: int) -> dict[int, int]:
    """Niceness of every thread of `pid` (Linux niceness is per thread), from /proc."""
    out = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            stat = (task / "stat").read_text()
        except OSError:
            continue  # the thread ended meanwhile
        fields = stat[stat.rindex(")") + 2:].split()
        out[int(task.name)] = int(fields[16])  # field 19 of proc(5) stat: nice
    return out


def test_every_service_runs_at_its_profile_niceness(tmp_path):
    """The launcher starts each child (and so every thread it makes) at the profile's `nice`."""
    expected = {s.name: s.nice for s in load_profile_file("sim").services if s.enabled}
    assert expected["recorder"] == 10 and expected["bridge"] == 0  # the profile under test
    proc, _profile = _launch(tmp_path, "--job", "none")
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")), daemon=True)
    reader.start()
    try:
        assert wait_until(lambda: any(re.search(r"all \d+ services alive", x) for x in lines), 60), "".join(lines)
        started = {m["name"]: int(m["pid"]) for m in (re.match(r"\[launcher\] started (?P<name>\w+) \(pid "
                                                               r"(?P<pid>\d+)\)", x) for x in list(lines)) if m}
        assert set(started) == set(expected)
        base = psutil.Process().nice()
        for name, pid in started.items():
            want = max(expected[name], base)
            assert psutil.Process(pid).nice() == want, name
            threads = _thread_niceness(pid)
            assert len(threads) > 1 and set(threads.values()) == {want}, (name, threads)
            marker = f"started {name} (pid {pid})" + (f" at nice {want}:" if want else ":")
            assert any(marker in x for x in lines), marker
        proc.send_signal(signal.SIGINT)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            for child in _children(proc):
                child.kill()
            proc.kill()
            proc.wait(10)
        reader.join(5)
    assert proc.returncode == 130, "".join(lines)


#: Most lines a successful default run may print (issue 19: quiet by default).
QUIET_MAX_LINES = 40


def test_a_default_run_is_quiet_and_each_service_logs_to_its_own_file(tmp_path):
    """One default handover (one episode, taking receiver): exit 0, no WARNING and at most
    `QUIET_MAX_LINES` lines on the console, every service's lines in its log file."""
    proc, _profile = _launch(tmp_path)
    try:
        out = _finish(proc, 150)
    finally:
        if proc.poll() is None:
            proc.kill()
    lines = out.splitlines()
    print(f"\n--- the console of a default run ({len(lines)} lines) ---\n{out}")
    assert proc.returncode == 0, out
    assert "summary: 1 episode(s): released; object never dropped" in out
    warnings = [line for line in lines if "WARNING" in line]
    assert not warnings, "a successful run warned (a warning must need the user's action):\n" + "\n".join(warnings)
    assert len(lines) <= QUIET_MAX_LINES, f"{len(lines)} lines on the console:\n{out}"
    assert not [line for line in lines if " INFO " in line], f"INFO records on a quiet console:\n{out}"
    logs = tmp_path / "handover-t-logs"
    assert f"[launcher] logs of every service: {logs}/ (--verbose prints them here too)" in lines
    expected = {s.name for s in load_profile_file("sim").services if s.enabled}
    assert {p.stem for p in logs.glob("*.log")} == expected | {"launcher", "router"}
    bridge, supervisor = (logs / "bridge.log").read_text(), (logs / "supervisor.log").read_text()
    assert "bridge running backend=sim" in bridge and "bridge stopped" in bridge, bridge[-2000:]
    assert "episode summary episode_id=1 outcome=released" in supervisor, supervisor[-2000:]
    assert "stop: braking reason=release" in bridge  # a release stop: logged, not a warning
    launcher_log = (logs / "launcher.log").read_text()
    assert "summary: 1 episode(s)" in launcher_log and "stopped supervisor" in launcher_log
