"""The Rerun viewer as a load beside the stack (issue 16's load test "beside the Rerun viewer").

The real viewer of the project's venv (the native binary of the ``rerun-sdk`` wheel), headless:
a private Xvfb display and Mesa's software Vulkan, set up by `services.recorder.headless` as for
``handover-recorder screenshot`` (loopback only, analytics off in private folders, stopped by
process id, and by the kernel when this process dies). It replays a handover recording over and
over (`services.recorder.blueprint.blueprint(..., replay_in_loop=True)`): the load of a user
watching a replay while a run goes on. On two cores with software rendering it keeps about 1.6
cores busy on its own (measured when the test was written), more than the two busy loops of the
hog tests; `ViewerLoad.cores` says how much it took in each run.

Its memory is not bounded: replaying with software rendering it grows about 20 MB a second
whatever ``--memory-limit`` says (the limit is kept for the data it holds); a twenty-episode
run ends near 3.5 GB, which `ViewerLoad.rss_mb` reports.

Needs (Debian): ``apt-get install -y xvfb mesa-vulkan-drivers``; without them the tests that
use it are skipped with that line.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

import psutil
import pytest

from services.recorder.headless import die_with_parent, headless_display, missing, stop, viewer_binary, viewer_env

__all__ = ["DRAWING_CORES", "MEMORY_LIMIT", "ViewerLoad", "handover_recording", "headless_viewer", "missing"]

#: The viewer's bound on the data it holds (Rerun drops the oldest past it; its own memory
#: grows beyond it while it replays: see the module docstring).
MEMORY_LIMIT = "1GB"
#: A viewer that is drawing takes at least this much CPU (cores) in its first seconds.
DRAWING_CORES = 0.3


def handover_recording(folder: Path, run_id: str) -> Path:
    """A recording of one default handover (`handover-up`, nothing beside it) in `folder`, for
    the viewer; skips the test, saying why, when the headless viewer cannot run here."""
    reason = missing()
    if reason is not None:
        pytest.skip(f"the headless Rerun viewer cannot run here: {reason}")
    done = subprocess.run([sys.executable, "-m", "services.launcher", "--port", "auto", "--episodes", "1",
                           "--recording-dir", str(folder), "--run-id", run_id],
                          stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return folder / f"handover-{run_id}.rrd"


class ViewerLoad:
    """The running viewer: how much CPU it takes.

    Args:
        process: the viewer's process.
    """

    def __init__(self, process: psutil.Process) -> None:
        self.process = process
        self._mark: tuple[float, float] | None = None

    def cpu_s(self) -> float:
        """CPU time the viewer used so far (user + system, every thread), s."""
        times = self.process.cpu_times()
        return times.user + times.system

    def mark(self) -> None:
        """Start a window for `cores`."""
        self._mark = (time.monotonic(), self.cpu_s())

    def cores(self) -> float:
        """The viewer's average CPU since `mark`, cores."""
        if self._mark is None:
            raise RuntimeError("ViewerLoad.cores() before mark()")
        started_s, cpu_s = self._mark
        return (self.cpu_s() - cpu_s) / max(time.monotonic() - started_s, 1e-9)

    def rss_mb(self) -> float:
        return self.process.memory_info().rss / 1e6


@contextmanager
def headless_viewer(recording: Path, workdir: Path, robot_name: str = "baxter",
                    start_timeout_s: float = 60.0) -> Iterator[ViewerLoad]:
    """The Rerun viewer replaying `recording` in a loop, headless, while the block runs.

    Skips the test when Xvfb or software Vulkan is missing (`missing`). Returns once the viewer
    draws (it took `DRAWING_CORES` over a second); raises RuntimeError, with the end of its
    output, when it does not within `start_timeout_s` (`HeadlessViewerError` when the display
    does not start)."""
    from services.recorder.blueprint import blueprint

    reason = missing()
    if reason is not None:
        pytest.skip(f"the headless Rerun viewer cannot run here: {reason}")
    viewer = None
    with headless_display(workdir, "1280x800x24", start_timeout_s) as display:
        try:
            env = viewer_env(workdir, display)
            layout = workdir / "replay.rbl"
            blueprint(robot_name, replay_in_loop=True).save("handover", str(layout))
            log_path = workdir / "viewer.log"
            with log_path.open("wb") as log:
                viewer = subprocess.Popen([str(viewer_binary()), "--bind", "127.0.0.1", "--port", "auto",
                                           "--memory-limit", MEMORY_LIMIT, "--window-size", "1280x800",
                                           str(recording), str(layout)],
                                          env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                          preexec_fn=die_with_parent)
            load = ViewerLoad(psutil.Process(viewer.pid))
            _wait_drawing(load, viewer, log_path, start_timeout_s)
            yield load
        finally:
            stop(viewer)
            with suppress(OSError):
                shutil.rmtree(workdir / "xdg_cache_home")


def _wait_drawing(load: ViewerLoad, viewer: subprocess.Popen, log_path: Path, timeout_s: float) -> None:
    """Return once the viewer took `DRAWING_CORES` over one second."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if viewer.poll() is not None:
            break
        load.mark()
        time.sleep(1.0)
        if load.cores() >= DRAWING_CORES:
            return
    tail = log_path.read_text(errors="replace")[-800:]
    state = f"exited with {viewer.returncode}" if viewer.poll() is not None else f"idle after {timeout_s:.0f} s"
    raise RuntimeError(f"the Rerun viewer is not drawing ({state}); its output: {tail}")
