"""The engine's checkpoint file: every finished task's result, appended as it finishes.

A checkpoint is one binary file of pickled records:

1. a header: the format tag, the task function (``module:qualname``), the number of tasks
   and one SHA-256 digest per task argument (of its pickle, protocol 5);
2. then one ``(index, digest, result)`` record per finished task, in the order they finished,
   each flushed and fsync'ed before the next task's result is taken (a crash loses at most the
   record being written; a torn last record is cut off on the next open; a whole record that
   does not load, its result's class renamed since, is refused and nothing is cut).

Opening an existing checkpoint for the same function and the same arguments returns the
finished results (the engine skips those tasks: resume); any difference (function, number of
tasks, an argument) is refused with an `EngineUsageError` naming the first difference. An
argument's digest is that of its pickle, so an argument must pickle the same way each run
(numbers, strings, tuples, lists, dicts, numpy arrays and seeds, dataclasses of those and
functions by name do; a set of strings does not, its order changes between processes).

Only open checkpoints you wrote: loading a pickle runs code named in it.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from pathlib import Path
from typing import Any, BinaryIO, Callable, Sequence

from services.studies.engine_errors import EngineError, EngineUsageError

__all__ = ["CHECKPOINT_FORMAT", "Checkpoint", "argument_digest", "function_name"]

CHECKPOINT_FORMAT = "handover-engine-checkpoint/1"
_PROTOCOL = 5


def function_name(function: Callable) -> str:
    """``module:qualname`` of a task function (a partial names the function it wraps)."""
    inner = getattr(function, "func", function)
    return f"{getattr(inner, '__module__', '?')}:{getattr(inner, '__qualname__', type(inner).__name__)}"


def argument_digest(argument: Any) -> str:
    """SHA-256 of the argument's pickle (hex)."""
    try:
        return hashlib.sha256(pickle.dumps(argument, protocol=_PROTOCOL)).hexdigest()
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        raise EngineUsageError(f"a task argument cannot be pickled ({exc}): the engine sends arguments to "
                               "other processes, so they must be picklable") from exc


class Checkpoint:
    """An open checkpoint: `done` maps task index → result of the tasks already finished."""

    def __init__(self, path: Path, handle: BinaryIO, digests: list[str], done: dict[int, Any]) -> None:
        self.path = path
        self._handle = handle
        self._digests = digests
        self.done = done

    @classmethod
    def open(cls, path: Path | str, function: Callable, arguments: Sequence[Any]) -> "Checkpoint":
        """Create `path`, or reopen it for the same function and arguments (refuse otherwise)."""
        path = Path(path)
        handle: BinaryIO
        digests = [argument_digest(a) for a in arguments]
        header: dict[str, Any] = {"format": CHECKPOINT_FORMAT, "function": function_name(function),
                                  "tasks": len(arguments), "digests": digests}
        try:
            if path.exists() and path.stat().st_size > 0:
                done, good_bytes = _read(path, header)
                handle = path.open("r+b")
                handle.truncate(good_bytes)  # a torn last record from a crash
                handle.seek(good_bytes)
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                handle = path.open("wb")
                done = {}
                pickle.dump(header, handle, protocol=_PROTOCOL)
                _sync(handle)
        except OSError as exc:
            raise EngineError(f"cannot use the checkpoint {path}: {exc.strerror or exc} (check the folder and "
                              "its permissions)") from exc
        return cls(path, handle, digests, done)

    def append(self, index: int, result: Any) -> None:
        """Record task `index`'s result durably (flushed and fsync'ed)."""
        try:
            pickle.dump((index, self._digests[index], result), self._handle, protocol=_PROTOCOL)
            _sync(self._handle)
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            raise EngineError(f"task {index}'s result cannot be pickled into {self.path}: {exc}") from exc
        except OSError as exc:
            raise EngineError(f"cannot write to the checkpoint {self.path}: {exc.strerror or exc} "
                              "(is the disk full?)") from exc
        self.done[index] = result

    def close(self) -> None:
        """Close the file (everything written is already on disk)."""
        self._handle.close()


def _sync(handle: BinaryIO) -> None:
    handle.flush()
    os.fsync(handle.fileno())


def _read(path: Path, expected: dict) -> tuple[dict[int, Any], int]:
    """The finished results of a checkpoint that matches `expected`, and the length (bytes) of
    its intact part."""
    fresh = f"delete {path} (or choose another checkpoint) to start afresh"
    with path.open("rb") as fh:
        try:
            header = pickle.load(fh)
        except Exception as exc:  # noqa: BLE001 - any unreadable start means "not a checkpoint"
            raise EngineUsageError(f"{path} is not an engine checkpoint ({type(exc).__name__}); {fresh}") from exc
        if not isinstance(header, dict) or header.get("format") != CHECKPOINT_FORMAT:
            raise EngineUsageError(f"{path} is not an engine checkpoint (format {CHECKPOINT_FORMAT}); {fresh}")
        _check_same(path, header, expected, fresh)
        done: dict[int, Any] = {}
        good = fh.tell()
        while True:
            try:
                index, digest, result = pickle.load(fh)
            except EOFError:
                break
            except pickle.UnpicklingError:  # a record torn by a crash: keep what precedes it
                break
            except Exception as exc:  # noqa: BLE001 - a whole record that does not load is not torn
                raise EngineUsageError(f"{path}: the result of a finished task (record {len(done) + 1}) cannot be "
                                       f"loaded ({type(exc).__name__}: {exc}); the checkpoint is left as it is. "
                                       f"Load it with the code that wrote it, or {fresh}") from exc
            if not (isinstance(index, int) and 0 <= index < expected["tasks"]) or digest != expected["digests"][index]:
                break
            done[index] = result
            good = fh.tell()
    return done, good


def _check_same(path: Path, header: dict, expected: dict, fresh: str) -> None:
    """Refuse a checkpoint written for another function or other arguments."""
    if header.get("function") != expected["function"]:
        raise EngineUsageError(f"the checkpoint {path} holds results of {header.get('function')}, not of "
                               f"{expected['function']}; {fresh}")
    if header.get("tasks") != expected["tasks"]:
        raise EngineUsageError(f"the checkpoint {path} is for {header.get('tasks')} tasks, this run has "
                               f"{expected['tasks']} (different arguments); {fresh}")
    for i, (old, new) in enumerate(zip(header.get("digests", []), expected["digests"])):
        if old != new:
            raise EngineUsageError(f"the checkpoint {path} was written with other arguments (task {i} differs: "
                                   f"another seed, size or setting?); {fresh}")
