"""Task functions of the engine's tests (module level, so that worker processes import them)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import psutil


def square_after(argument: tuple[int, float]) -> int:
    """x², after sleeping `delay_s` (so that tasks finish out of order)."""
    x, delay_s = argument
    time.sleep(delay_s)
    return x * x


def counted(argument: tuple[int, str]) -> dict:
    """A result derived from x; appends x to the log file (one line per call, any process);
    raises while a file ``fail-<x>`` exists beside the log."""
    x, log_path = argument
    log = Path(log_path)
    with log.open("a") as fh:
        fh.write(f"{x}\n")
    if (log.parent / f"fail-{x}").exists():
        raise ValueError(f"told to fail on {x}")
    return {"x": x, "cube": x ** 3, "text": f"r{x}"}


def fails_on_three(x: int) -> int:
    """Raises a KeyError on 3, else returns x."""
    if x == 3:
        raise KeyError("no such key for three")
    return x


def whereabouts(main_pid: int) -> dict:
    """This worker's pid, its parent's, and the TCP addresses listening in this process, its
    parent (the nanny) and the main process (the scheduler)."""
    me = psutil.Process()
    procs = [me, psutil.Process(os.getppid()), psutil.Process(main_pid)]
    listening = sorted({c.laddr.ip for p in procs for c in p.net_connections(kind="inet")
                        if c.status == psutil.CONN_LISTEN})
    return {"pid": me.pid, "parent": os.getppid(), "listening": listening}


def slow_pid(argument: tuple[int, str]) -> int:
    """Writes this worker's pid to the folder, sleeps 0.4 s, marks x done, returns x."""
    x, folder = argument
    (Path(folder) / f"pid-{os.getpid()}").write_text("")
    time.sleep(0.4)
    (Path(folder) / f"done-{x}").write_text("")
    return x


def child_or_failure(argument: tuple[int, str]) -> int:
    """x = 0: starts a child process in a session of its own (as an evaluation episode starts
    its launcher), writes its pid to ``child-<pid>`` in the folder and waits for it; any other
    x: raises once that file exists (which ends the run while the child still runs)."""
    import subprocess
    import sys

    x, folder = argument
    if x == 0:
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"], start_new_session=True)
        (Path(folder) / f"child-{child.pid}").write_text("")
        return child.wait()
    deadline = time.monotonic() + 60.0
    while not list(Path(folder).glob("child-*")) and time.monotonic() < deadline:
        time.sleep(0.05)
    raise RuntimeError("told to fail once the other task's child runs")


def _class_gone() -> None:
    raise AttributeError("module 'results' has no attribute 'Outcome' (renamed since the run)")


class Unloadable:
    """A result that pickles but cannot be loaded again (as one whose class was renamed since)."""

    def __reduce__(self):
        return (_class_gone, ())


def unloadable_on_one(x: int) -> object:
    """x, or for 1 a result that cannot be loaded back from a checkpoint."""
    return Unloadable() if x == 1 else x
