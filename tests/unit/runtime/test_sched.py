"""Starved or frozen: the run-queue judge (`services.runtime.sched`) on fake readings and on a
few real processes (the busy-loop ones: test_sched_real.py)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys


from services.runtime.machine_load import MachineHistory, MachineReading
from services.runtime.sched import (SchedSample, ServiceStarvation, StarvationJudge, delivery_pids,
                                    parse_state, read_sched, runs_a_service, starved)
from services.runtime.testing import wait_until
from services.supervisor.watchdog import Watchdog


def test_state_and_run_queue_wait_of_this_process_are_read():
    assert parse_state("123 (python -m x) S 1 2 3") == "S"
    assert parse_state("123 (a) b) T 1") == "T"  # the last ')' ends the name
    assert parse_state("garbage") is None
    sample = read_sched(os.getpid(), 5.0)
    assert sample is not None and sample.state == "R" and sample.queue_wait_s >= 0.0 and sample.at_s == 5.0
    assert read_sched(2 ** 22 + 1, 0.0) is None  # no such process


def test_starved_needs_a_third_of_the_window_on_the_run_queue_and_not_stopped():
    a = SchedSample(10.0, 1.0, "R")
    assert starved(a, SchedSample(10.1, 1.03, "R"))
    assert not starved(a, SchedSample(10.1, 1.02, "R"))  # 20 % of the window
    assert not starved(a, SchedSample(10.1, 1.09, "T"))  # stopped now
    assert not starved(a, SchedSample(10.0, 1.09, "R"))  # no window


class FakeReader:
    def __init__(self) -> None:
        self.samples: dict[int, SchedSample | None] = {}
        self.reads = 0

    def __call__(self, pid: int, at_s: float) -> SchedSample | None:
        self.reads += 1
        s = self.samples.get(pid)
        return None if s is None else SchedSample(at_s, s.queue_wait_s, s.state)


def test_the_judge_excuses_only_after_a_starved_window_and_never_a_stopped_process():
    fake = FakeReader()
    judge = StarvationJudge(fake)
    fake.samples[7] = SchedSample(0.0, 1.0, "R")
    assert judge.excuse(7, 10.0) is None  # one reading: no window yet
    fake.samples[7] = SchedSample(0.0, 1.07, "R")
    judge.note(7, 10.05)  # under a window: not read (excuse read it twice: a window and the state)
    assert fake.reads == 2
    why = judge.excuse(7, 10.1)  # 70 ms of 100 on the run queue
    assert why is not None and "waited 70 ms" in why
    fake.samples[7] = SchedSample(0.0, 1.07, "T")  # SIGSTOP since the window: at once not excused
    assert judge.excuse(7, 10.12) is None
    fake.samples[7] = SchedSample(0.0, 1.08, "S")  # blocked since: 10 ms of 100 waited, 80 of 220 in the spell
    assert judge.excuse(7, 10.22) is not None and "since it went quiet" in judge.explain(7)
    fake.samples[7] = SchedSample(0.0, 1.08, "S")  # blocked for good: the spell's share falls
    judge.note(7, 10.31)
    assert judge.excuse(7, 10.40) is None and "in the last window" in judge.explain(7)


def test_a_process_starved_early_in_its_silence_is_excused_though_it_runs_now():
    """The late-beat case: it waited for a CPU, then ran (its beat on the way) as the watcher judged."""
    fake = FakeReader()
    judge = StarvationJudge(fake)
    fake.samples[5] = SchedSample(0.0, 0.0, "R")
    judge.note(5, 1.00, quiet_since_s=0.94)
    fake.samples[5] = SchedSample(0.0, 0.075, "R")  # 75 of 80 ms on the run queue
    judge.note(5, 1.08, quiet_since_s=0.94)
    fake.samples[5] = SchedSample(0.0, 0.080, "R")  # then it ran: 5 of 80 ms
    judge.note(5, 1.17, quiet_since_s=0.94)
    why = judge.excuse(5, 1.17)
    assert why is not None and "waited 80 ms for a CPU in 170 ms since it went quiet" in why
    # Heard from at 1.2: a new spell starts from a new reading, not the old one.
    fake.samples[5] = SchedSample(0.0, 0.085, "S")
    judge.note(5, 1.25, quiet_since_s=1.20)
    fake.samples[5] = SchedSample(0.0, 0.090, "S")
    judge.note(5, 1.34, quiet_since_s=1.20)
    assert judge.excuse(5, 1.34) is None


def test_an_old_reading_opens_a_new_window_rather_than_closing_one():
    fake = FakeReader()
    judge = StarvationJudge(fake)
    fake.samples[3] = SchedSample(0.0, 1.0, "R")
    judge.note(3, 0.0)
    fake.samples[3] = SchedSample(0.0, 3.0, "R")  # 2 s waited ... over 10 s: another quiet spell
    assert judge.excuse(3, 10.0) is None


def test_service_starvation_uses_pids_only_of_the_stacks_processes():
    fake = FakeReader()
    checked = []
    adapter = ServiceStarvation(StarvationJudge(fake), check_pid=lambda pid: checked.append(pid) or pid == 11)
    adapter.heard("bridge", 0)
    adapter.heard("bridge", 12)  # not one of ours: refused, and not checked again
    adapter.heard("bridge", 12)
    assert checked == [12] and adapter.excuse("bridge", 1.0) is None
    adapter.heard("bridge", 11)
    fake.samples[11] = SchedSample(0.0, 0.0, "R")
    adapter.note("bridge", 1.0)
    fake.samples[11] = SchedSample(0.0, 0.09, "R")
    assert adapter.excuse("bridge", 1.1) is not None



def test_only_a_process_running_a_module_of_the_stack_counts_as_a_service():
    assert not runs_a_service(os.getpid())  # pytest
    assert not runs_a_service(2 ** 22 + 1)
    proc = subprocess.Popen([sys.executable, "-m", "services.launcher.router"], stdin=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # waits for its config
    try:
        assert wait_until(lambda: runs_a_service(proc.pid), 5.0)  # once it has exec'd
    finally:
        proc.kill()
        proc.wait(5.0)


class FixedExcuser:
    def __init__(self, why: str | None) -> None:
        self.why, self.noted, self.ticks = why, [], 0
        self.stopped_services: set[str] = set()

    def note(self, service: str, now_s: float, quiet_since_s: float | None = None) -> None:
        self.noted.append((service, now_s))
        self.since = quiet_since_s

    def excuse(self, service: str, now_s: float) -> str | None:
        return self.why

    def tick(self, now_s: float) -> None:
        self.ticks += 1

    def exited(self) -> set[str]:
        return set()

    def stopped(self, service: str, now_s: float) -> bool:
        return service in self.stopped_services

    def revived(self, service: str) -> None:
        pass


def test_the_watchdog_excuses_a_starved_silence_up_to_its_bound_but_never_a_lost_service():
    excuser = FixedExcuser("its threads waited 200 ms for a CPU")
    dog = Watchdog(["bridge", "gripper"], heartbeat_timeout_s=0.25, excuser=excuser, max_excused_s=1.0)
    for name in ("bridge", "gripper"):
        dog.liveliness(name, True, 0.0)
        dog.heartbeat(name, 0.0)
    assert dog.check(0.05) == [] and excuser.noted == [] and excuser.ticks == 1  # a beat's period: not noted
    assert dog.check(0.1) == [] and ("bridge", 0.1) in excuser.noted and excuser.since == 0.0  # quiet > 60 ms
    assert dog.check(0.5) == [] and {s for s, _ in dog.excused} == {"bridge", "gripper"}
    dog.liveliness("gripper", False, 0.6)
    faults = dog.check(0.6)
    assert [(f.service, f.what) for f in faults] == [("gripper", "lost")]
    faults = dog.check(1.01)  # past the bound: silent whatever the reason
    assert [(f.service, f.what) for f in faults] == [("bridge", "silent")]
    plain = Watchdog(["bridge"], heartbeat_timeout_s=0.25, excuser=FixedExcuser(None))
    plain.liveliness("bridge", True, 0.0)
    plain.heartbeat("bridge", 0.0)
    assert [f.service for f in plain.check(0.26)] == ["bridge"]


def test_a_starved_delivery_path_excuses_every_service_but_a_running_one_excuses_none():
    fake = FakeReader()
    adapter = ServiceStarvation(StarvationJudge(fake), check_pid=lambda pid: True, path_pids=(90, 91))
    adapter.heard("bridge", 11)
    for pid in (11, 90, 91):
        fake.samples[pid] = SchedSample(0.0, 0.0, "S")
    adapter.note("bridge", 1.0)
    fake.samples[91] = SchedSample(0.0, 0.06, "R")  # the router waited 60 of 100 ms for a CPU
    adapter.note("bridge", 1.1)
    why = adapter.excuse("bridge", 1.1)
    assert why is not None and "delivery path" in why and "pid 91" in why
    fake.samples[91] = SchedSample(0.0, 0.065, "S")  # the router ran again: 5 of 100 ms ...
    adapter.note("bridge", 1.2)
    assert adapter.excuse("bridge", 1.2) is not None  # ... but 65 of the spell's 200 ms waited
    adapter.note("bridge", 1.3)  # 65 of 300 ms
    assert adapter.excuse("bridge", 1.3) is None
    assert delivery_pids()[0] == os.getpid()


def test_a_refused_excuse_says_what_the_judge_saw():
    fake = FakeReader()
    adapter = ServiceStarvation(StarvationJudge(fake), check_pid=lambda pid: True, path_pids=(90,))
    assert adapter.explain("bridge").startswith("pid unknown")
    adapter.heard("bridge", 11)
    for pid in (11, 90):
        fake.samples[pid] = SchedSample(0.0, 0.0, "S")
    adapter.note("bridge", 1.0)
    fake.samples[11] = SchedSample(0.0, 0.01, "S")
    adapter.note("bridge", 1.1)
    line = adapter.explain("bridge")
    assert "pid 11 not starved: its threads waited 10 ms for a CPU in 100 ms in the last window (state S)" in line
    assert "path pid 90 not starved: its threads waited 0 ms" in line



class FakeMachine:
    def __init__(self) -> None:
        self.reading = MachineReading(0.0, 0.0, 0.0)

    def __call__(self, at_s: float) -> MachineReading:
        return MachineReading(at_s, self.reading.pressure_s, self.reading.steal_s)


def test_a_silence_on_a_machine_short_of_cpu_is_excused_even_when_the_watcher_judges_late():
    """schedstat adds a thread's wait only once it runs: a process waiting now shows none. The
    machine's pressure, read at the watcher's ticks from before the silence, says it."""
    fake, machine = FakeReader(), FakeMachine()
    judge = StarvationJudge(fake, MachineHistory(machine))
    fake.samples[4] = SchedSample(0.0, 1.0, "R")
    machine.reading = MachineReading(0.0, 10.0, 0.0)
    judge.tick(1.00)  # the last tick before the watcher itself was starved
    machine.reading = MachineReading(0.0, 10.17, 0.0)  # some task waited 170 of the next 210 ms
    judge.note(4, 1.21, quiet_since_s=1.005)  # first note at the verdict: no window of the process
    why = judge.excuse(4, 1.21)
    assert why is not None and "short of CPU: some task waited for a CPU 81 % of 210 ms" in why
    fake.samples[4] = SchedSample(0.0, 1.0, "T")  # stopped: never excused, whatever the machine did
    assert judge.excuse(4, 1.22) is None


def test_a_silence_on_a_machine_with_cpu_to_spare_is_not_excused():
    fake, machine = FakeReader(), FakeMachine()
    judge = StarvationJudge(fake, MachineHistory(machine))
    fake.samples[4] = SchedSample(0.0, 1.0, "S")
    machine.reading = MachineReading(0.0, 10.0, 0.0)
    judge.tick(1.00)
    machine.reading = MachineReading(0.0, 10.05, 0.0)  # 50 of 210 ms: a deadlock, not starvation
    judge.note(4, 1.21, quiet_since_s=1.005)
    assert judge.excuse(4, 1.21) is None
    assert "some task waited for a CPU 24 % of 210 ms" in judge.explain(4)


def test_a_stopped_or_gone_service_is_never_excused_by_a_busy_delivery_path_or_machine():
    fake, machine = FakeReader(), FakeMachine()
    adapter = ServiceStarvation(StarvationJudge(fake, MachineHistory(machine)), check_pid=lambda pid: True,
                                path_pids=(90,))
    adapter.heard("bridge", 11)
    fake.samples[11] = SchedSample(0.0, 0.0, "S")
    fake.samples[90] = SchedSample(0.0, 0.0, "S")
    machine.reading = MachineReading(0.0, 10.0, 0.0)
    adapter.tick(1.0)
    adapter.note("bridge", 1.0, quiet_since_s=0.95)
    fake.samples[90] = SchedSample(0.0, 0.09, "R")  # the router waited 90 of 100 ms ...
    machine.reading = MachineReading(0.0, 10.09, 0.0)  # ... on a machine short of CPU
    adapter.note("bridge", 1.1, quiet_since_s=0.95)
    assert adapter.excuse("bridge", 1.1) is not None  # a sleeping bridge: excused
    fake.samples[11] = SchedSample(0.0, 0.0, "T")  # SIGSTOP
    assert adapter.excuse("bridge", 1.1) is None
    fake.samples[11] = None  # killed
    assert adapter.excuse("bridge", 1.1) is None
    # The path alone is judged on its own wait, not on the machine's.
    judge = StarvationJudge(fake, MachineHistory(machine))
    fake.samples[91] = SchedSample(0.0, 0.0, "S")
    judge.tick(2.0)
    judge.note(91, 2.0, quiet_since_s=2.0)
    machine.reading = MachineReading(0.0, 10.5, 0.0)
    judge.note(91, 2.1, quiet_since_s=2.0)
    assert judge.excuse(91, 2.1) is not None and judge.excuse_path((91,), 2.1) is None


def test_a_killed_service_is_known_lost_from_the_kernel_without_the_bus():
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    adapter = ServiceStarvation(check_pid=lambda pid: True)
    dog = Watchdog(["planner"], heartbeat_timeout_s=0.25, excuser=adapter)
    try:
        dog.liveliness("planner", True, 0.0)
        dog.heartbeat("planner", 0.0)
        adapter.heard("planner", proc.pid)
        assert dog.check(0.01) == [] and adapter.exited() == set()
        proc.kill()
        assert wait_until(lambda: adapter.exited() == {"planner"}, 5.0)  # not reaped yet: a zombie
        faults = dog.check(0.02)  # the liveliness token is still there
        assert [(f.service, f.what, f.detail) for f in faults] == [("planner", "lost", "process gone (it exited)")]
        dog.liveliness("planner", False, 0.03)
        dog.liveliness("planner", True, 0.5)  # restarted: the old process speaks no more for it
        assert adapter.exited() == set()
    finally:
        proc.kill()
        proc.wait(5.0)
        adapter.exits.close()


def test_a_service_whose_process_is_stopped_is_silent_after_two_beats_not_the_full_time_out():
    excuser = FixedExcuser("the machine was short of CPU")
    dog = Watchdog(["bridge", "gripper"], heartbeat_timeout_s=0.2, excuser=excuser)
    for name in ("bridge", "gripper"):
        dog.liveliness(name, True, 0.0)
        dog.heartbeat(name, 0.0)
    excuser.stopped_services = {"gripper"}
    assert dog.check(0.09) == []  # under two beats: not judged yet
    faults = dog.check(0.11)
    assert [(f.service, f.detail) for f in faults] == [
        ("gripper", "silent: no heartbeat for 0.110 s, its process is stopped")]
    assert dog.check(0.3) == []  # the bridge, quiet but not stopped: excused (starved), not stopped


def test_a_stopped_process_is_known_stopped_and_a_running_or_gone_one_is_not():
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    adapter = ServiceStarvation(check_pid=lambda pid: True)
    try:
        adapter.heard("motion", proc.pid)
        assert not adapter.stopped("motion", 0.0) and not adapter.stopped("nobody", 0.0)
        proc.send_signal(signal.SIGSTOP)
        assert wait_until(lambda: adapter.stopped("motion", 0.0), 5.0)
        proc.send_signal(signal.SIGCONT)
        proc.kill()
        proc.wait(5.0)
        assert not adapter.stopped("motion", 0.0)  # gone: the kernel's exit and liveliness tell
    finally:
        proc.kill()
        proc.wait(5.0)
        adapter.exits.close()


def test_a_watcher_starved_mid_silence_still_judges_it_from_its_start():
    """The watcher's own stall makes its last reading stale: the spell starts over, but it
    still began when the service was last heard from."""
    fake, machine = FakeReader(), FakeMachine()
    judge = StarvationJudge(fake, MachineHistory(machine))
    fake.samples[6] = SchedSample(0.0, 0.0, "S")
    machine.reading = MachineReading(0.0, 10.0, 0.0)
    judge.tick(0.99)
    judge.note(6, 1.0, quiet_since_s=0.95)
    machine.reading = MachineReading(0.0, 10.3, 0.0)  # the watcher itself stalled 0.5 s
    judge.note(6, 1.5, quiet_since_s=0.95)
    why = judge.excuse(6, 1.5)
    assert why is not None and "short of CPU" in why
