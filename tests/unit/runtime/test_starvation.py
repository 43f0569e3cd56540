"""Telling a CPU-starved heartbeat thread from a GIL-starved one (`services.runtime.starvation`)."""

from __future__ import annotations

import sys
import threading
import time

from services.runtime.starvation import WakeSample, late_wake_report, parse_schedstat, sample_wake


def test_schedstat_line_gives_the_run_queue_wait_in_seconds():
    assert parse_schedstat("355954009 2586612 34\n") == 0.002586612
    assert parse_schedstat("") is None
    assert parse_schedstat("1 2") is None
    assert parse_schedstat("1 x 3") is None


def test_on_time_wake_is_not_reported():
    a = WakeSample(10.0, 1.0, 5.0)
    assert late_wake_report(a, WakeSample(10.025, 1.0, 5.01), 0.025) is None
    assert late_wake_report(a, WakeSample(10.12, 1.09, 5.01), 0.025) is None  # 95 ms late: under 0.1 s


def test_late_wake_spent_on_the_run_queue_is_cpu_starvation():
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0), WakeSample(10.325, 1.28, 5.02), 0.025)
    assert line is not None
    assert line.startswith("heartbeat thread woke 300 ms late: 280 ms waiting for a CPU, process used 20 ms")
    assert "starved of CPU" in line


def test_late_wake_with_the_cpu_busy_elsewhere_in_the_process_is_the_gil():
    line = late_wake_report(WakeSample(10.0, 1.0, 5.0), WakeSample(10.325, 1.01, 5.29), 0.025)
    assert line is not None
    assert "10 ms waiting for a CPU, process used 290 ms of CPU" in line
    assert "GIL" in line


def test_unknown_run_queue_wait_still_reports_the_lateness():
    line = late_wake_report(WakeSample(10.0, None, 5.0), WakeSample(10.5, None, 5.1), 0.025)
    assert line == "heartbeat thread woke 475 ms late (process used 100 ms of CPU meanwhile; run-queue wait unknown)"


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
    assert "GIL" in results[0] or "run-queue wait unknown" in results[0], results[0]
