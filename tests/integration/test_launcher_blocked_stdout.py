"""`handover-up` with its stdout blocked: no log write may hold back a safety loop (issue 16).

One run of the whole simulated stack (``absent`` receiver, so the transfer phase lasts until
its 6 s time-out) with the launcher's stdout and stderr into a 4096-byte pipe that the test
fills before the start and does not read until the stack has shut down: from its first line
on, every write of the launcher to stdout would block. The launcher's output queue is cut to
`QUEUE_LINES` lines (profile key ``[launcher] output_queue_lines``; a whole run prints about
a hundred) so that it overflows within the run and the drop path is exercised.

The test watches the stack from its own Zenoh client (never from stdout), SIGKILLs the
gripper `KILL_AFTER_TRANSFER_S` into the transfer phase, and asserts:

- the protective stop (`motion/stop`, protective) was sent within `STOP_BOUND_S` of the kill,
  by the sender's wall-clock stamp (DESIGN targets: a killed service noticed within 100 ms,
  the stop sent within 100 ms more, plus 100 ms of margin for this loaded 2-core machine);
- `supervisor/state` kept coming the whole time stdout was blocked (no gap over
  `MAX_STATE_GAP_S` between sender stamps) and the pipe stayed full (nobody read it);
- the launcher shut its children down with stdout still blocked, and once the test drains the
  pipe it exits 1, its exit line names the gripper, and it says how many lines it dropped.

Every process the test started is ended by PID (the launcher, then its children and router
recorded from `/proc` with their start times), even when an assertion fails.
"""

from __future__ import annotations

import fcntl
import os
import re
import signal
import subprocess
import sys
import termios
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import psutil
import pytest

from bus_schema import topics
from services.launcher.logins import OBSERVER, login_profile
from services.runtime import ServiceNode
from services.runtime.profile import free_tcp_port, load_profile_file
from services.runtime.testing import interrupt_then_kill

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

REPO = Path(__file__).resolve().parents[2]
F_SETPIPE_SZ, F_GETPIPE_SZ = 1031, 1032
PIPE_BYTES = 4096
#: The launcher's output queue for this run, lines (default 8192).
QUEUE_LINES = 16
KILL_AFTER_TRANSFER_S = 0.3
#: Kill → protective `motion/stop` sent, s (100 ms detection + 100 ms stop + 100 ms margin).
STOP_BOUND_S = 0.3
#: Longest gap between two supervisor states while stdout is blocked, s (the supervisor
#: sends one every 50 ms; its own watch trips at 250 ms of silence).
MAX_STATE_GAP_S = 0.5
#: Start → transfer phase; kill → every child of the launcher gone; drain → launcher exit, s.
TRANSFER_WITHIN_S = 38.0
SHUTDOWN_WITHIN_S = 12.0
EXIT_AFTER_DRAIN_S = 5.0
_DROPPED = re.compile(r"^\[launcher\] (?P<n>\d+) output line\(s\) dropped while stdout was blocked "
                      r"\((?P<total>\d+) in all\)$")
_EXIT = re.compile(r"^\[launcher\] exit (?P<code>\d+)(?P<rest>.*)$")


@dataclass
class Observed:
    """What the test saw on the bus, with the fault's time (test monotonic and wall clock)."""

    states: list = field(default_factory=list)
    stops: list = field(default_factory=list)
    kill_wall_s: float | None = None
    pipe_full_at_kill: int | None = None
    shutdown_s: float | None = None
    pipe_full_at_drain: int | None = None
    capacity: int = 0
    exit_after_drain_s: float = float("nan")
    returncode: int | None = None
    lines: list[str] = field(default_factory=list)


def _blocked_pipe() -> tuple[int, int, int]:
    """A pipe shrunk to one page and filled: (read fd, write fd, capacity in bytes)."""
    read_fd, write_fd = os.pipe()
    fcntl.fcntl(write_fd, F_SETPIPE_SZ, PIPE_BYTES)
    capacity = fcntl.fcntl(write_fd, F_GETPIPE_SZ)
    assert os.write(write_fd, b"#" * (capacity - 1) + b"\n") == capacity
    return read_fd, write_fd, capacity


def _unread_bytes(read_fd: int) -> int:
    buf = bytearray(4)
    fcntl.ioctl(read_fd, termios.FIONREAD, buf)
    return int.from_bytes(buf, sys.byteorder)


def _profile_with_small_queue(tmp_path: Path) -> Path:
    text = load_profile_file("sim").path.read_text()
    assert "\n[launcher]\n" in text
    path = tmp_path / "sim_small_queue.toml"
    path.write_text(re.sub(r"(?m)^output_queue_lines *=.*$", f"output_queue_lines = {QUEUE_LINES}", text, count=1))
    return path


class _Family:
    """The launcher's descendants seen so far (pid → start time), to end only those."""

    def __init__(self, launcher_pid: int) -> None:
        self.launcher_pid = launcher_pid
        self.seen: dict[int, tuple[float, str]] = {}

    def scan(self) -> list[psutil.Process]:
        try:
            children = psutil.Process(self.launcher_pid).children(recursive=True)
        except psutil.NoSuchProcess:
            return []
        live = []
        for child in children:
            try:
                if child.status() == psutil.STATUS_ZOMBIE:
                    continue
                self.seen.setdefault(child.pid, (child.create_time(), " ".join(child.cmdline())))
                live.append(child)
            except psutil.NoSuchProcess:
                pass
        return live

    def pid_of(self, module: str) -> int | None:
        for child in self.scan():
            if module in self.seen.get(child.pid, (0.0, ""))[1].split():
                return child.pid
        return None

    def kill_leftovers(self) -> None:
        for pid, (created, _cmd) in self.seen.items():
            try:
                proc = psutil.Process(pid)
                if proc.create_time() == created:
                    proc.kill()
            except psutil.NoSuchProcess:
                pass


def _drain_forever(read_fd: int, sink: bytearray) -> None:
    while True:
        try:
            chunk = os.read(read_fd, 65536)
        except OSError:
            return
        if not chunk:
            return
        sink.extend(chunk)


def _watch(node: ServiceNode, launcher: subprocess.Popen, family: _Family, seen: Observed, read_fd: int,
           start_s: float) -> None:
    """Follow the episode on the bus; kill the gripper in the transfer phase; return once every
    child of the launcher is gone (stdout still unread)."""
    states = node.subscribe(topics.SUPERVISOR_STATE, 100_000)
    stops = node.subscribe(topics.MOTION_STOP, 10_000)
    transfer_s = kill_s = None
    next_scan_s = 0.0
    while True:
        node.wait(0.002)
        now = time.monotonic()
        seen.states.extend(r.msg for r in states.drain())
        seen.stops.extend(r.msg for r in stops.drain())
        if kill_s is None:
            assert launcher.poll() is None, f"handover-up exited {launcher.returncode} before the fault"
            early = [m for m in seen.states if m.phase in ("protective_stop", "failed", "done")]
            assert not early, f"the stack stopped before the fault: {early[0].phase}: {early[0].reason}"
            if transfer_s is None and any(m.phase == "transfer" for m in seen.states):
                transfer_s = now
            if now >= next_scan_s:
                family.scan()
                next_scan_s = now + 0.5
            assert now - start_s < TRANSFER_WITHIN_S, \
                f"no transfer phase within {TRANSFER_WITHIN_S} s ({sorted({m.phase for m in seen.states})})"
            if transfer_s is not None and now >= transfer_s + KILL_AFTER_TRANSFER_S:
                gripper = family.pid_of("services.gripper")
                assert gripper is not None, "no gripper process among the launcher's children"
                seen.pipe_full_at_kill = _unread_bytes(read_fd)
                seen.kill_wall_s = time.time()
                os.kill(gripper, signal.SIGKILL)
                kill_s = now
        elif now >= next_scan_s:
            next_scan_s = now + 0.05
            if not family.scan():
                seen.shutdown_s = now - kill_s
                seen.pipe_full_at_drain = _unread_bytes(read_fd)
                return
            assert now - kill_s < SHUTDOWN_WITHIN_S, \
                f"the launcher's children still run {SHUTDOWN_WITHIN_S} s after the kill while stdout is blocked " \
                f"(see where it waits: .venv/bin/py-spy dump --pid {family.launcher_pid})"


def _max_gap_s(states: list) -> float:
    stamps = sorted(m.stamp_ns for m in states)
    return max((b - a for a, b in zip(stamps, stamps[1:])), default=float("inf")) / 1e9


def _run_blocked(tmp_path: Path) -> Observed:
    """One `handover-up` run with stdout blocked and the gripper killed (module docstring);
    an `AssertionError` of the watch is raised after cleanup, with the launcher's output."""
    seen = Observed()
    read_fd, write_fd, seen.capacity = _blocked_pipe()
    port = free_tcp_port()
    profile_path = _profile_with_small_queue(tmp_path)
    profile = load_profile_file(profile_path).with_bus(endpoint=f"tcp/127.0.0.1:{port}")
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    for name in ("HANDOVER_FAULTS", "HANDOVER_FAULTS_ARM_DIR"):
        env.pop(name, None)
    start_s = time.monotonic()
    launcher = subprocess.Popen(
        [sys.executable, "-m", "services.launcher", "--profile", str(profile_path), "--port", str(port),
         "--receiver", "absent", "--episodes", "1", "--seed", "0", "--recording-dir", str(tmp_path),
         "--run-id", "blocked"],
        stdout=write_fd, stderr=write_fd, stdin=subprocess.DEVNULL, env=env, cwd=REPO, start_new_session=True,
    )
    os.close(write_fd)
    family = _Family(launcher.pid)
    output = bytearray()
    drainer = threading.Thread(target=_drain_forever, args=(read_fd, output), daemon=True)
    node = None
    failure: AssertionError | None = None  # raised with the launcher's output once it was read
    try:
        node = ServiceNode(OBSERVER, login_profile(profile, tmp_path, "blocked", OBSERVER),
                           install_signal_handlers=False, connect_timeout_s=30.0)
        node.open()
        try:
            _watch(node, launcher, family, seen, read_fd, start_s)
        except AssertionError as exc:
            failure = exc
        drain_s = time.monotonic()
        drainer.start()
        try:
            launcher.wait(EXIT_AFTER_DRAIN_S)
        except subprocess.TimeoutExpired:
            failure = failure or AssertionError(
                f"the launcher did not exit within {EXIT_AFTER_DRAIN_S} s once its stdout was read")
        seen.exit_after_drain_s = time.monotonic() - drain_s
    finally:
        if node is not None:
            node.close()
        if drainer.ident is None:
            drainer.start()  # never leave the launcher waiting on the pipe at cleanup
        interrupt_then_kill(launcher, 20.0)
        family.kill_leftovers()
        drainer.join(5.0)
        os.close(read_fd)
    seen.returncode = launcher.returncode
    text = output.decode(errors="replace")
    seen.lines = [line for line in text.splitlines() if not line.startswith("#")]  # not the filler
    (tmp_path / "handover-up.log").write_text("\n".join(seen.lines) + "\n")
    if failure is not None:
        raise AssertionError(f"{failure}\n--- handover-up output (last 40 lines):\n{_tail(seen)}") from None
    return seen


def _tail(seen: Observed) -> str:
    return "\n".join(seen.lines[-40:])


def test_a_blocked_stdout_holds_back_neither_the_protective_stop_nor_the_exit(tmp_path):
    seen = _run_blocked(tmp_path)
    lines, tail = seen.lines, _tail(seen)
    after_kill = [m for m in seen.stops if m.protective and m.stamp_ns / 1e9 >= seen.kill_wall_s]
    assert after_kill, f"no protective motion/stop after the gripper was killed\n{tail}"
    stop_s = after_kill[0].stamp_ns / 1e9 - seen.kill_wall_s
    noticed = [m for m in seen.states if m.stamp_ns / 1e9 >= seen.kill_wall_s and "gripper" in m.reason]
    detect_s = noticed[0].stamp_ns / 1e9 - seen.kill_wall_s if noticed else float("nan")
    notices = [m for m in map(_DROPPED.match, lines) if m]
    print(f"\nkill → noticed {detect_s * 1e3:.1f} ms, kill → protective stop {stop_s * 1e3:.1f} ms "
          f"({after_kill[0].reason!r}); max supervisor state gap {_max_gap_s(seen.states) * 1e3:.0f} ms over "
          f"{len(seen.states)} states; kill → children gone {seen.shutdown_s:.2f} s; drain → exit "
          f"{seen.exit_after_drain_s:.2f} s; {len(lines)} lines out, dropped {[m['n'] for m in notices]}")
    assert stop_s <= STOP_BOUND_S, f"protective stop {stop_s:.3f} s after the kill (bound {STOP_BOUND_S} s)"
    assert _max_gap_s(seen.states) <= MAX_STATE_GAP_S, \
        f"supervisor/state silent for {_max_gap_s(seen.states):.3f} s while stdout was blocked"
    assert seen.pipe_full_at_kill == seen.capacity and seen.pipe_full_at_drain == seen.capacity, \
        "stdout was not blocked the whole time (the pipe was not full)"
    assert seen.returncode == 1, f"launcher exit {seen.returncode}, expected 1\n{tail}"
    exits = [m for m in map(_EXIT.match, lines) if m]
    assert exits and exits[-1]["code"] == "1" and "gripper" in exits[-1]["rest"], \
        f"no exit line naming the gripper\n{tail}"
    assert notices, f"no dropped-line count in the launcher's output\n{tail}"
    assert sum(int(m["n"]) for m in notices) == int(notices[-1]["total"]) > 0
    assert seen.exit_after_drain_s < EXIT_AFTER_DRAIN_S
