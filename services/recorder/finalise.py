"""Finalising a recording: Rerun's footer (the chunk manifest) added once the file is complete.

While it records, the writer streams the file without a footer (`writer`): Rerun's file sink
would keep the footer's metadata for every chunk in memory until the file is closed (measured:
+86 MB RSS over 5 minutes of recording, 330 MB at close). A footer-less file is read in one pass
by the viewer and `readback`, but ``rerun rrd verify`` rejects it ("Missing RRD footer").

`finalise` rewrites a footer-less file with its footer, with Rerun's own tool (the ``rerun`` CLI
of the rerun-sdk wheel), into a folder beside the file:

1. ``rerun rrd optimize FILE -o COPY`` reads every message, merges the small chunks of each
   flush into larger ones and writes every store (the recording, the blueprint and its
   activation) with the footer. 12 s of the stack's messages: 460 chunks → 161, 2.50 → 2.46 MB
   (the compaction pays for the footer; 5 minutes: 57 → 31 MB). A file cut off by a SIGKILL
   mid-write ends inside a message: that incomplete message is left out
   (``--continue-on-error`` when the original cannot be read to its end), and the report says so;
2. the copy must have its footer, the same number of temporal rows for every entity of every
   store as the original (when the original can be read whole) and the same static entities
   (static rows are last-write-wins: compaction keeps the last); only then does it replace the
   original (`os.replace`, atomic). On any failure the original is left as it was.

The recorder finalises its file when it is stopped normally (`node.close_and_finalise`); after
a crash ``handover-recorder finalise FILE`` does it. Cost: the child holds the whole recording
while it compacts it (55 MB for 12 s of recording, 175 MB for 5 minutes, 410 MB for 15), and
this process reads the file twice to count; the whole step took 0.5 s, 4.4 s and 13 s on two
shared cores at load ≈ 2 (docs/recorder.md).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from services.recorder import rerun_env  # noqa: F401  (before the first `import rerun`)
from services.recorder.errors import RecorderError


class RecordingUnreadable(RecorderError):
    """The file is not a Rerun recording (or holds no data): nothing to finalise; left as it was."""

    bad_input = False


class FinaliseFailed(RecorderError):
    """Rerun's tools could not rewrite the file, or the rewrite lost something; original kept."""

    bad_input = False


@dataclass(frozen=True)
class Contents:
    """What a recording holds: chunks, temporal rows per (store kind, entity path), and the
    entities with static data per store kind."""

    chunks: int = 0
    rows: dict[tuple[str, str], int] = field(default_factory=dict)
    static: frozenset[tuple[str, str]] = frozenset()

    @property
    def total_rows(self) -> int:
        return sum(self.rows.values())

    def bus_messages(self) -> dict[str, int]:
        """Messages per bus key: the rows of each ``bus/<key>`` entity of the recording."""
        return {entity.removeprefix("/bus/"): n for (kind, entity), n in sorted(self.rows.items())
                if kind == "recording" and entity.startswith("/bus/")}


@dataclass(frozen=True)
class FinaliseReport:
    """The outcome of `finalise` for one file."""

    path: Path
    #: The file had a footer already: left as it was (`kept` is then not counted).
    already_finalised: bool = False
    #: What the finalised file holds.
    kept: Contents = field(default_factory=Contents)
    #: Why the original could not be read whole (its end was cut off), or None.
    damaged_end: str | None = None
    #: Chunks of the original (0 when it could not be read whole).
    chunks_before: int = 0
    bytes_before: int = 0
    bytes_after: int = 0
    seconds: float = 0.0

    def line(self) -> str:
        """One line for the console."""
        if self.already_finalised:
            return f"{self.path}: already has its footer; unchanged"
        bus = self.kept.bus_messages()
        chunks = f"{self.chunks_before} chunks compacted into {self.kept.chunks}" if self.chunks_before else \
            f"{self.kept.chunks} chunks"
        keys = f"{len(bus)} key" + ("" if len(bus) == 1 else "s")
        text = (f"finalised {self.path}: kept {sum(bus.values())} bus messages on {keys}, "
                f"{self.kept.total_rows} rows in all, {len(self.kept.static)} static entities; {chunks}; footer "
                f"written ({self.bytes_before / 1e6:.2f} → {self.bytes_after / 1e6:.2f} MB, {self.seconds:.1f} s)")
        if self.damaged_end is None:
            return text + "; nothing dropped"
        return (text + "; the file's end was cut off (the recorder was killed while writing): its incomplete "
                f"last message was dropped (reader: {self.damaged_end})")


def has_footer(path: Path) -> bool:
    """True when `path` ends with Rerun's footer (``rerun rrd verify`` requires it)."""
    import rerun_bindings

    try:
        return bool(rerun_bindings.check_for_rrd_footer(str(path)))
    except Exception:  # noqa: BLE001 - unreadable (Rerun's bindings raise several types): not finalised
        return False


def read_contents(path: Path) -> Contents:
    """Chunks, temporal rows per (store kind, entity) and static entities of every store of
    `path`, read whole.

    Raises:
        RecordingUnreadable: `path` is not a Rerun recording, or holds no store.
        RuntimeError: from Rerun's reader, when the file cannot be read to its end (cut off).
    """
    import rerun.chunk as rrc

    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="RRD file has no footer")
            reader = rrc.RrdReader(str(path))
    except Exception as exc:  # noqa: BLE001 - whatever Rerun's reader raises becomes RecordingUnreadable
        raise RecordingUnreadable(f"{path} is not a Rerun recording ({_first_line(exc)}); left unchanged") from None
    stores = [*reader.recordings(), *reader.blueprints()]  # a file cut off mid-message raises here
    if not stores:
        raise RecordingUnreadable(f"{path} holds no complete message (the recorder stopped before its first "
                                  "write?); left unchanged")
    chunks = 0
    rows: Counter[tuple[str, str]] = Counter()
    static: set[tuple[str, str]] = set()
    for store in stores:
        for chunk in reader.stream(store=store):
            chunks += 1
            if chunk.is_static:
                static.add((store.kind, chunk.entity_path))
            else:
                rows[(store.kind, chunk.entity_path)] += chunk.num_rows
    return Contents(chunks, dict(rows), frozenset(static))


def finalise(path: Path) -> FinaliseReport:
    """Give the recording at `path` its footer, keeping every complete message (module docstring).

    Raises:
        RecorderError: `path` does not exist (a usage error).
        RecordingUnreadable: it is not a Rerun recording, or holds no complete message; unchanged.
        FinaliseFailed: Rerun's tools failed, or the rewrite would change rows; unchanged.
    """
    path = Path(path)
    if not path.is_file():
        raise RecorderError(missing_file(path))
    bytes_before = path.stat().st_size
    if has_footer(path):
        return FinaliseReport(path, already_finalised=True, bytes_before=bytes_before, bytes_after=bytes_before)
    t0 = time.perf_counter()
    damaged_end: str | None = None
    try:
        before: Contents | None = read_contents(path)
    except RecordingUnreadable:
        raise
    except Exception as exc:  # noqa: BLE001 - cut off by a SIGKILL mid-write: its last message is incomplete
        before, damaged_end = None, _first_line(exc)
    try:
        work = Path(tempfile.mkdtemp(prefix=f".{path.stem}.finalise-", dir=path.parent))  # same file system
        try:
            copy = work / f"{path.stem}.rrd"
            kept = _rewrite(path, copy, before, cut_off=damaged_end is not None)
            os.replace(copy, path)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    except OSError as exc:  # e.g. a read-only folder
        raise FinaliseFailed(f"{path}: {exc}; left unchanged") from None
    return FinaliseReport(path, kept=kept, damaged_end=damaged_end, chunks_before=before.chunks if before else 0,
                          bytes_before=bytes_before, bytes_after=path.stat().st_size,
                          seconds=time.perf_counter() - t0)


def _rewrite(path: Path, copy: Path, before: Contents | None, cut_off: bool) -> Contents:
    """`path` into `copy`, compacted, with its footer (module docstring); returns what it holds."""
    # --continue-on-error: stop at the damage instead of failing (the messages before it are kept).
    _rerun(["rrd", "optimize", *(["--continue-on-error"] if cut_off else []), str(path), "-o", str(copy)], path)
    try:
        kept = read_contents(copy)
    except RecordingUnreadable:
        raise RecordingUnreadable(f"{path} holds no complete message (the recorder stopped before its first "
                                  "write?); left unchanged") from None
    if not has_footer(copy):
        raise FinaliseFailed(f"{path}: `rerun rrd optimize` wrote no footer; left unchanged")
    if before is not None and (kept.rows != before.rows or kept.static != before.static):
        changed = {k: (before.rows.get(k, 0), kept.rows.get(k, 0)) for k in before.rows.keys() | kept.rows.keys()
                   if before.rows.get(k, 0) != kept.rows.get(k, 0)}
        static = sorted(before.static ^ kept.static)
        raise FinaliseFailed(f"{path}: the rewrite would change rows (before, after): {changed}, static entities: "
                             f"{static}; left unchanged")
    return kept


def missing_file(path: Path) -> str:
    """The usage error for a path that is not a recording's file."""
    return f"recording {path} {'is not a file' if path.exists() else 'does not exist'}"


def rerun_cli() -> str:
    """Path of the ``rerun`` executable of the installed rerun-sdk (``RERUN_CLI_PATH`` wins)."""
    if os.environ.get("RERUN_CLI_PATH"):
        return os.environ["RERUN_CLI_PATH"]
    try:
        import rerun_cli as package

        exe = Path(package.__file__).with_name("rerun")
        if exe.is_file():
            return str(exe)
    except ImportError:
        pass
    found = shutil.which("rerun")
    if found is None:
        raise FinaliseFailed("the rerun CLI (from the rerun-sdk package) was not found")
    return found


def _rerun(args: list[str], path: Path) -> None:
    """Run the rerun CLI; an exception while it runs (a signal: see `node`) ends it too."""
    env = dict(os.environ, RUST_LOG="error")  # its progress lines are not ours to print
    proc = subprocess.Popen([rerun_cli(), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if proc.returncode != 0:
        detail = " / ".join(line.strip() for line in (err or out).splitlines() if line.strip())
        raise FinaliseFailed(f"{path}: `rerun {' '.join(args[:2])}` failed ({detail[-300:]}); left unchanged")


def _first_line(exc: BaseException) -> str:
    """The first line of Rerun's message, without the file name it repeats."""
    text = (str(exc).strip() or type(exc).__name__).splitlines()[0]
    return text.split(": ", 1)[1] if text.startswith("Failed to read RRD file at ") and ": " in text else text
