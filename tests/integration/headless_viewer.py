"""The Rerun viewer as a load beside the stack (issue 16's load test "beside the Rerun viewer").

The real viewer of the project's venv (the native binary of the ``rerun-sdk`` wheel), headless:
a private Xvfb display (its number chosen by Xvfb, no TCP listener) and Mesa's software Vulkan
(llvmpipe), as `tools/screenshot_recording.sh` runs it. It replays a handover recording over
and over (`services.recorder.blueprint.blueprint(..., replay_in_loop=True)`): the load of a
user watching a replay while a run goes on. On two cores with software rendering it keeps about
1.6 cores busy on its own (measured when the test was written), more than the two busy loops
of the hog tests; `ViewerLoad.cores` says how much it took in each run.

Kept to the machine: the viewer listens on 127.0.0.1 only, its analytics are disabled in a
private configuration folder (its first start sends nothing; `rerun analytics disable` there
makes sure), and the viewer and Xvfb are stopped by their process ids, even when the test
fails (and by the kernel when this process dies: ``PR_SET_PDEATHSIG``). Its memory is not
bounded: replaying with software rendering it grows about 20 MB a second whatever
``--memory-limit`` says (the limit is kept for the data it holds); a twenty-episode run ends
near 3.5 GB, which `ViewerLoad.rss_mb` reports.

Needs (Debian): ``apt-get install -y xvfb mesa-vulkan-drivers``; without them the tests that
use it are skipped with that line.
"""

from __future__ import annotations

import ctypes
import glob
import os
import select
import shutil
import signal
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

import psutil
import pytest

#: The viewer's bound on the data it holds (Rerun drops the oldest past it; its own memory
#: grows beyond it while it replays: see the module docstring).
MEMORY_LIMIT = "1GB"
#: A viewer that is drawing takes at least this much CPU (cores) in its first seconds.
DRAWING_CORES = 0.3
_INSTALL = "apt-get install -y xvfb mesa-vulkan-drivers"
_PR_SET_PDEATHSIG = 1


def missing() -> str | None:
    """Why the headless viewer cannot run on this machine (one line), or None."""
    if shutil.which("Xvfb") is None:
        return f"Xvfb not found (needs: {_INSTALL})"
    if not glob.glob("/usr/share/vulkan/icd.d/lvp_icd*.json"):
        return f"no software Vulkan driver (needs: {_INSTALL})"
    return None


def viewer_binary() -> Path:
    """The native viewer of the ``rerun-sdk`` wheel (the venv's ``rerun`` script only starts it)."""
    import rerun_cli

    return Path(rerun_cli.__file__).parent / "rerun"


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


def _die_with_parent() -> None:  # runs in the child between fork and exec
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def _read_line(fd: int, timeout_s: float) -> bytes:
    """Bytes from `fd` up to a newline (b"" or a partial line when it did not come in time)."""
    text, deadline = b"", time.monotonic() + timeout_s
    while not text.endswith(b"\n"):
        ready, _, _ = select.select([fd], [], [], max(deadline - time.monotonic(), 0.0))
        chunk = os.read(fd, 64) if ready else b""
        if not chunk:
            break
        text += chunk
    return text


def _start_xvfb(log_path: Path, timeout_s: float) -> tuple[subprocess.Popen, str]:
    """A private X display: (Xvfb's process, ``:N``). Xvfb is stopped again when it does not
    say its display, whatever ends the wait."""
    read_fd, write_fd = os.pipe()
    xvfb = None
    try:
        with log_path.open("wb") as log:
            xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-nolisten", "tcp",
                                     "-screen", "0", "1280x800x24"], pass_fds=(write_fd,),
                                    stdin=subprocess.DEVNULL, stdout=log, stderr=log, preexec_fn=_die_with_parent)
        os.close(write_fd)
        write_fd = -1
        # Up to the newline: Xvfb may write the number and the newline apart, and dies on a
        # pipe closed in between ("Cannot write display number to fd").
        text = _read_line(read_fd, timeout_s)
        if not (text.endswith(b"\n") and text.strip().isdigit()):
            raise RuntimeError(f"Xvfb did not say its display in {timeout_s:.0f} s: "
                               f"{log_path.read_text(errors='replace')[-500:]}")
    except BaseException:
        _stop(xvfb)
        raise
    finally:
        os.close(read_fd)
        if write_fd >= 0:
            os.close(write_fd)
    return xvfb, f":{text.decode().strip()}"


def _viewer_env(workdir: Path, display: str) -> dict[str, str]:
    """The viewer's environment: the display, software Vulkan, private configuration folders."""
    env = dict(os.environ)
    for name in ("XDG_CONFIG_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME", "XDG_RUNTIME_DIR"):
        folder = workdir / name.lower()
        folder.mkdir(mode=0o700, exist_ok=True)
        env[name] = str(folder)
    env.update(DISPLAY=display, WGPU_BACKEND="vulkan", RUST_LOG="error",
               VK_ICD_FILENAMES=":".join(glob.glob("/usr/share/vulkan/icd.d/lvp_icd*.json")))
    return env


def _stop(proc: subprocess.Popen | None) -> None:
    """Stop a process this module started, by its pid (SIGTERM, then SIGKILL)."""
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(10.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(10.0)


@contextmanager
def headless_viewer(recording: Path, workdir: Path, robot_name: str = "baxter",
                    start_timeout_s: float = 60.0) -> Iterator[ViewerLoad]:
    """The Rerun viewer replaying `recording` in a loop, headless, while the block runs.

    Skips the test when Xvfb or software Vulkan is missing (`missing`). Returns once the viewer
    draws (it took `DRAWING_CORES` over a second); raises RuntimeError, with the end of its
    output, when it does not within `start_timeout_s`."""
    from services.recorder.blueprint import blueprint

    reason = missing()
    if reason is not None:
        pytest.skip(f"the headless Rerun viewer cannot run here: {reason}")
    workdir.mkdir(parents=True, exist_ok=True)
    xvfb, display = _start_xvfb(workdir / "xvfb.log", start_timeout_s)
    viewer = None
    try:
        env = _viewer_env(workdir, display)
        binary = viewer_binary()
        subprocess.run([str(binary), "analytics", "disable"], env=env, check=True, timeout=30,
                       stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        layout = workdir / "replay.rbl"
        blueprint(robot_name, replay_in_loop=True).save("handover", str(layout))
        log_path = workdir / "viewer.log"
        with log_path.open("wb") as log:
            viewer = subprocess.Popen([str(binary), "--bind", "127.0.0.1", "--port", "auto",
                                       "--memory-limit", MEMORY_LIMIT, "--window-size", "1280x800",
                                       str(recording), str(layout)],
                                      env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                      preexec_fn=_die_with_parent)
        load = ViewerLoad(psutil.Process(viewer.pid))
        _wait_drawing(load, viewer, log_path, start_timeout_s)
        yield load
    finally:
        try:
            _stop(viewer)
        finally:
            _stop(xvfb)
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
