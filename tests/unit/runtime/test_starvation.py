"""Telling why a heartbeat thread woke late (`services.runtime.starvation`)."""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path

import pytest

from services.runtime.starvation import (WakeSample, WakeSampler, late_wake_report, parse_schedstat, parse_steal,
                                         sample_wake)


def test_schedstat_line_gives_the_run_queue_wait_in_seconds():
    assert parse_schedstat("355954009 2586612 34\n") == 0.002586612
    assert parse_schedstat("") is None
    assert parse_schedstat("1 2") is None
    assert parse_schedstat("1 x 3") is None


def test_proc_stat_line_gives_the_steal_time_per_cpu_in_seconds():
    line = "cpu  3635021 3023612 1622721 2716202 22978 0 123217 128591 0 0\n"
    assert parse_steal(line, ticks_per_s=100, cpus=2) == 128591 / 100 / 2
    assert parse_steal("cpu0 1 2 3 4 5 6 7 8 0 0", 100, 2) is None
    assert parse_steal("cpu 1 2 3", 100, 2) is None
    assert parse_steal("", 100, 2) is None


def test_on_time_wake_is_not_reported():
    a = WakeSample(10.0, 1.0, 5.0, 3.0)
    assert late_wake_report(a, WakeSample(10.025, 1.0, 5.01, 3.0), 0.025) is None
    assert late_wake_report(a, WakeSample(10.12, 1.09, 5.01, 3.0), 0.025) is None  # 95 ms late: under 0.1 s


def test_late_wake_spent_on_the_run_queue_is_cpu_starvation():
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0, 3.0), WakeSample(10.325, 1.28, 5.02, 3.0), 0.025)
    assert line == ("heartbeat thread woke 300 ms late: 280 ms waiting for a CPU, 0 ms stolen by the host, "
                    "process used 20 ms of CPU meanwhile; starved of CPU: the machine is overloaded or this "
                    "process's niceness is too high")


def test_late_wake_while_the_host_took_the_cpus_is_a_machine_pause():
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0, 3.0), WakeSample(10.225, 1.003, 5.0, 3.15), 0.025)
    assert line is not None
    assert "200 ms late: 3 ms waiting for a CPU, 150 ms stolen by the host, process used 0 ms" in line
    assert line.endswith("the machine paused: the host took its virtual CPUs (steal time)")


def test_late_wake_with_the_cpu_busy_elsewhere_in_the_process_is_the_gil():
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0, 3.0), WakeSample(10.325, 1.01, 5.29, 3.0), 0.025)
    assert line is not None
    assert "10 ms waiting for a CPU, 0 ms stolen by the host, process used 290 ms of CPU" in line
    assert line.endswith("another thread computed holding the GIL")


def test_late_wake_while_the_main_thread_waited_for_a_cpu_is_starvation_through_the_gil():
    """The heartbeat thread itself barely waited, the process hardly ran: the GIL holder (the
    main thread) was on the run queue, and the heartbeat thread slept on the GIL."""
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0, 3.0, 2.0), WakeSample(10.317, 1.006, 5.01, 3.005, 2.25), 0.025)
    assert line == ("heartbeat thread woke 292 ms late: 6 ms waiting for a CPU, 5 ms stolen by the host, main thread "
                    "250 ms waiting for a CPU, process used 10 ms of CPU meanwhile; starved of CPU through the GIL: "
                    "the main thread, which most often holds it, was waiting for a CPU (the machine is overloaded)")
    # the heartbeat thread's own wait comes first
    own = late_wake_report(WakeSample(10.0, 1.0, 5.0, 3.0, 2.0), WakeSample(10.317, 1.2, 5.01, 3.0, 2.25), 0.025)
    assert own is not None and own.endswith("this process's niceness is too high")


def test_late_wake_without_waiting_running_or_steal_is_blocked():
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0, 3.0), WakeSample(10.155, 1.003, 5.0, 3.0), 0.025)
    assert line is not None and "130 ms late" in line
    assert "blocked: neither waiting for a CPU nor running" in line


def test_unknown_figures_still_report_the_lateness():
    line = late_wake_report(WakeSample(10.0, None, 5.0), WakeSample(10.5, None, 5.1), 0.025)
    assert line == ("heartbeat thread woke 475 ms late: run-queue wait unknown, process used 100 ms of CPU "
                    "meanwhile; cause unknown (no run-queue figures on this kernel)")


def test_a_thread_kept_from_the_gil_is_told_apart_from_real_samples():
    """Real `/proc` samples: a thread that sleeps while the main thread holds the GIL in a
    pure-Python loop is late without run-queue wait, and the process burnt the CPU."""
    results: list[str | None] = []
    sleeping = threading.Event()

    def sleeper() -> None:
        before = sample_wake()
        sleeping.set()
        time.sleep(0.01)  # wakes while the main thread holds the GIL
        results.append(late_wake_report(before, sample_wake(), 0.01))

    old = sys.getswitchinterval()
    sys.setswitchinterval(1.0)  # the main thread keeps the GIL for up to 1 s
    try:
        t = threading.Thread(target=sleeper)
        t.start()
        sleeping.wait(5.0)
        end = time.monotonic() + 0.4
        while time.monotonic() < end:
            pass
    finally:
        sys.setswitchinterval(old)
    t.join()
    assert results and results[0] is not None, "the sleeper was not held up"
    assert "GIL" in results[0] or "waiting for a CPU" in results[0], results[0]


def test_the_sampler_rereads_its_open_files(tmp_path):
    """Each sample reads the files afresh (a changed figure shows), through the files it opened
    (a file put in the path's place after it opened is not read)."""
    stat = tmp_path / "stat"
    schedstat = tmp_path / "schedstat"
    stat.write_text("cpu  10 0 10 100 0 0 0 200 0 0\ncpu0 5 0 5 50 0 0 0 100 0 0\n")
    schedstat.write_text("1000 2000000000 7\n")
    with WakeSampler(schedstat, stat) as sampler:
        first = sampler.sample()
        stat.write_text("cpu  10 0 10 100 0 0 0 900 0 0\n")  # same file, new content
        replacement = tmp_path / "new"
        replacement.write_text("1000 9000000000 9\n")
        os.replace(replacement, schedstat)  # a new file in the path's place
        second = sampler.sample()
    assert first.queue_wait_s == pytest.approx(2.0) and second.queue_wait_s == pytest.approx(2.0)
    ticks, cpus = os.sysconf("SC_CLK_TCK"), os.cpu_count()
    assert second.steal_s - first.steal_s == pytest.approx(700 / ticks / cpus)


def test_a_sampler_without_its_files_reports_unknown_figures(tmp_path):
    with WakeSampler(tmp_path / "missing", tmp_path / "missing-too") as sampler:
        sample = sampler.sample()
    assert sample.queue_wait_s is None and sample.steal_s is None and sample.process_cpu_s > 0
    sampler.close()  # closing twice is harmless
    assert sampler.sample().queue_wait_s is None


@pytest.mark.skipif(not Path("/proc/thread-self/schedstat").exists() or not Path("/proc/stat").exists(),
                    reason="this kernel has no /proc/thread-self/schedstat or /proc/stat")
def test_the_real_proc_files_are_read_afresh():
    """The thread's on-CPU time (first schedstat field) grows between two reads of the open file
    across a computation: the kernel regenerates the file on each read at offset 0."""
    def on_cpu_ns(fd: int) -> int:
        return int(os.pread(fd, 128, 0).split()[0])

    with WakeSampler() as sampler:
        fd = sampler._schedstat_fd
        before_ns = on_cpu_ns(fd)
        first = sampler.sample()
        sum(range(300_000))
        second = sampler.sample()
        after_ns = on_cpu_ns(fd)
    assert after_ns > before_ns
    assert first.queue_wait_s is not None and first.steal_s is not None
    assert second.queue_wait_s >= first.queue_wait_s and second.steal_s >= first.steal_s


@pytest.mark.skipif(not Path("/proc/thread-self/schedstat").exists() or not Path("/proc/self/schedstat").exists(),
                    reason="this kernel has no per-thread schedstat")
def test_a_sampler_made_in_a_thread_reads_that_thread_and_the_main_thread():
    """Made in a worker, the sampler's own file is the worker's and its main file the main
    thread's: while the main thread computes 0.1 s of CPU, only the main file's on-CPU grows."""
    def on_cpu_s(fd: int) -> float:
        return int(os.pread(fd, 128, 0).split()[0]) / 1e9

    made, measured, done = threading.Event(), threading.Event(), threading.Event()
    box: dict = {}

    def worker() -> None:
        sampler = WakeSampler()
        box["before"] = (on_cpu_s(sampler._schedstat_fd), on_cpu_s(sampler._main_schedstat_fd))
        made.set()
        done.wait(10.0)
        box["after"] = (on_cpu_s(sampler._schedstat_fd), on_cpu_s(sampler._main_schedstat_fd))
        box["sample"] = sampler.sample()
        sampler.close()
        measured.set()

    t = threading.Thread(target=worker)
    t.start()
    made.wait(5.0)
    start = time.thread_time()
    while time.thread_time() - start < 0.1:  # 0.1 s of this (main) thread's CPU
        pass
    done.set()
    measured.wait(10.0)
    t.join()
    own_s = box["after"][0] - box["before"][0]
    main_s = box["after"][1] - box["before"][1]
    assert main_s >= 0.09, main_s
    assert own_s < 0.05, own_s
    assert box["sample"].main_queue_wait_s is not None
