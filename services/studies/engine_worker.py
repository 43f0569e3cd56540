"""What the engine sets up in every Dask worker (`KeepFreedMemory`, registered by
`services.studies.engine` on each client, so workers that join later get it too).

Dask's nanny starts each worker with ``MALLOC_TRIM_THRESHOLD_=65536``, so that glibc gives
freed memory back to the system soon. The contact plant makes many small numpy temporaries per
step; with that threshold its chunks took 1.7× the CPU they take in a plain process (0.77 s
against 1.37 s of thread CPU per 500-episode chunk, measured here; docs/engine.md). Each
worker gets the stack's own allocator thresholds instead (`services.runtime.allocator`).
"""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin

from services.runtime.allocator import keep_freed_memory

__all__ = ["KeepFreedMemory"]


class KeepFreedMemory(WorkerPlugin):
    """Applies `keep_freed_memory` in the worker's process when the worker starts."""

    name = "handover-keep-freed-memory"

    def setup(self, worker) -> None:  # noqa: D401 - Dask's hook
        keep_freed_memory()
