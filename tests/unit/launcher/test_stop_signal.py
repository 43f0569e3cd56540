"""The launcher's SIGINT/SIGTERM go through `SignalRelay`: one that lands while the main
thread holds the lock of `stop_requested` (as its `wait` does around the sleep) still stops
the run, and says so once. Before the relay the handler set the event itself and hung there.
In a child process: a hang is a time-out, not a hung test run."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def test_a_stop_signal_while_the_main_thread_holds_the_stop_lock_stops_the_launcher(tmp_path):
    script = f"""
    import os, signal, time
    from pathlib import Path
    from services.launcher.core import LaunchOptions
    from services.launcher.node import Launcher
    from services.launcher.processes import stdout_outlet
    from services.runtime.profile import load_profile_file
    launcher = Launcher(load_profile_file("sim"), LaunchOptions(run_id="t", recording_dir=Path({str(tmp_path)!r})))
    launcher._signals.install()
    with launcher.stop_requested._cond:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.3)
    stopped = launcher.stop_requested.wait(5.0)
    launcher._signals.restore()  # joins the relay thread: its line is queued by now
    stdout_outlet().flush(5.0)  # the launcher's own lines go out through a writer thread
    print("stopped" if stopped and launcher.interrupted else "running", flush=True)
    """
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], cwd=ROOT, capture_output=True,
                          text=True, timeout=30.0)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[-1] == "stopped"
    assert lines.count("[launcher] SIGTERM received: shutting down") == 1
