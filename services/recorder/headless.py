"""The real Rerun viewer on a machine without a display or a GPU, kept to the machine.

One place for what the screenshot command (`services.recorder.screenshot`) and the load tests
beside the viewer (`tests/integration/headless_viewer.py`) both need:

- a private X display (`headless_display`): Xvfb with its number chosen by Xvfb itself
  (``-displayfd``), no TCP listener, stopped by its process id whatever ends the block, and by
  the kernel when this process dies (``PR_SET_PDEATHSIG``);
- the environment of every ``rerun`` run (`private_env`: the viewer, ``rrd optimize``):
  private configuration, data, cache and runtime folders, with Rerun's usage analytics disabled
  in them (they are on by default in a user's ``~/.config/rerun``: nothing may be sent off the
  machine); for the viewer, that display and Mesa's software Vulkan (llvmpipe) too
  (`viewer_env`, `on_display`);
- the native viewer of the ``rerun-sdk`` wheel (`viewer_binary`), which the callers start with
  ``--bind 127.0.0.1``.

Needs (Debian): ``apt-get install -y xvfb mesa-vulkan-drivers`` (`missing` says what is not there).
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
from contextlib import contextmanager
from pathlib import Path

from services.recorder.errors import RecorderError

INSTALL = "apt-get install -y xvfb mesa-vulkan-drivers"
_LAVAPIPE = "/usr/share/vulkan/icd.d/lvp_icd*.json"
_PR_SET_PDEATHSIG = 1
# Looked up once here: a child between fork and exec must not load a library (locks another
# thread of this process may have held at the fork).
_PRCTL = ctypes.CDLL("libc.so.6", use_errno=True).prctl


class HeadlessViewerError(RecorderError):
    """The headless display or the viewer did not start (check the message: a missing package,
    or the end of the program's own output)."""

    bad_input = False


def one_line(text: str, limit: int = 300) -> str:
    """The end of a program's output (at most `limit` characters) on one line, for an error."""
    return " ".join(text.split())[-limit:]


def missing() -> str | None:
    """Why the headless viewer cannot run on this machine (one line), or None."""
    if shutil.which("Xvfb") is None:
        return f"Xvfb not found (needs: {INSTALL})"
    if not glob.glob(_LAVAPIPE):
        return f"no software Vulkan driver (needs: {INSTALL})"
    return None


def viewer_binary() -> Path:
    """The native viewer of the ``rerun-sdk`` wheel (the venv's ``rerun`` script only starts it)."""
    import rerun_cli

    return Path(rerun_cli.__file__).parent / "rerun"


def die_with_parent() -> None:
    """`preexec_fn` of a child that must not outlive this process (runs between fork and exec)."""
    _PRCTL(_PR_SET_PDEATHSIG, signal.SIGTERM)


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


def stop(proc: subprocess.Popen | None) -> None:
    """Stop a process started here, by its pid (SIGTERM, then SIGKILL after 10 s)."""
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(10.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(10.0)


def _start_xvfb(log_path: Path, screen: str, timeout_s: float) -> tuple[subprocess.Popen, str]:
    """A private X display: (Xvfb's process, ``:N``). Xvfb is stopped again when it does not
    say its display, whatever ends the wait."""
    read_fd, write_fd = os.pipe()
    xvfb = None
    try:
        with log_path.open("wb") as log:
            xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-nolisten", "tcp", "-screen", "0", screen],
                                    pass_fds=(write_fd,), stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                    preexec_fn=die_with_parent)
        os.close(write_fd)
        write_fd = -1
        # Up to the newline: Xvfb may write the number and the newline apart, and dies on a
        # pipe closed in between ("Cannot write display number to fd").
        text = _read_line(read_fd, timeout_s)
        if not (text.endswith(b"\n") and text.strip().isdigit()):
            said = one_line(log_path.read_text(errors="replace"))
            raise HeadlessViewerError(f"Xvfb did not say its display in {timeout_s:.0f} s: {said}")
    except BaseException:
        stop(xvfb)
        raise
    finally:
        os.close(read_fd)
        if write_fd >= 0:
            os.close(write_fd)
    return xvfb, f":{text.decode().strip()}"


@contextmanager
def headless_display(workdir: Path, screen: str = "1280x800x24", timeout_s: float = 60.0) -> Iterator[str]:
    """A private X display (``:N``) for the block; Xvfb's output goes to ``workdir/xvfb.log``.

    Raises:
        HeadlessViewerError: Xvfb or software Vulkan is missing, or Xvfb did not start.
    """
    reason = missing()
    if reason is not None:
        raise HeadlessViewerError(f"the headless Rerun viewer cannot run here: {reason}")
    workdir.mkdir(parents=True, exist_ok=True)
    xvfb, display = _start_xvfb(workdir / "xvfb.log", screen, timeout_s)
    try:
        yield display
    finally:
        stop(xvfb)


def private_env(workdir: Path) -> dict[str, str]:
    """The environment of any ``rerun`` run here (the viewer, ``rrd optimize``): private XDG
    folders under `workdir`, Rerun's usage analytics disabled in them.

    Raises:
        HeadlessViewerError: Rerun could not disable its analytics.
    """
    env = dict(os.environ)
    for name in ("XDG_CONFIG_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME", "XDG_RUNTIME_DIR"):
        folder = workdir / name.lower()
        folder.mkdir(mode=0o700, exist_ok=True)
        env[name] = str(folder)
    where = env["XDG_CONFIG_HOME"]
    try:
        done = subprocess.run([str(viewer_binary()), "analytics", "disable"], env=env, timeout=30,
                              stdin=subprocess.DEVNULL, capture_output=True, text=True, preexec_fn=die_with_parent)
    except subprocess.TimeoutExpired:
        raise HeadlessViewerError(f"the viewer did not disable its analytics in {where} within 30 s") from None
    if done.returncode != 0:
        raise HeadlessViewerError(f"the viewer could not disable its analytics in {where}: "
                                  f"{one_line(done.stderr or done.stdout)}")
    return env


def on_display(env: dict[str, str], display: str) -> dict[str, str]:
    """`env` (from `private_env`) for the viewer on `display`, with Mesa's software Vulkan."""
    return {**env, "DISPLAY": display, "WGPU_BACKEND": "vulkan", "RUST_LOG": "error",
            "VK_ICD_FILENAMES": ":".join(glob.glob(_LAVAPIPE))}


def viewer_env(workdir: Path, display: str) -> dict[str, str]:
    """The viewer's environment on `display`: `private_env` under `workdir`, `on_display`.

    Raises:
        HeadlessViewerError: Rerun could not disable its analytics.
    """
    return on_display(private_env(workdir), display)
