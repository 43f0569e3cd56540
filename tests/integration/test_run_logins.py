"""Per-run logins of the default profile (issue 17): a default `handover-up` stack takes no
session without a login of the run, and a service's login cannot publish another's keys."""

from __future__ import annotations

import dataclasses
import os
import re
import signal
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from bus_schema import decode, encode_for, topics
from services.launcher.logins import OBSERVER, login_profile, logins_dir
from services.runtime.errors import BusError
from services.runtime.node import open_session
from services.runtime.profile import Profile, free_tcp_port
from services.runtime.testing import interrupt_then_kill, loopback_profile, wait_until

REPO = Path(__file__).resolve().parents[2]


def _launch(tmp_path: Path, run_id: str, *args: str) -> tuple[subprocess.Popen, Profile]:
    """`handover-up` (default profile, absent receiver) as a real process on a free port, its
    output in a text pipe; the caller stops it (`interrupt_then_kill`)."""
    port = free_tcp_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("HANDOVER_BUS_CREDENTIALS", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "services.launcher", "--port", str(port), "--receiver", "absent", *args,
         "--recording-dir", str(tmp_path), "--run-id", run_id],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env, cwd=REPO,
        start_new_session=True, text=True)
    return proc, loopback_profile(port)


@pytest.fixture
def stack(tmp_path):
    """A default `handover-up --job none` stack (one episode with an absent receiver first)."""
    proc, profile = _launch(tmp_path, "auth", "--job", "none")
    try:
        yield profile, tmp_path, proc
    finally:
        interrupt_then_kill(proc)
        if proc.stdout is not None:
            proc.stdout.close()


def test_a_stranger_cannot_connect_and_a_login_cannot_publish_anothers_keys(stack):
    profile, recording_dir, proc = stack
    observer = login_profile(profile, recording_dir, "auth", OBSERVER, timeout_s=30.0)
    folder = logins_dir(recording_dir, "auth")
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert all(stat.S_IMODE(f.stat().st_mode) == 0o600 for f in folder.iterdir())
    # A stranger (no login, then a wrong password) is refused by the router.
    for stranger in (profile, dataclasses.replace(observer, auth=dataclasses.replace(
            observer.auth, credentials_file=_wrong_password(folder, recording_dir)))):
        with pytest.raises(BusError):
            open_session(stranger, "client", timeout_s=2.0, user=OBSERVER)
    watch = open_session(observer, "client", timeout_s=10.0, user=OBSERVER)
    stops: list[bytes] = []
    states: list[bytes] = []
    watch.declare_subscriber(topics.MOTION_STOP.key(profile.prefix), lambda s: stops.append(s.payload.to_bytes()))
    watch.declare_subscriber(topics.SUPERVISOR_STATE.key(profile.prefix), lambda s: states.append(b""))
    assert wait_until(lambda: len(states) > 5, 30.0), "the observer login receives nothing"
    # The planner's login may not stop the arm, and the observer may publish nothing.
    # (A session's own puts reach its own subscribers without the router: publish from others.)
    planner = open_session(login_profile(profile, recording_dir, "auth", "planner"), "client", timeout_s=10.0,
                           user="planner")
    other_observer = open_session(observer, "client", timeout_s=10.0, user=OBSERVER)
    try:
        for session in (planner, other_observer):
            for _ in range(20):
                session.put(topics.MOTION_STOP.key(profile.prefix), b"forged-stop")
                time.sleep(0.01)
        time.sleep(0.5)
        assert b"forged-stop" not in stops
        assert proc.poll() is None
        # The launcher's login may stop the arm (its job does when the supervisor falls silent).
        launcher = open_session(login_profile(profile, recording_dir, "auth", "credentials"), "client",
                                timeout_s=10.0, user="launcher")
        launcher.put(topics.MOTION_STOP.key(profile.prefix), b"launcher-stop")
        assert wait_until(lambda: b"launcher-stop" in stops, 5.0)
        launcher.close()
    finally:
        planner.close()
        other_observer.close()
        watch.close()


def _wrong_password(folder: Path, into: Path) -> Path:
    path = into / "wrong"
    path.write_text(f"{OBSERVER}:not-the-password\n")
    path.chmod(0o600)
    assert path.read_text() != (folder / OBSERVER).read_text()
    return path


def test_the_logins_folder_is_gone_after_the_run(tmp_path):
    port = free_tcp_port()
    env = dict(os.environ)
    env.pop("HANDOVER_BUS_CREDENTIALS", None)
    res = subprocess.run([sys.executable, "-m", "services.launcher", "--port", str(port), "--job", "check",
                          "--recording-dir", str(tmp_path), "--run-id", "gone"], capture_output=True, text=True,
                         timeout=120, env=env, cwd=REPO)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert f"logins in {logins_dir(tmp_path, 'gone')}/" in res.stdout
    assert not logins_dir(tmp_path, "gone").exists()


def test_a_zero_grip_forged_with_the_grippers_own_login_is_reported_as_a_drop(tmp_path):
    """The worst case the logins leave (issue 17): a process with the gripper's login sends
    0 N grip commands at 500 Hz while the arm carries the object. The object falls; the run's
    summary says so from the simulation's truth and the run fails, whatever the bus said."""
    proc, profile = _launch(tmp_path, "forged", "--episodes", "1")
    try:
        observer = open_session(login_profile(profile, tmp_path, "forged", OBSERVER), "client", timeout_s=30.0,
                                user=OBSERVER)
        phases: list[str] = []
        observer.declare_subscriber(topics.SUPERVISOR_STATE.key(profile.prefix), lambda s: phases.append(
            decode(topics.SUPERVISOR_STATE, s.payload.to_bytes()).phase))
        assert wait_until(lambda: "reach" in phases, 60.0), sorted(set(phases))
        gripper = open_session(login_profile(profile, tmp_path, "forged", "gripper"), "client", timeout_s=10.0,
                               user="gripper")
        key = topics.GRIPPER_COMMAND.key(profile.prefix)
        for seq in range(750):  # 1.5 s at 500 Hz
            forged = topics.GRIPPER_COMMAND.type(seq=10_000 + seq, stamp_ns=time.time_ns(), source="gripper",
                                                 grip_force_n=0.0, position_m=0.0, mode="release")
            gripper.put(key, encode_for(topics.GRIPPER_COMMAND, forged))
            time.sleep(0.002)
        gripper.close()
        observer.close()
        out, _ = proc.communicate(timeout=90)
    finally:
        interrupt_then_kill(proc)
        if proc.stdout is not None:
            proc.stdout.close()
    assert proc.returncode == 1, out[-3000:]
    assert "DROPPED during the episode" in out, out[-3000:]
    assert "episode 1: DROPPED: the object fell (simulation truth); the supervisor saw" in out, out[-3000:]
    assert "the object was dropped" in out.splitlines()[-1], out[-3000:]


def test_forged_heartbeats_do_not_hide_a_frozen_service(tmp_path):
    """A process with the gripper's login beats for the planner (on the planner's key, which
    the router refuses it, and on its own key, which every reader refuses) while the planner
    is frozen: the supervisor still calls the planner silent within the freeze target."""
    proc, profile = _launch(tmp_path, "spoof", "--episodes", "1")
    planner_pid = None
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")), daemon=True)
    reader.start()
    stop_spoofing = threading.Event()
    try:
        observer = open_session(login_profile(profile, tmp_path, "spoof", OBSERVER), "client", timeout_s=30.0,
                                user=OBSERVER)
        phases: list[str] = []
        stops: list[tuple[float, str]] = []
        observer.declare_subscriber(topics.SUPERVISOR_STATE.key(profile.prefix), lambda s: phases.append(
            decode(topics.SUPERVISOR_STATE, s.payload.to_bytes()).phase))
        observer.declare_subscriber(topics.MOTION_STOP.key(profile.prefix), lambda s: stops.append(
            (time.monotonic(), decode(topics.MOTION_STOP, s.payload.to_bytes()).reason)))
        assert wait_until(lambda: "transfer" in phases, 60.0), sorted(set(phases))
        planner_pid = int(next(re.search(r"started planner \(pid (\d+)\)", line).group(1)
                               for line in lines if "started planner (pid" in line))
        spoofer = open_session(login_profile(profile, tmp_path, "spoof", "gripper"), "client", timeout_s=10.0,
                               user="gripper")

        def spoof() -> None:
            seq = 0
            while not stop_spoofing.is_set():
                beat = topics.HEARTBEAT.type(seq=seq, stamp_ns=time.time_ns(), source="planner", uptime_s=1.0,
                                             beats=seq, pid=planner_pid)
                for sender in ("planner", "gripper"):
                    spoofer.put(topics.HEARTBEAT.sender_key(sender, profile.prefix), encode_for(topics.HEARTBEAT, beat))
                seq += 1
                time.sleep(0.02)

        spoofing = threading.Thread(target=spoof, daemon=True)
        spoofing.start()
        time.sleep(0.3)  # forged beats flowing before the freeze
        frozen_at = time.monotonic()
        os.kill(planner_pid, signal.SIGSTOP)
        assert wait_until(lambda: any("planner" in why for _, why in stops), 5.0), stops
        noticed_s = min(t for t, why in stops if "planner" in why) - frozen_at
        assert noticed_s < 0.5, f"the frozen planner was stopped for only after {noticed_s:.3f} s"
        stop_spoofing.set()
        spoofing.join(2.0)
        spoofer.close()
        observer.close()
    finally:
        stop_spoofing.set()
        if planner_pid is not None:
            try:
                os.kill(planner_pid, signal.SIGCONT)
            except ProcessLookupError:
                pass
        interrupt_then_kill(proc)
        reader.join(5.0)
        if proc.stdout is not None:
            proc.stdout.close()


def test_a_failed_start_leaves_no_logins_behind(tmp_path):
    """The router cannot listen (its port is taken): exit 2, one line, and the run's logins
    folder is gone."""
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        env = {k: v for k, v in os.environ.items() if k != "HANDOVER_BUS_CREDENTIALS"}
        res = subprocess.run([sys.executable, "-m", "services.launcher", "--port", str(port), "--job", "check",
                              "--recording-dir", str(tmp_path), "--run-id", "busy"], capture_output=True, text=True,
                             timeout=120, env=env, cwd=REPO)
    assert res.returncode == 2, res.stdout[-2000:] + res.stderr[-2000:]
    assert "cannot host the bus" in res.stderr and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert not logins_dir(tmp_path, "busy").exists()
    assert not any(p.name.startswith(".handover-busy-bus") for p in tmp_path.iterdir())
