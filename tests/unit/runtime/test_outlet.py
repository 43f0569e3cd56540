"""LineOutlet and the services' logging never block the caller, and count what they drop."""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import threading
import time

from services.runtime.outlet import LineOutlet

F_SETPIPE_SZ = 1031


def _small_pipe() -> tuple[int, int]:
    read_fd, write_fd = os.pipe()
    fcntl.fcntl(write_fd, F_SETPIPE_SZ, 4096)
    return read_fd, write_fd


def _drain(read_fd: int, quiet_s: float = 0.5) -> str:
    os.set_blocking(read_fd, False)
    data, last = b"", time.monotonic()
    while time.monotonic() - last < quiet_s:
        try:
            chunk = os.read(read_fd, 65536)
        except BlockingIOError:
            time.sleep(0.01)
            continue
        if not chunk:
            break
        data, last = data + chunk, time.monotonic()
    return data.decode()


def test_puts_return_while_nobody_reads_and_drops_are_counted_then_reported():
    read_fd, write_fd = _small_pipe()
    outlet = LineOutlet(write_fd, max_lines=100)
    lines = [f"line {i:05d} {'x' * 60}\n" for i in range(10_000)]
    putter = threading.Thread(target=lambda: [outlet.put(line) for line in lines], daemon=True)
    putter.start()
    putter.join(30.0)
    assert not putter.is_alive(), "put() blocked on a pipe nobody reads"
    assert outlet.dropped > 9_000  # the pipe holds ~60 lines, the queue 100
    text, deadline = _drain(read_fd), time.monotonic() + 10.0
    while not outlet.flush(0.05):  # a writer thread starved of CPU may still hold lines
        assert time.monotonic() < deadline, "the outlet never finished writing"
        text += _drain(read_fd, quiet_s=0.05)
    text += _drain(read_fd, quiet_s=0.05)
    out = text.splitlines()
    notices = [line for line in out if "dropped" in line]
    assert len(notices) == 1
    assert int(notices[0].split()[0]) == outlet.dropped
    assert outlet.written + outlet.dropped == len(lines)
    # The notice follows the batch written when the pipe took output again: before the newest
    # lines, or after them when that batch held them all (a writer starved until the end).
    kept = [line for line in out if "dropped" not in line]
    assert kept[-1] == lines[-1].rstrip("\n"), "the newest lines survive (the oldest are dropped)"
    assert len(out) - 1 == outlet.written


def test_a_closed_output_drops_without_raising():
    read_fd, write_fd = os.pipe()
    os.close(read_fd)
    outlet = LineOutlet(write_fd)
    for i in range(50):
        outlet.put(f"{i}\n")
    assert not outlet.flush(0.5) or outlet.dropped == 50
    time.sleep(0.1)
    assert outlet.put("after\n") is False
    assert outlet.dropped == 51 and outlet.written == 0
    os.close(write_fd)


def test_a_service_logging_into_a_blocked_stderr_does_not_block():
    """A real process: stderr is a small pipe nobody reads; 20 000 log lines must not stop it."""
    read_fd, write_fd = _small_pipe()
    code = (
        "import logging, sys\n"
        "from services.runtime.logs import setup_logging\n"
        "setup_logging('probe')\n"
        "log = logging.getLogger('probe')\n"
        "for i in range(20000): log.info('line %d', i)\n"
        "sys.stdout.write('done\\n'); sys.stdout.flush()\n"
        "import os; os._exit(0)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=write_fd, text=True)
    os.close(write_fd)
    try:
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    os.close(read_fd)
    assert out.strip() == "done"


def test_logging_reports_the_dropped_count_once_stderr_takes_output_again():
    read_fd, write_fd = _small_pipe()
    code = (
        "import logging, sys, time\n"
        "from services.runtime.logs import setup_logging\n"
        "setup_logging('probe')\n"
        "log = logging.getLogger('probe')\n"
        "for i in range(20000): log.info('line %d', i)\n"
        "sys.stdout.write('logged\\n'); sys.stdout.flush()\n"
        "sys.stdin.readline()\n"  # the test reads stderr now
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stdin=subprocess.PIPE,
                            stderr=write_fd, text=True)
    os.close(write_fd)
    try:
        assert proc.stdout.readline().strip() == "logged"
        text = _drain(read_fd, quiet_s=1.0)
        proc.stdin.write("\n")
        proc.stdin.flush()
        proc.wait(30)
        text += _drain(read_fd, quiet_s=0.3)
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(read_fd)
    notices = [line for line in text.splitlines() if "dropped: stderr was blocked" in line]
    assert len(notices) == 1, text[-2000:]
    dropped = int(notices[0].split()[0])
    logged = [line for line in text.splitlines() if " INFO " in line]
    assert dropped + len(logged) == 20000
    assert logged[-1].endswith("line 19999")
