"""The candidates of the engine choice (docs/engine.md), behind one small interface:
``start(workers)``, ``run(function, arguments) -> results``, ``processes()``, ``stop()``.

- `PoolCandidate`: the home-made `multiprocessing` pool the studies used before the engine
  (fork, `imap_unordered`), the baseline;
- `DaskCandidate`: Dask distributed `LocalCluster` as `services.studies.engine` starts it;
- `RayCandidate`: Ray's local cluster (`ray.init`), dashboard and usage statistics off, on
  127.0.0.1. Ray is not a dependency of the stack: install it in a throwaway venv to compare
  (docs/engine.md says how); without it the bench reports Dask and the pool only.
"""

from __future__ import annotations

import importlib.metadata as md
import importlib.util
import multiprocessing as mp
import os
import re

import psutil

__all__ = ["CANDIDATES", "install_footprint", "noop"]


def noop(x: int) -> int:
    """The task of the per-task overhead measurement."""
    return x


def _tree() -> list[psutil.Process]:
    return [psutil.Process(), *psutil.Process().children(recursive=True)]


class PoolCandidate:
    name = "multiprocessing pool (before)"
    available = True

    def start(self, workers: int) -> None:
        self.pool = mp.get_context("fork").Pool(processes=workers)
        self.pool.map(noop, range(workers))

    def run(self, function, arguments: list) -> list:
        return self.pool.map(function, arguments, chunksize=1)

    def stop(self) -> None:
        self.pool.close()
        self.pool.join()


class DaskCandidate:
    name = f"Dask distributed {md.version('distributed')}"
    available = True

    def start(self, workers: int) -> None:
        from distributed import Client, LocalCluster

        self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                    dashboard_address="127.0.0.1:0", worker_dashboard_address=None, silence_logs=40)
        self.client = Client(self.cluster, set_as_default=False)
        from services.studies.engine_worker import KeepFreedMemory

        self.client.register_plugin(KeepFreedMemory())  # as services.studies.engine does
        self.client.gather(self.client.map(noop, range(workers), pure=False))

    def run(self, function, arguments: list) -> list:
        return self.client.gather(self.client.map(function, arguments, pure=False))

    def stop(self) -> None:
        self.client.close()
        self.cluster.close()


class RayCandidate:
    name = "Ray " + (md.version("ray") if importlib.util.find_spec("ray") else "(not installed)")
    available = importlib.util.find_spec("ray") is not None

    def start(self, workers: int) -> None:
        os.environ["RAY_USAGE_STATS_ENABLED"] = "0"  # no usage reports sent out
        import ray

        ray.init(num_cpus=workers, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False,
                 configure_logging=False)
        self.remote = {}
        self.run(noop, list(range(workers)))

    def run(self, function, arguments: list) -> list:
        import ray

        remote = self.remote.setdefault(function, ray.remote(num_cpus=1)(function))
        return ray.get([remote.remote(a) for a in arguments])

    def stop(self) -> None:
        import ray

        ray.shutdown()


CANDIDATES = (PoolCandidate, DaskCandidate, RayCandidate)


def tree_memory_mb() -> float:
    """Proportional set size (PSS: shared pages split between their users) of this process and
    all its descendants, MB."""
    total = 0
    for p in _tree():
        try:
            total += p.memory_full_info().pss
        except psutil.Error:
            pass
    return total / 1e6


def listening_ips() -> list[str]:
    """The IP addresses that this process and its descendants listen on (TCP)."""
    ips = set()
    for p in _tree():
        try:
            ips |= {c.laddr.ip for c in p.net_connections(kind="tcp") if c.status == psutil.CONN_LISTEN}
        except psutil.Error:
            pass
    return sorted(ips)


def _requires(name: str) -> set[str]:
    try:
        reqs = md.requires(name) or []
    except md.PackageNotFoundError:
        return set()
    out = set()
    for r in reqs:
        if ";" in r and "extra" in r.split(";", 1)[1]:
            continue
        out.add(re.split(r"[\s<>=!~;\[(]", r, maxsplit=1)[0].lower().replace("_", "-"))
    return out


def _closure(roots: set[str], skip: set[str] = frozenset()) -> set[str]:  # type: ignore[assignment]
    seen: set[str] = set()
    todo = [r.lower().replace("_", "-") for r in roots]
    while todo:
        n = todo.pop()
        if n in seen or n in skip:
            continue
        seen.add(n)
        todo.extend(_requires(n))
    return seen


def install_footprint(roots: set[str], others: set[str]) -> tuple[int, float]:
    """(packages, MB on disk) that `roots` bring beyond what the stack's other dependencies
    (`others`) already install."""
    base = _closure(others)
    extra = _closure(roots) - base
    size = 0
    for n in extra:
        try:
            size += sum((f.size or 0) for f in (md.files(n) or []))
        except md.PackageNotFoundError:
            pass
    return len(extra), size / 1e6
