"""Where a running stack's CPU goes, counted by activation: for every thread of every process,
how often it ran and what each run cost.

On the 2-core CI machine the idle stack's CPU is mostly what it costs to wake a thread and run
it with cold caches, not computation (docs/performance.md): so the figures that explain it are
the number of runs a second and the CPU of one run, per kind of thread. Both come from the
kernel's scheduler statistics of each thread, ``/proc/PID/task/TID/schedstat``: the CPU time
it ran (ns), the time it waited for a CPU (ns), and ``pcount``, the number of times it was put
on a CPU (one run: a wake, or a return after it was preempted).

Run directly on a stack that is up (e.g. ``handover-up --job none`` in another terminal)::

    python -m tests.bench.activation_census --launcher-pid PID --seconds 20
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import psutil

#: Zenoh's Tokio worker threads (``app-0`` in a service; ``rx-0``, ``rx-1``, ``tx-0``, ``acc-0``,
#: ``net-0`` in the router, which keeps Zenoh's layout: services/runtime/zenoh_threads.py).
ZENOH_WORKER = re.compile(r"^(app|rx|tx|acc|net)-\d+$")
KINDS = ("Python main thread", "other Python threads", "Zenoh workers", "other native threads")


def thread_kind(pid: int, tid: int, comm: str, main_comm: str) -> str:
    """One of `KINDS` for thread `tid` (named `comm`) of process `pid`, whose main thread is
    named `main_comm`. Python names no thread of its own: they keep the process's name
    (``python``, or a console script's: ``handover-up``), so the main thread is the one whose id
    is the process's and the other Python threads (the heartbeat, zenoh-python's callback
    threads, the launcher's output relays) are those named as it is."""
    if ZENOH_WORKER.match(comm):
        return "Zenoh workers"
    if tid == pid:
        return "Python main thread"
    return "other Python threads" if comm == main_comm else "other native threads"


@dataclass(frozen=True)
class ThreadTotals:
    """A thread's cumulative scheduler figures (`/proc/PID/task/TID/schedstat`).

    Attributes:
        cpu_s: CPU time it ran, s.
        runs: times it was put on a CPU.
    """

    cpu_s: float
    runs: int


def read_threads(pid: int, proc_root: str = "/proc") -> dict[int, tuple[str, ThreadTotals]]:
    """Per thread id of process `pid`: (kind, totals). Threads that end while read are left out;
    a process that ended gives {}."""
    out: dict[int, tuple[str, ThreadTotals]] = {}
    try:
        tasks = list(Path(f"{proc_root}/{pid}/task").iterdir())
    except OSError:
        return out
    try:
        main_comm = Path(f"{proc_root}/{pid}/comm").read_text().strip()
    except OSError:
        return out
    for task in tasks:
        try:
            comm = (task / "comm").read_text().strip()
            exec_ns, _wait_ns, runs = (task / "schedstat").read_text().split()[:3]
        except (OSError, ValueError):
            continue
        tid = int(task.name)
        out[tid] = (thread_kind(pid, tid, comm, main_comm), ThreadTotals(int(exec_ns) / 1e9, int(runs)))
    return out


@dataclass
class Census:
    """Per (process name, thread kind): CPU cores and runs a second over one window.

    Attributes:
        seconds: the window, s.
        cores: CPU seconds / window seconds.
        runs_per_s: runs (times put on a CPU) a second.
    """

    seconds: float
    cores: dict[tuple[str, str], float]
    runs_per_s: dict[tuple[str, str], float]

    def us_per_run(self, key: tuple[str, str]) -> float:
        """Mean CPU of one run, µs (NaN without runs)."""
        runs = self.runs_per_s.get(key, 0.0)
        return self.cores.get(key, 0.0) / runs * 1e6 if runs > 0 else float("nan")

    def by_kind(self) -> dict[str, tuple[float, float]]:
        """Per thread kind over every process: (cores, runs a second)."""
        totals: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0])
        for (_name, kind), cores in self.cores.items():
            totals[kind][0] += cores
            totals[kind][1] += self.runs_per_s[(_name, kind)]
        return {kind: (c, r) for kind, (c, r) in totals.items()}

    @property
    def total_cores(self) -> float:
        return sum(self.cores.values())

    @property
    def total_runs_per_s(self) -> float:
        return sum(self.runs_per_s.values())


def take_census(processes: dict[str, int], seconds: float) -> Census:
    """Count every thread of `processes` (name → pid) over `seconds` of wall time. A thread
    that started in the window counts from zero; one that ended is left out."""
    before = {name: read_threads(pid) for name, pid in processes.items()}
    t0 = time.monotonic()
    time.sleep(seconds)
    after = {name: read_threads(pid) for name, pid in processes.items()}
    window = time.monotonic() - t0
    cores: dict[tuple[str, str], float] = defaultdict(float)
    runs: dict[tuple[str, str], float] = defaultdict(float)
    for name, threads in after.items():
        for tid, (kind, end) in threads.items():
            start = before[name].get(tid, (kind, ThreadTotals(0.0, 0)))[1]
            cores[(name, kind)] += (end.cpu_s - start.cpu_s) / window
            runs[(name, kind)] += (end.runs - start.runs) / window
    return Census(window, dict(cores), dict(runs))


def rows(census: Census) -> list[tuple[str, ...]]:
    """Table rows: per process (largest first) and thread kind, runs/s, core, µs per run."""
    per_process: dict[str, float] = defaultdict(float)
    for (name, _kind), cores in census.cores.items():
        per_process[name] += cores
    out = []
    for name in sorted(per_process, key=lambda n: -per_process[n]):
        for kind in KINDS:
            key = (name, kind)
            if census.runs_per_s.get(key, 0.0) >= 0.5:
                out.append((name, kind, f"{census.runs_per_s[key]:.0f}", f"{census.cores[key]:.3f}",
                            f"{census.us_per_run(key):.0f}"))
    for kind, (cores, runs) in sorted(census.by_kind().items(), key=lambda kv: -kv[1][0]):
        if runs >= 0.5:
            out.append(("**all**", kind, f"{runs:.0f}", f"{cores:.3f}", f"{cores / runs * 1e6:.0f}"))
    runs = census.total_runs_per_s
    out.append(("**all**", "**every thread**", f"{runs:.0f}", f"{census.total_cores:.3f}",
                f"{census.total_cores / runs * 1e6:.0f}" if runs > 0 else "—"))
    return out


def stack_processes(launcher_pid: int) -> dict[str, int]:
    """The launcher and its children (name → pid): a service by its module (``bridge``), the
    router as ``router``. Children that end while listed are left out.

    Raises:
        psutil.NoSuchProcess: no process `launcher_pid`.
        psutil.Error: its children cannot be listed (e.g. another user's process).
    """
    launcher = psutil.Process(launcher_pid)
    processes = {"launcher": launcher.pid}
    for child in launcher.children():
        try:
            argv = child.cmdline()
        except psutil.NoSuchProcess:
            continue
        module = next((a for a in argv if a.startswith("services.")), child.name())
        processes[module.removeprefix("services.").replace("launcher.", "")] = child.pid
    return processes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--launcher-pid", type=int, required=True, help="pid of a running handover-up")
    parser.add_argument("--seconds", type=float, default=20.0, help="length of the window, s (> 0)")
    args = parser.parse_args(argv)
    if not args.seconds > 0:
        parser.error(f"--seconds must be > 0, got {args.seconds:g}")
    try:
        processes = stack_processes(args.launcher_pid)
    except psutil.NoSuchProcess:
        parser.error(f"no process {args.launcher_pid}: pass the pid of a running handover-up")
    except psutil.Error as exc:
        sys.stderr.write(f"activation_census: cannot list the processes of {args.launcher_pid}: {exc}\n")
        return 1
    census = take_census(processes, args.seconds)
    for row in rows(census):
        print(" | ".join(row))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
