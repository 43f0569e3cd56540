"""Per-service CPU of a running `handover-up`, sampled with psutil.

`run_stack(...)` starts `handover-up` (any job) with its output to a file, waits for the
``all N services alive`` line, and measures each child process's CPU time (user + system) over a
window: idle for `--job none`, or from the first episode line to the summary for `--job handover`.
The launcher process itself (and its router child, when there is one) is measured too.

Run directly for a quick look::

    python -m tests.bench.cpu_probe --job none --seconds 20
    python -m tests.bench.cpu_probe --job handover
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import psutil

from services.runtime.testing import interrupt_then_kill

_ALIVE = re.compile(r"all \d+ services alive")
_STARTED = re.compile(r"started (?P<name>\w+) \(pid (?P<pid>\d+)\)")
_EPISODE_START = re.compile(r"episode 1: locate")
_SUMMARY = re.compile(r"\] summary: |exit \d+")
#: The supervisor's line when its episode ends: with ``--job none`` it still runs the
#: profile's episode(s), so the stack is idle only after this line. It is in the supervisor's
#: log file (`handover-up` is quiet on the console), or the launcher's output (``--verbose``, or
#: a launcher from before the log files).
_EPISODE_ENDED = re.compile(r"INFO +episode summary")


@dataclass
class CpuWindow:
    """CPU use of every process of one stack over one window.

    Attributes:
        seconds: length of the window, s (wall clock).
        cores: per process name, CPU seconds / window seconds (1.0 = one core busy).
        switches_per_s: per process name, context switches of all its threads per second
            (voluntary + involuntary, `/proc/PID/task/*/status`): each is a thread put to sleep
            and woken again.
        recording_bytes: size of the run's recording once the stack has stopped, bytes.
        run_seconds: wall time from the launch to the stack's exit, s (the recording's span).
        output: the launcher's whole output.
    """

    seconds: float
    cores: dict[str, float] = field(default_factory=dict)
    switches_per_s: dict[str, float] = field(default_factory=dict)
    recording_bytes: int = 0
    run_seconds: float = 0.0
    output: str = ""

    @property
    def total_cores(self) -> float:
        return sum(self.cores.values())

    @property
    def total_switches_per_s(self) -> float:
        return sum(self.switches_per_s.values())

    @property
    def recording_bytes_per_s(self) -> float:
        """Recording size per second of run, bytes/s."""
        return self.recording_bytes / self.run_seconds if self.run_seconds > 0 else float("nan")


def _cpu_s(proc: psutil.Process) -> float:
    try:
        t = proc.cpu_times()
        return t.user + t.system
    except psutil.Error:
        return float("nan")


def _switches(proc: psutil.Process) -> float:
    """Context switches so far of every thread of `proc` (nan once it is gone)."""
    total = 0
    try:
        for task in Path(f"/proc/{proc.pid}/task").iterdir():
            try:
                for line in (task / "status").read_text().splitlines():
                    if line.startswith(("voluntary_ctxt_switches", "nonvoluntary_ctxt_switches")):
                        total += int(line.split()[1])
            except (OSError, ValueError):
                continue  # the thread ended meanwhile
    except OSError:
        return float("nan")
    return float(total)


def wake_cost_us(processes: int = 1, rate_hz: float = 100.0, seconds: float = 3.0,
                 one_grid: bool = True) -> float:
    """CPU time (µs) one wake of a sleeping Python thread costs on this machine: `processes`
    fresh interpreters sleep to `rate_hz` grids of the host's monotonic clock at once, all on
    one grid (`one_grid`, as the stack's loops are) or each on its own phase, spread evenly over
    the period; each divides its CPU time by its wakes. All start at one moment, 0.5 s after
    launch (their start-up out of the window); the mean over the processes."""
    code = ("import time, resource, sys\n"
            f"period = 1 / {rate_hz}; start = float(sys.argv[1]); n = int({rate_hz} * {seconds})\n"
            "time.sleep(max(0.0, start - time.monotonic()))\n"
            "u = resource.getrusage(resource.RUSAGE_SELF)\n"
            "for k in range(1, n + 1):\n    d = start + k * period - time.monotonic()\n"
            "    if d > 0: time.sleep(d)\n"
            "v = resource.getrusage(resource.RUSAGE_SELF)\n"
            "print((v.ru_utime + v.ru_stime - u.ru_utime - u.ru_stime) / n * 1e6)")
    start_s = (time.monotonic() // (1 / rate_hz) + 1) / rate_hz + 0.5
    phases = [0.0 if one_grid else k / (processes * rate_hz) for k in range(processes)]
    procs = [subprocess.Popen([sys.executable, "-c", code, repr(start_s + phase)], stdout=subprocess.PIPE, text=True)
             for phase in phases]
    costs = [float(proc.communicate(timeout=seconds + 30)[0]) for proc in procs]
    return statistics.fmean(costs)


def _wait_for(path: Path | list[Path], pattern: re.Pattern[str], proc: subprocess.Popen, timeout_s: float) -> str:
    """The text of `path` (of those of the paths that exist, joined) once `pattern` is in it."""
    paths = path if isinstance(path, list) else [path]
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        text = "".join(p.read_text(errors="replace") for p in paths if p.exists())
        if pattern.search(text):
            return text
        if proc.poll() is not None:
            raise RuntimeError(f"handover-up exited {proc.returncode} early:\n{text[-3000:]}")
        time.sleep(0.05)
    text = "".join(p.read_text(errors="replace") for p in paths if p.exists())
    raise RuntimeError(f"no line matching {pattern.pattern!r} within {timeout_s} s:\n{text[-3000:]}")


def _processes(launcher: psutil.Process, text: str) -> dict[str, psutil.Process]:
    procs = {"launcher": launcher}
    for match in _STARTED.finditer(text):
        try:
            procs[match["name"]] = psutil.Process(int(match["pid"]))
        except psutil.Error:
            pass
    known = {p.pid for p in procs.values()}
    for child in launcher.children():
        if child.pid not in known:  # e.g. the router process
            try:
                is_router = "services.launcher.router" in " ".join(child.cmdline())
            except psutil.Error:
                is_router = False
            procs["router" if is_router else f"other:{child.name()}:{child.pid}"] = child
    return procs


def start_stack(tmp_dir: Path, job: str, run_id: str, extra_args: list[str] | None = None,
                checkout: Path | None = None) -> tuple[subprocess.Popen, Path]:
    """Start `handover-up --job JOB --run-id RUN_ID` recording into `tmp_dir`, its output to a
    file there; returns the launcher's process and that file (stop it with
    `interrupt_then_kill`). `checkout`: run another source tree (see `run_stack`)."""
    out_path = tmp_dir / f"handover-up-{job}.log"
    cmd = [sys.executable, "-m", "services.launcher", "--port", "auto", "--job", job,
           "--recording-dir", str(tmp_dir), "--run-id", run_id, *(extra_args or [])]
    with open(out_path, "w") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                cwd=checkout)
    return proc, out_path


def wait_idle(proc: subprocess.Popen, out_path: Path, tmp_dir: Path, run_id: str, timeout_s: float = 120.0,
              settle_s: float = 3.0) -> str:
    """Until a `--job none` stack is idle: every service alive, the supervisor's episode ended
    (it runs the profile's episode whatever the launcher's job) and `settle_s` more; returns the
    launcher's output so far."""
    _wait_for(out_path, _ALIVE, proc, timeout_s)
    _wait_for([out_path, tmp_dir / f"handover-{run_id}-logs" / "supervisor.log"], _EPISODE_ENDED, proc, timeout_s)
    time.sleep(settle_s)
    return out_path.read_text(errors="replace")


def run_stack(tmp_dir: Path, job: str = "none", idle_s: float = 20.0, settle_s: float = 3.0,
              extra_args: list[str] | None = None, timeout_s: float = 120.0,
              checkout: Path | None = None) -> CpuWindow:
    """Start `handover-up --job JOB`, measure per-process CPU over the window, stop it.

    `job="none"`: the window starts `settle_s` after the supervisor's episode has ended (the
    supervisor runs the profile's episode whatever the launcher's job; before its summary the
    stack is not idle) and lasts `idle_s`.
    `job="handover"`: the window runs from the first episode's ``locate`` line to the summary.
    `checkout`: run the stack of another source tree (e.g. an older commit's, for a baseline
    measured in the same sitting); its modules shadow the installed ones (``python -m`` puts the
    working directory first on the path, and the launcher's children inherit it).
    """
    t_launch = time.monotonic()
    proc, out_path = start_stack(tmp_dir, job, f"cpu-{job}", extra_args, checkout)
    try:
        launcher = psutil.Process(proc.pid)
        if job == "none":
            text = wait_idle(proc, out_path, tmp_dir, f"cpu-{job}", timeout_s, settle_s)
        else:
            _wait_for(out_path, _ALIVE, proc, timeout_s)
            text = _wait_for(out_path, _EPISODE_START, proc, timeout_s)
        procs = _processes(launcher, text)
        before = {name: _cpu_s(p) for name, p in procs.items()}
        before_sw = {name: _switches(p) for name, p in procs.items()}
        t0 = time.monotonic()
        # The last reading of each process while it lived: a service that ends with its
        # episode (the supervisor, once its summary is out) is counted up to its exit.
        last = dict(before)
        last_sw = dict(before_sw)

        def sample() -> None:
            for name, p in procs.items():
                cpu_s, switches = _cpu_s(p), _switches(p)
                if cpu_s == cpu_s and switches == switches:  # not nan: still alive
                    last[name], last_sw[name] = cpu_s, switches

        if job == "none":
            time.sleep(idle_s)
            sample()
        else:
            deadline = time.monotonic() + timeout_s
            ticks = 0
            while not _SUMMARY.search(out_path.read_text(errors="replace")):
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"no summary within {timeout_s} s:\n"
                                       f"{out_path.read_text(errors='replace')[-3000:]}")
                if ticks % 4 == 0:  # every 0.2 s: the probe's own reads stay light
                    sample()
                ticks += 1
                time.sleep(0.05)
            sample()
        after, after_sw = last, last_sw
        seconds = time.monotonic() - t0
        window = CpuWindow(seconds, {n: (after[n] - before[n]) / seconds for n in procs},
                           {n: (after_sw[n] - before_sw[n]) / seconds for n in procs})
    finally:
        interrupt_then_kill(proc, 30.0)
    window.run_seconds = time.monotonic() - t_launch
    window.recording_bytes = sum(r.stat().st_size for r in tmp_dir.glob(f"handover-cpu-{job}*.rrd"))
    window.output = out_path.read_text(errors="replace")
    return window


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", choices=["none", "handover"], default="none")
    parser.add_argument("--seconds", type=float, default=20.0, help="idle window, s (--job none)")
    parser.add_argument("--dir", type=Path, default=Path("/tmp/cpu_probe"))
    args = parser.parse_args(argv)
    args.dir.mkdir(parents=True, exist_ok=True)
    w = run_stack(args.dir, args.job, args.seconds)
    print(json.dumps({"seconds": round(w.seconds, 2), "total_cores": round(w.total_cores, 3),
                      "switches_per_s": round(w.total_switches_per_s),
                      "recording_MB": round(w.recording_bytes / 1e6, 2),
                      "recording_MB_per_s": round(w.recording_bytes_per_s / 1e6, 3),
                      "cores": {k: round(v, 3) for k, v in sorted(w.cores.items(), key=lambda kv: -kv[1])}},
                     indent=1))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    raise SystemExit(main())
