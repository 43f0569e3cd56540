"""Was the whole machine short of CPU over a stretch of time? (one host; `/proc` reads only.)

`MachineHistory` keeps the machine's cumulative CPU pressure (``/proc/pressure/cpu``, ``some``:
time during which at least one runnable task waited for a CPU) and steal (time the host took
from this virtual machine), read at the watcher's tick at most every `SAMPLE_PERIOD_S`, for
the last `KEEP_S`. `judge(since_s, now_s)` then says, for any silence that began at
`since_s`, how much of it the machine spent with tasks waiting for a CPU, from a reading taken
before the silence began: even when the watcher itself was starved through the silence and
reads again only at its end (its earlier reading is still valid: the counters only grow).

Both counters are kept up to date by the kernel at every read, unlike a thread's run-queue
wait (``schedstat``), which the kernel adds only once the thread gets a CPU.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from io import FileIO

from services.runtime.starvation import parse_steal, reread_text

#: Machine readings are taken at most this often, s (two small `/proc` reads in place).
SAMPLE_PERIOD_S = 0.02
#: Readings older than this are dropped, s (longer than any silence that may be excused).
KEEP_S = 3.0
#: Some task waited for a CPU at least this fraction of a silence: the machine was short of CPU.
PRESSURED_FRACTION = 0.5
#: The host took at least this fraction of a silence (per CPU): the machine was paused.
STOLEN_FRACTION = 0.3


@dataclass(frozen=True)
class MachineReading:
    """Cumulative machine figures at one instant.

    Attributes:
        at_s: local monotonic time of the reading, s.
        pressure_s: CPU pressure ``some`` total so far, s (None: the kernel does not say).
        steal_s: steal per CPU so far, s (None: not known).
    """

    at_s: float
    pressure_s: float | None
    steal_s: float | None


def parse_pressure_some(text: str) -> float | None:
    """The ``some`` total of ``/proc/pressure/cpu``, s (None when the text is not that)."""
    for line in text.splitlines():
        fields = line.split()
        if fields and fields[0] == "some":
            for field in fields[1:]:
                if field.startswith("total=") and field[6:].isdigit():
                    return int(field[6:]) / 1e6
    return None


class MachineReader:
    """Reads the machine's CPU pressure and steal, the two ``/proc`` files kept open and re-read
    in place (``pread`` at offset 0, as `services.runtime.starvation.WakeSampler` does: no
    open and close at each of the 40 readings a second of a watcher's tick). A file that cannot
    be opened or read gives None for its figure; the files close with the reader.

    Args:
        proc_root: where ``/proc`` is (tests point it elsewhere).
    """

    def __init__(self, proc_root: str = "/proc") -> None:
        self._pressure = self._open(f"{proc_root}/pressure/cpu")
        self._stat = self._open(f"{proc_root}/stat")

    @staticmethod
    def _open(path: str) -> FileIO | None:
        try:
            return FileIO(path, "rb")  # unbuffered; closed when the reader goes
        except OSError:
            return None

    @staticmethod
    def _read(file: FileIO | None) -> str | None:
        return None if file is None or file.closed else reread_text(file.fileno(), 256)

    def __call__(self, at_s: float) -> MachineReading:
        """The machine's CPU pressure and steal now, stamped `at_s` (None where unreadable)."""
        pressure_text, stat_text = self._read(self._pressure), self._read(self._stat)
        return MachineReading(at_s, None if pressure_text is None else parse_pressure_some(pressure_text),
                              None if stat_text is None else parse_steal(stat_text.split("\n", 1)[0]))

    def close(self) -> None:
        for file in (self._pressure, self._stat):
            if file is not None:
                file.close()


def read_machine(at_s: float, proc_root: str = "/proc") -> MachineReading:
    """The machine's CPU pressure and steal now (one-off; None where unreadable)."""
    reader = MachineReader(proc_root)
    try:
        return reader(at_s)
    finally:
        reader.close()


def _delta(older: float | None, newer: float | None) -> float | None:
    return None if older is None or newer is None else max(0.0, newer - older)


class MachineHistory:
    """Recent machine readings (see the module docstring).

    Args:
        read: `read_machine`-like reader, ``read(at_s)`` (default: a `MachineReader`; tests
            pass a fake).
    """

    def __init__(self, read=None) -> None:
        self._read = read if read is not None else MachineReader()
        self._readings: deque[MachineReading] = deque()

    def __len__(self) -> int:
        """Readings kept."""
        return len(self._readings)

    def observe(self, now_s: float) -> None:
        """Take a reading if the last is at least `SAMPLE_PERIOD_S` old (call at every tick)."""
        if self._readings and now_s - self._readings[-1].at_s < SAMPLE_PERIOD_S:
            return
        self._readings.append(self._read(now_s))
        while self._readings and now_s - self._readings[0].at_s > KEEP_S:
            self._readings.popleft()

    def judge(self, since_s: float, now_s: float) -> tuple[bool, str] | None:
        """(short of CPU?, one clause saying why or what was seen) from `since_s` to `now_s`;
        None when nothing is known.

        Judged from the newest reading taken at or before `since_s` (else the oldest kept) to
        a reading taken now."""
        before = None
        for reading in self._readings:
            if reading.at_s > since_s:
                break
            before = reading
        if before is None:
            if not self._readings:
                return None
            before = self._readings[0]
        now = self._read(now_s)
        span_s = now.at_s - before.at_s
        waited = _delta(before.pressure_s, now.pressure_s)
        stolen = _delta(before.steal_s, now.steal_s)
        if span_s <= 0.0 or (waited is None and stolen is None):
            return None
        span_ms = 1000.0 * span_s
        if stolen is not None and stolen >= STOLEN_FRACTION * span_s:
            return True, f"the host took {1000.0 * stolen:.0f} ms of {span_ms:.0f} ms from this machine"
        if waited is None:
            return False, f"the host took {1000.0 * (stolen or 0.0):.0f} ms of {span_ms:.0f} ms"
        clause = f"some task waited for a CPU {100.0 * waited / span_s:.0f} % of {span_ms:.0f} ms"
        if waited >= PRESSURED_FRACTION * span_s:
            return True, f"the machine was short of CPU: {clause}"
        return False, clause

    def short_of_cpu(self, since_s: float, now_s: float) -> str | None:
        """Why the machine was short of CPU from `since_s` to `now_s` (one clause), or None."""
        verdict = self.judge(since_s, now_s)
        return verdict[1] if verdict is not None and verdict[0] else None
