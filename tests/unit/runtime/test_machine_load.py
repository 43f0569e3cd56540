"""The machine's CPU pressure and steal over a silence (`services.runtime.machine_load`)."""

from __future__ import annotations

import os

from services.runtime.machine_load import (KEEP_S, SAMPLE_PERIOD_S, MachineHistory, MachineReading,
                                           parse_pressure_some, read_machine)


def test_the_machines_cpu_pressure_and_steal_are_read():
    text = "some avg10=1.00 avg60=2.00 avg300=3.00 total=4809551227\nfull avg10=0.00 avg60=0.00 avg300=0.00 total=0\n"
    assert parse_pressure_some(text) == 4809.551227
    assert parse_pressure_some("full total=3") is None and parse_pressure_some("some total=x") is None
    now = read_machine(5.0)
    assert now.at_s == 5.0 and now.steal_s is not None and now.steal_s >= 0.0
    if os.path.exists("/proc/pressure/cpu"):
        assert now.pressure_s is not None and now.pressure_s > 0.0
    assert read_machine(1.0, "/nonexistent") == MachineReading(1.0, None, None)


class Script:
    """Readings by time: the newest entry at or before the time asked."""

    def __init__(self, entries: list[tuple[float, float | None, float | None]]) -> None:
        self.entries, self.reads = entries, 0

    def __call__(self, at_s: float) -> MachineReading:
        self.reads += 1
        pressure, steal = next((p, s) for t, p, s in reversed(self.entries) if t <= at_s)
        return MachineReading(at_s, pressure, steal)


def test_a_silence_is_judged_from_the_reading_before_it_began():
    script = Script([(0.0, 10.0, 1.0), (1.05, 10.0, 1.0), (1.25, 10.15, 1.0)])
    machine = MachineHistory(script)
    for t in (0.9, 0.91, 0.95, 1.0):  # one reading per SAMPLE_PERIOD_S at most
        machine.observe(t)
    assert script.reads == 3 and SAMPLE_PERIOD_S == 0.02
    verdict = machine.judge(1.02, 1.25)  # the silence began after the reading at 1.0
    assert verdict == (True, "the machine was short of CPU: some task waited for a CPU 60 % of 250 ms")
    assert machine.short_of_cpu(1.02, 1.25) is not None
    assert machine.judge(1.02, 1.0) is None  # no time covered


def test_steal_alone_or_a_free_machine():
    machine = MachineHistory(Script([(0.0, 10.0, 1.0), (0.5, 10.02, 1.08)]))
    machine.observe(0.3)
    assert machine.judge(0.35, 0.5) == (True, "the host took 80 ms of 200 ms from this machine")
    free = MachineHistory(Script([(0.0, 10.0, 1.0), (0.5, 10.05, 1.0)]))
    free.observe(0.3)
    assert free.judge(0.35, 0.5) == (False, "some task waited for a CPU 25 % of 200 ms")
    assert free.short_of_cpu(0.35, 0.5) is None
    assert MachineHistory(Script([(0.0, None, None)])).judge(0.0, 1.0) is None  # never observed
    unknown = MachineHistory(Script([(0.0, None, None)]))
    unknown.observe(0.0)
    assert unknown.judge(0.1, 0.5) is None  # the kernel says nothing


def test_old_readings_are_dropped():
    machine = MachineHistory(Script([(0.0, 1.0, 0.0)]))
    for k in range(400):
        machine.observe(k * 0.05)
    assert len(machine) <= KEEP_S / 0.05 + 1


def test_the_reader_keeps_its_files_open_and_reads_them_again_in_place(tmp_path):
    """`MachineReader`: each reading re-reads the same open files from the start (a rewritten
    file gives its new figures; the reader holds the same two descriptors throughout)."""
    from services.runtime.machine_load import MachineReader

    (tmp_path / "pressure").mkdir()
    pressure, stat = tmp_path / "pressure" / "cpu", tmp_path / "stat"

    def write(pressure_us: int, steal_ticks: int) -> None:
        pressure.write_text(f"some avg10=0.00 avg60=0.00 avg300=0.00 total={pressure_us}\n")
        stat.write_text(f"cpu  1 0 1 100 0 0 0 {steal_ticks} 0 0\ncpu0 1 0 1 100 0 0 0 {steal_ticks} 0 0\n")

    write(2_000_000, 0)
    before = set(os.listdir("/proc/self/fd"))
    reader = MachineReader(str(tmp_path))
    fds = sorted(os.listdir("/proc/self/fd"))
    assert len(set(fds) - before) == 2  # its two files, held open
    first = reader(1.0)
    with open(pressure, "r+") as f, open(stat, "r+") as g:  # rewritten in place: the same files
        f.write("some avg10=0.00 avg60=0.00 avg300=0.00 total=5000000\n")
        g.seek(0)
        g.write(stat.read_text().replace(" 100 0 0 0 0 ", " 100 0 0 0 9 "))
    second = reader(2.0)
    assert sorted(os.listdir("/proc/self/fd")) == fds
    assert (first.at_s, first.pressure_s) == (1.0, 2.0)
    assert (second.at_s, second.pressure_s) == (2.0, 5.0)
    assert second.steal_s is not None and first.steal_s is not None and second.steal_s > first.steal_s
    reader.close()
    assert reader(3.0) == MachineReading(3.0, None, None)
