"""The studies' engine: run many independent tasks on Dask distributed, local or on a cluster.

`run_tasks(function, arguments)` runs ``function(argument)`` for every argument and returns
the results in argument order. Where the tasks run:

- ``address=None`` (default): a Dask `LocalCluster` started for the call: ``workers`` worker
  processes (default: every core), one thread each, scheduler, workers and nannies listening
  on 127.0.0.1 only (the scheduler's HTTP server too: health checks only, the dashboard needs
  bokeh, which is not installed); torn down after the call, also on an error or Ctrl-C (any
  process of the cluster still alive then is terminated). ``workers=1`` runs the tasks in this
  process instead (no start-up cost, same checkpoint, progress and errors), and so does a
  call with a single task left to run.
- ``address="host:port"`` (or ``tcp://host:port``, ``tls://host:port``): an existing Dask
  scheduler (``dask scheduler`` and ``dask worker`` on the machines; every worker needs this
  project installed at the same version, see docs/engine.md). Its workers run the tasks;
  ``workers`` must then be None.

Why Dask and not Ray: docs/engine.md (measured: start-up, throughput, per-task overhead,
idle memory, install footprint).

A checkpoint (`engine_checkpoint.Checkpoint`) keeps every finished result on disk as it
finishes; a call with the same checkpoint and the same arguments runs only the unfinished
tasks (resume) and returns identical results. A task that raises stops the run: the pending
tasks are cancelled and `EngineError` names the argument and the original error; the results
finished so far stay in the checkpoint.

Task functions and arguments must be picklable (functions by module and name, so defined at
module level); results should be small (they travel back to this process).
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import reprlib
import uuid
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Sequence

import psutil
from tqdm import tqdm

from services.studies.engine_checkpoint import Checkpoint
from services.studies.engine_errors import EngineError, EngineUsageError

__all__ = ["EngineError", "EngineUsageError", "available_cores", "normalise_address", "open_cluster", "run_tasks"]

log = logging.getLogger(__name__)

#: ``host:port``, optionally with a scheme Dask speaks (tcp, tls).
_ADDRESS = re.compile(r"^(?:(?P<scheme>tcp|tls)://)?(?P<host>\[[0-9a-fA-F:.]+\]|[A-Za-z0-9_.-]+):(?P<port>\d{1,5})$")
CONNECT_TIMEOUT_S = 10.0
CLOSE_TIMEOUT_S = 10.0


def normalise_address(address: str) -> str:
    """A scheduler address as Dask wants it (``tcp://host:port``); `EngineUsageError` for a
    malformed one."""
    m = _ADDRESS.match(address.strip())
    if not m or not 1 <= int(m["port"]) <= 65535:
        raise EngineUsageError(f"--address {address!r} is not HOST:PORT (e.g. 10.0.0.5:8786 or "
                               "tcp://10.0.0.5:8786, the address `dask scheduler` prints)")
    return f"{m['scheme'] or 'tcp'}://{m['host']}:{int(m['port'])}"


def run_tasks(task_function: Callable[[Any], Any], task_arguments: Iterable[Any], *, address: str | None = None,
              workers: int | None = None, description: str = "tasks", checkpoint_path: Path | None = None,
              show_progress: bool = True, unit: str = "task", weights: Sequence[float] | None = None,
              client: Any = None) -> list:
    """Run task_function(argument) for every argument on the engine; results in argument order.

    address None: a local cluster started for the call (`workers` processes, default every
    core; 1, or a single task to run, runs in this process), torn down after; address
    "host:port" (or "tcp://host:port"): an existing Dask cluster. checkpoint_path: every
    finished task's result is appended (durably, flushed) as it finishes; a call with the same
    checkpoint_path and the same arguments skips the finished ones (resume), and refuses with
    an EngineUsageError if the arguments differ from the checkpoint's. A tqdm progress bar
    with rate and ETA on stderr when show_progress, counting `weights` (e.g. episodes per
    task, in `unit`) or tasks. client: a client of `open_cluster` to run on (address and workers
    are then ignored), for a caller that runs many short calls on one cluster."""
    arguments = list(task_arguments)
    if client is not None:
        address, workers = None, 1
    scheduler, workers = _where(address, workers)
    sizes = [1] * len(arguments) if weights is None else list(weights)
    if len(sizes) != len(arguments):
        raise EngineUsageError(f"{len(sizes)} weights for {len(arguments)} tasks")
    checkpoint = Checkpoint.open(checkpoint_path, task_function, arguments) if checkpoint_path is not None else None
    results: dict[int, Any] = dict(checkpoint.done) if checkpoint else {}
    pending = [i for i in range(len(arguments)) if i not in results]
    total, initial = sum(sizes), sum(sizes[i] for i in results)
    bar = tqdm(total=total, initial=initial, unit=unit, desc=description, disable=not show_progress,
               dynamic_ncols=True, smoothing=0.1)

    def finished(index: int, result: Any) -> None:
        if checkpoint is not None:
            checkpoint.append(index, result)
        results[index] = result
        bar.update(sizes[index])

    try:
        if pending and client is not None:
            _run_on(client, task_function, arguments, pending, finished, description)
        elif pending and scheduler is None and (workers == 1 or len(pending) == 1):
            _run_here(task_function, arguments, pending, finished)
        elif pending:
            with _client(scheduler, min(workers, len(pending))) as client:
                _run_on(client, task_function, arguments, pending, finished, description)
    finally:
        bar.close()
        if checkpoint is not None:
            checkpoint.close()
    return [results[i] for i in range(len(arguments))]


def _where(address: str | None, workers: int | None) -> tuple[str | None, int]:
    """The scheduler (None: a local cluster) and the local cluster's size; `EngineUsageError`
    for a malformed address, workers with an address, or workers < 1."""
    scheduler = normalise_address(address) if address is not None else None
    if scheduler is not None and workers is not None:
        raise EngineUsageError("--workers sizes the local cluster; with --address the cluster's own workers run "
                               "the tasks (drop --workers)")
    workers = available_cores() if workers is None else int(workers)
    if workers < 1:
        raise EngineUsageError(f"workers must be >= 1, got {workers}")
    return scheduler, workers


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity; `os.cpu_count` where unknown)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _task_failed(index: int, argument: Any, error: BaseException) -> EngineError:
    short = reprlib.Repr()
    short.maxstring = short.maxother = 120
    text = short.repr(argument)
    return EngineError(f"task {index} failed on argument {text}: {type(error).__name__}: {error}", task_error=error)


def _run_here(function: Callable, arguments: list, pending: list[int], finished: Callable[[int, Any], None]) -> None:
    """The tasks one after the other in this process."""
    for i in pending:
        try:
            result = function(arguments[i])
        except Exception as exc:  # noqa: BLE001 - any task error becomes the engine's, naming its argument
            raise _task_failed(i, arguments[i], exc) from exc
        finished(i, result)


def _run_on(client, function: Callable, arguments: list, pending: list[int],
            finished: Callable[[int, Any], None], description: str) -> None:
    """The tasks on a Dask client, results taken as they finish; all cancelled on any error."""
    from distributed import as_completed

    token = uuid.uuid4().hex[:12]
    futures = {client.submit(function, arguments[i], key=f"{description}-{token}-{i}", pure=False): i
               for i in pending}
    try:
        for future in as_completed(futures, loop=client.loop):
            i = futures[future]
            if future.status == "error":
                error = future.exception()
                raise _task_failed(i, arguments[i], error) from error
            if future.status == "cancelled":
                raise EngineError(f"task {i} was cancelled by the cluster (a worker died or the scheduler "
                                  "restarted?); the finished results are kept in the checkpoint")
            finished(i, future.result())
            future.release()
    finally:
        client.cancel([f for f in futures if not f.done()])


@contextlib.contextmanager
def open_cluster(address: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A Dask client for many `run_tasks(..., client=...)` calls: of the cluster at `address`,
    or of a local cluster of `workers` processes (default every core) torn down on exit; None
    (run in this process) for a local cluster of one worker."""
    scheduler, workers = _where(address, workers)
    if scheduler is None and workers == 1:
        yield None
        return
    with _client(scheduler, workers) as client:
        yield client


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int) -> Iterator[Any]:
    """A Dask client: of the cluster at `scheduler`, or of a local cluster of `workers`
    processes that is torn down on exit (any of its processes left is terminated)."""
    from distributed import Client, LocalCluster

    from services.studies.engine_worker import KeepFreedMemory

    # The scheduler of a local cluster runs in this process: its INFO lines (start, workers,
    # connections, and a traceback when a comm closes at teardown) are not the user's business
    # when all is well. `silence_logs` covers the worker processes only.
    logging.getLogger("distributed").setLevel(logging.WARNING)
    if scheduler is not None:
        try:
            remote = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s", set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise EngineError(f"cannot reach the Dask scheduler at {scheduler} within {CONNECT_TIMEOUT_S:.0f} s "
                              f"({type(exc).__name__}); check that `dask scheduler` runs there and that this "
                              "machine may connect to it") from exc
        try:
            remote.register_plugin(KeepFreedMemory())
            yield remote
        finally:
            remote.close(timeout=CLOSE_TIMEOUT_S)
        return
    before = {p.pid for p in psutil.Process().children(recursive=True)}
    cluster: Any = None
    client: Any = None
    try:
        try:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   scheduler_port=0, dashboard_address="127.0.0.1:0", worker_dashboard_address=None,
                                   silence_logs=logging.ERROR)
            client = Client(cluster, set_as_default=False)
            client.register_plugin(KeepFreedMemory())
        except (OSError, TimeoutError) as exc:
            raise EngineError(f"the local Dask cluster did not start ({type(exc).__name__}: {exc})") from exc
        yield client
    finally:
        _close_local(client, cluster, before)


def _close_local(client, cluster, before: set[int]) -> None:
    """Close the client and the local cluster; terminate any of its processes still alive,
    the tasks' own children too (listed before the workers go: a child in a session of its
    own, an evaluation episode's launcher, is re-parented to init once its worker is gone)."""
    spawned = _spawned(before)
    with contextlib.suppress(Exception):
        if client is not None:
            client.close(timeout=CLOSE_TIMEOUT_S)
    with contextlib.suppress(Exception):
        if cluster is not None:
            cluster.close(timeout=CLOSE_TIMEOUT_S)
    left = [p for p in {*spawned, *_spawned(before)} if p.is_running()]  # is_running: not a reused pid
    for p in left:
        with contextlib.suppress(psutil.Error):
            p.terminate()
    _gone, alive = psutil.wait_procs(left, timeout=3.0)
    for p in alive:
        with contextlib.suppress(psutil.Error):
            p.kill()
    if left:
        log.warning("terminated %d process(es) the local cluster left behind", len(left))


def _spawned(before: set[int]) -> list[psutil.Process]:
    """This process's descendants not in `before` (pids), Python's resource tracker aside."""
    return [p for p in psutil.Process().children(recursive=True) if p.pid not in before and not _is_helper(p)]


def _is_helper(process: psutil.Process) -> bool:
    """Python's multiprocessing resource tracker: one per parent process, started with the
    first worker and ending with this process; not the cluster's."""
    try:
        return "multiprocessing.resource_tracker" in " ".join(process.cmdline())
    except psutil.Error:
        return True
