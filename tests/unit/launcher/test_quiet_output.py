"""`handover-up` is quiet by default: which service lines reach the console, the run's log
files (one per service, beside the recording), and that writing them never blocks a relay."""

from __future__ import annotations

import fcntl
import json
import os
import sys
import time

import pytest

from services.launcher import logfiles, node, processes
from services.launcher.core import LaunchOptions, line_level, logs_dir, recording_path, shown_when_quiet
from services.launcher.logfiles import LogFiles, own_line
from services.launcher.processes import Child, relay
from services.runtime.outlet import LineOutlet
from services.runtime.profile import load_profile_file

F_SETPIPE_SZ, F_GETPIPE_SZ = 1031, 1032


def _record(level: str, message: str) -> str:
    """A service's text log line as `services.runtime.logs` writes it."""
    return f"14:48:15.414 {level:<7} {message}\n"


def _json_record(level: str, message: str) -> str:
    return json.dumps({"t": 1.0, "level": level, "service": "bridge", "logger": "x", "msg": message}) + "\n"


@pytest.mark.parametrize(("line", "level", "shown"), [
    (_record("INFO", "bridge running backend=sim"), "INFO", False),
    (_record("DEBUG", "tick"), "DEBUG", False),
    (_record("WARNING", "service fault service=motion what=silent"), "WARNING", True),
    (_record("ERROR", "start failed missing=bridge"), "ERROR", True),
    (_record("CRITICAL", "x"), "CRITICAL", True),
    # The level is the record's, not a word in its message.
    (_record("INFO", "WARNING in the text ERROR too"), "INFO", False),
    (_json_record("info", "bridge running"), "INFO", False),
    (_json_record("warning", "holding the grip"), "WARNING", True),
    # Not a log record: a crash's traceback, the one-line error of a service that exits.
    ("Traceback (most recent call last):\n", None, True),
    ('  File "/x/services/bridge/node.py", line 3, in run\n', None, True),
    ("bridge: internal error: ValueError: boom\n", None, True),
    ("WARNING without a time stamp\n", None, True),
    ("\n", None, False),
    ("   \n", None, False),
])
def test_the_quiet_console_keeps_warnings_errors_and_lines_that_are_no_record(line, level, shown):
    assert line_level(line) == level
    assert shown_when_quiet(line) is shown


def test_the_log_folder_sits_beside_the_recording(tmp_path):
    assert logs_dir(tmp_path, "t") == tmp_path / "handover-t-logs"
    assert logs_dir(tmp_path, "t").parent == recording_path(tmp_path, "t").parent
    assert recording_path(tmp_path, "t").name == "handover-t.rrd"


@pytest.fixture
def console(monkeypatch):
    """What the launcher would have written to stdout (`processes.emit` replaced)."""
    lines: list[str] = []
    monkeypatch.setattr(processes, "emit", lines.append)
    monkeypatch.setattr(node, "emit", lines.append)
    return lines


@pytest.fixture
def files(tmp_path):
    logs = LogFiles(tmp_path / "logs")
    assert logs.open(), logs.error
    yield logs
    logs.close(2.0)


LINES = [_record("INFO", "bridge running"), _record("WARNING", "stop: braking reason=protective"),
         "Traceback (most recent call last):\n", _record("INFO", "bridge stopped")]


@pytest.mark.parametrize("verbose", [False, True], ids=["quiet", "verbose"])
def test_relay_writes_every_line_to_the_file_and_the_console_gets_what_the_mode_shows(console, files, verbose):
    outlet = files.outlet("bridge")
    for line in LINES:
        relay("bridge", line, 8, outlet, verbose)
    assert files.close(2.0)
    assert (files.directory / "bridge.log").read_text() == "".join(LINES)
    shown = LINES if verbose else LINES[1:3]
    assert console == [f"[bridge]   {line}" for line in shown]
    # A mode that showed every line quietly would fail here:
    assert verbose or not any("bridge running" in line for line in console)


def test_a_child_logs_to_its_file_and_only_its_warnings_reach_a_quiet_console(console, files):
    script = ("import sys\n"
              "print('14:00:00.000 INFO    hello from the child')\n"
              "print('14:00:00.001 WARNING something to act on')\n"
              "sys.stdout.flush()\n"
              "raise SystemExit('child: error: it failed')\n")
    child = Child("chatty", [sys.executable, "-c", script], 8, log=files.outlet("chatty"), verbose=False)
    child.start()
    assert child.wait(20.0) == 1
    child.stop(1.0)  # exited: joins the relay thread
    assert files.close(2.0)
    text = (files.directory / "chatty.log").read_text()
    assert "hello from the child" in text and "something to act on" in text and "child: error: it failed" in text
    assert [line.split("]", 1)[0] for line in console] == ["[chatty", "[chatty"]
    assert "WARNING something to act on" in console[0] and "child: error: it failed" in console[1]


def test_a_log_file_that_takes_nothing_never_holds_the_relay_back(console):
    """A log 'file' that is a full pipe nobody reads: the child still runs to its end, and every
    line is either written or counted as dropped (the file's own writer thread waits, the
    relay thread does not)."""
    read_fd, write_fd = os.pipe()
    fcntl.fcntl(write_fd, F_SETPIPE_SZ, 4096)
    os.write(write_fd, b"#" * (fcntl.fcntl(write_fd, F_GETPIPE_SZ) - 1) + b"\n")
    log = LineOutlet(write_fd, max_lines=16, name="blocked.log")
    n = 3000
    child = Child("chatty", [sys.executable, "-c", f"for i in range({n}): print('14:00:00.000 INFO    line', i)"],
                  8, log=log, verbose=False)
    t0 = time.monotonic()
    child.start()
    try:
        assert child.wait(20.0) == 0, "the child did not finish: its relay waited for the log file"
        child.stop(1.0)
        assert time.monotonic() - t0 < 20.0
        assert log.dropped > 0 and log.written + log.dropped <= n
        assert console == []  # INFO lines: none on a quiet console
    finally:
        os.close(read_fd)  # the writer's write fails (EPIPE): the outlet is broken for good
        deadline = time.monotonic() + 5.0
        while log.put("x\n") and time.monotonic() < deadline:
            time.sleep(0.01)
        os.close(write_fd)  # only once the writer stopped writing to it


def test_launcher_log_holds_the_launchers_own_lines_stamped_like_a_service(files):
    own_line("bus on tcp/127.0.0.1:7447")
    own_line("something odd", "WARNING")
    assert files.close(2.0)
    lines = (files.directory / "launcher.log").read_text().splitlines()
    assert [line_level(line) for line in lines] == ["INFO", "WARNING"]
    assert lines[0].endswith("bus on tcp/127.0.0.1:7447")
    own_line("after the close")  # a no-op, not a write to a closed descriptor
    assert logfiles._launcher_file is None


def test_a_folder_that_cannot_be_made_is_reported_not_raised(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    logs = LogFiles(blocker / "logs")
    assert not logs.open()
    assert "cannot make" in (logs.error or "") and logs.outlet("bridge") is None


def test_a_restarted_service_goes_on_in_the_same_file_and_a_new_run_starts_it_empty(tmp_path):
    (tmp_path / "logs").mkdir()
    (tmp_path / "logs" / "bridge.log").write_text("an older run with the same id\n")
    logs = LogFiles(tmp_path / "logs")
    assert logs.open()
    first = logs.outlet("bridge")
    first.put("first start\n")
    assert logs.outlet("bridge") is first
    first.put("after the restart\n")
    assert logs.close(2.0)
    assert (tmp_path / "logs" / "bridge.log").read_text() == "first start\nafter the restart\n"


def test_a_closed_outlet_drops_later_lines_and_counts_them(tmp_path):
    fd = os.open(tmp_path / "f.log", os.O_WRONLY | os.O_CREAT)
    outlet = LineOutlet(fd)
    outlet.put("one\n")
    assert outlet.close(2.0)
    with pytest.raises(OSError):
        os.fstat(fd)  # closed
    assert outlet.put("two\n") is False and outlet.dropped == 1
    assert (tmp_path / "f.log").read_text() == "one\n"


class _StoppedChild:
    def __init__(self, pid: int, code: int, how: str) -> None:
        self.pid, self._result = pid, (code, how)

    def stop(self, _timeout_s: float) -> tuple[int, str]:
        return self._result


@pytest.mark.parametrize("verbose", [False, True], ids=["quiet", "verbose"])
def test_shutdown_is_one_console_line_when_every_service_ended_as_asked(console, tmp_path, verbose):
    launcher = node.Launcher(load_profile_file("sim"),
                             LaunchOptions(run_id="t", recording_dir=tmp_path, verbose=verbose))
    assert launcher.logs.open()
    names = [s.name for s in launcher.specs]
    launcher.children = {name: _StoppedChild(100 + i, 0, "SIGINT") for i, name in enumerate(names)}
    launcher.children["motion"] = _StoppedChild(7, -9, "SIGKILL")
    launcher._shutdown()
    assert launcher.logs.close(2.0)
    said = [line.removeprefix("[launcher] ").rstrip("\n") for line in console]
    if verbose:
        assert len(said) == len(names) and all(line.startswith("stopped ") for line in said)
    else:
        # The one that needed SIGKILL is shown; the others are one line.
        assert said[0] == "stopped motion (pid 7) with SIGKILL: was killed by SIGKILL"
        assert len(said) == 2 and said[1].startswith(f"{len(names)} services stopped in ")
        assert "each exited" not in said[1]
    log = (tmp_path / "handover-t-logs" / "launcher.log").read_text()
    assert all(f"stopped {name} (pid" in log for name in names)


def test_shutdown_says_each_exited_as_asked_when_all_did(console, tmp_path):
    launcher = node.Launcher(load_profile_file("sim"), LaunchOptions(run_id="t", recording_dir=tmp_path))
    launcher.children = {s.name: _StoppedChild(1, 0, "SIGINT") for s in launcher.specs}
    launcher._shutdown()
    assert len(console) == 1 and console[0].endswith("(each exited with code 0 on SIGINT)\n")


def test_help_describes_verbose(capsys):
    from services.launcher.cli import main

    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "-v, --verbose" in out and "every line of every service" in out


class _TimedChild(_StoppedChild):
    def __init__(self) -> None:
        super().__init__(1, 0, "SIGINT")
        self.timeout_s: float | None = None

    def stop(self, timeout_s: float) -> tuple[int, str]:
        self.timeout_s = timeout_s
        return self._result


def test_the_recorder_is_given_its_own_time_to_finalise_its_file(console, tmp_path):
    """SIGTERM cuts the recorder's finalising short (a footer-less file): it gets the profile's
    `stop_timeout_s`, the others the launcher's `term_timeout_s`."""
    launcher = node.Launcher(load_profile_file("sim"),
                             LaunchOptions(run_id="t", recording_dir=tmp_path, term_timeout_s=5.0))
    launcher.children = {s.name: _TimedChild() for s in launcher.specs}
    launcher._shutdown()
    assert launcher.children["recorder"].timeout_s == 60.0
    assert {c.timeout_s for name, c in launcher.children.items() if name != "recorder"} == {5.0}
