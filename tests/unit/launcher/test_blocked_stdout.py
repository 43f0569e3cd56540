"""The launcher's relay of its children's output with its own stdout blocked (issue 16).

A small program stands in for `handover-up`: it relays a chatty child through
`services.launcher.processes` (`Child`, `emit`, the bounded stdout outlet) while its stdout is
a full one-page pipe nobody reads, blocking or non-blocking (a parent may have set
O_NONBLOCK on it). The child must finish (a relay that waited for stdout would leave it stuck
on its own full pipe), and once the test reads the pipe the program's last line and the
dropped-line count arrive, and every line is either written or counted as dropped.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from services.runtime.profile import load_profile_file

REPO = Path(__file__).resolve().parents[3]
F_SETPIPE_SZ, F_GETPIPE_SZ = 1031, 1032
CHILD_LINES = 5000
QUEUE_LINES = 64
#: The relaying program: relays CHILD_LINES lines, says on stderr when the child is done,
#: waits for a line on stdin (the test reads stdout first), then prints its last line.
RELAY = f"""
import sys, time
from services.launcher.processes import Child, emit, stdout_outlet
stdout_outlet({QUEUE_LINES})
child = Child("chatty", [sys.executable, "-c", "for i in range({CHILD_LINES}): print('line', i, 'x' * 60)"], 8)
t0 = time.monotonic()
child.start()
code = child.wait(30.0)
child.stop(1.0)  # exited: joins the relay thread
sys.stderr.write(f"child {{code}} {{time.monotonic() - t0:.3f}}\\n"); sys.stderr.flush()
sys.stdin.readline()
emit("[launcher] last line\\n")
stdout_outlet().flush(10.0)
"""
_DROPPED = re.compile(r"^\[launcher\] (\d+) output line\(s\) dropped while stdout was blocked \((\d+) in all\)$")


def _full_pipe(nonblocking: bool) -> tuple[int, int]:
    read_fd, write_fd = os.pipe()
    fcntl.fcntl(write_fd, F_SETPIPE_SZ, 4096)
    capacity = fcntl.fcntl(write_fd, F_GETPIPE_SZ)
    os.write(write_fd, b"#" * (capacity - 1) + b"\n")
    os.set_blocking(write_fd, not nonblocking)
    return read_fd, write_fd


def _read_all(read_fd: int, timeout_s: float) -> str:
    data, deadline = b"", time.monotonic() + timeout_s
    os.set_blocking(read_fd, False)
    while time.monotonic() < deadline:
        try:
            chunk = os.read(read_fd, 65536)
        except BlockingIOError:
            time.sleep(0.01)
            continue
        if not chunk:
            return data.decode()
        data += chunk
    raise AssertionError(f"stdout did not close within {timeout_s} s; got {len(data)} bytes")


@pytest.mark.parametrize("nonblocking", [False, True], ids=["blocking-fd", "nonblocking-fd"])
def test_relay_never_waits_for_a_blocked_stdout_and_reports_what_it_dropped(nonblocking):
    read_fd, write_fd = _full_pipe(nonblocking)
    proc = subprocess.Popen([sys.executable, "-c", RELAY], stdout=write_fd, stderr=subprocess.PIPE,
                            stdin=subprocess.PIPE, text=True, cwd=REPO)
    os.close(write_fd)
    try:
        done = proc.stderr.readline().split()  # blocks until the child was relayed to the end
        assert done[:2] == ["child", "0"], f"the chatty child did not finish: {done}"
        relay_s = float(done[2])
        proc.stdin.write("\n")
        proc.stdin.flush()
        text = _read_all(read_fd, 20.0)
        proc.wait(10.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5.0)
        os.close(read_fd)
    lines = [line for line in text.splitlines() if not line.startswith("#")]
    relayed = [line for line in lines if line.startswith("[chatty]")]
    notices = [_DROPPED.match(line) for line in lines if _DROPPED.match(line)]
    assert relay_s < 20.0
    # The last line may push one more queued line out: its drop notice may then follow it.
    content = [line for line in lines if not _DROPPED.match(line)]
    assert content and content[-1] == "[launcher] last line", f"the output ends with {lines[-3:]}"
    assert notices, "no dropped-line count"
    dropped = int(notices[-1][2])
    assert sum(int(m[1]) for m in notices) == dropped
    assert dropped + len(relayed) == CHILD_LINES  # every line written or counted
    # The queue bound held: written are at most the queue and the one batch (≤ 64 KiB) the writer
    # held when stdout blocked.
    assert len(relayed) <= QUEUE_LINES + 65536 // len(relayed[-1])
    assert relayed[-1].endswith(f"line {CHILD_LINES - 1} " + "x" * 60), "the newest lines survive"
    assert proc.returncode == 0


@pytest.mark.parametrize("value", ["0", "-5", "2.5", '"64"', "true", "2000000"])
def test_a_bad_output_queue_bound_is_one_line_naming_the_key(tmp_path, value):
    text = load_profile_file("sim").path.read_text()
    path = tmp_path / "p.toml"
    path.write_text(re.sub(r"(?m)^output_queue_lines *=.*$", f"output_queue_lines = {value}", text, count=1))
    proc = subprocess.run([sys.executable, "-m", "services.launcher", "--profile", str(path), "--job", "check",
                           "--port", "auto"], capture_output=True, text=True, timeout=60, cwd=REPO)
    assert proc.returncode == 2
    assert "launcher.output_queue_lines" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_the_router_answers_ready_on_its_merged_output_and_stops_cleanly():
    from services.launcher.processes import RouterProcess
    from services.runtime.profile import free_tcp_port
    from services.runtime.zenoh_config import zenoh_config_dict

    profile = load_profile_file("sim").with_bus(endpoint=f"tcp/127.0.0.1:{free_tcp_port()}")
    router = RouterProcess(json.dumps(zenoh_config_dict(profile, "router")))
    try:
        router.start()
        assert router.proc is not None and router.proc.poll() is None
    finally:
        code = router.stop()
    assert code == 0


def test_a_router_that_cannot_start_says_why():
    from services.launcher.processes import RouterProcess

    router = RouterProcess("{ not json")
    with pytest.raises(RuntimeError, match="router: invalid Zenoh config"):
        router.start()
    assert router.proc is not None and router.proc.poll() == 1


def test_emit_takes_no_lock_once_the_outlet_exists(monkeypatch):
    """The launcher's SIGINT/SIGTERM handler says what it does: were `emit` to take a lock, a
    signal arriving while the same thread held it would hang the launcher for good."""
    import threading

    from services.launcher import processes
    from services.runtime.outlet import LineOutlet

    read_fd, write_fd = os.pipe()
    monkeypatch.setattr(processes, "_outlet", LineOutlet(write_fd, max_lines=8))
    done = threading.Event()
    with processes._outlet_lock:  # held, as by an interrupted first call
        worker = threading.Thread(target=lambda: (processes.emit("[launcher] x\n"), done.set()), daemon=True)
        worker.start()
        worker.join(2.0)
    assert done.is_set(), "emit() waited for the outlet's creation lock"
    assert os.read(read_fd, 100) == b"[launcher] x\n"
    os.close(read_fd)
    os.close(write_fd)
