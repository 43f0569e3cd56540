"""Zenoh's worker threads: one in each service process, Zenoh's own layout in the router.

By default a Zenoh session runs five Tokio runtimes (``app``, ``acc``, ``tx``, ``net`` and a
two-worker ``rx``). A message then crosses several threads in each process it touches, and
the two ``rx`` workers wake each other for every sample: on the 2-core machine the idle
stack made about 13 500 context switches a second, most of them Zenoh's, at 30–70 µs of CPU
each. Handing every runtime of a *service* over to ``app`` (Zenoh's own `ZENOH_RUNTIME`
setting) leaves one worker per service process: measured in one sitting
(`docs/performance.md`), it takes about 0.05 core off the idle stack and shortens a bus hop.

The *router* keeps Zenoh's layout. It routes inside its receive task, and a message sent
with congestion control BLOCK to a subscriber that does not keep up makes that task wait:
with a single worker the whole bus waits with it. Measured: 20 000 joint commands flooded at
the bridge through a one-worker router stopped the bridge's joint states reaching anyone for
20 s; with Zenoh's two receive workers the largest gap stays under 0.5 s
(`tests/faults/test_fuzz_services.py`).

`ZENOH_RUNTIME` is read once, when a process first uses a Zenoh runtime: `run_main` (every
service's and the launcher's entry point) calls `use_one_zenoh_thread` first, and the
router process calls `keep_zenoh_default_threads` before it imports Zenoh. A user who sets
`ZENOH_RUNTIME` to anything else keeps their value everywhere.
"""

from __future__ import annotations

import os

#: Zenoh's environment variable for its runtimes (RON syntax, `zenoh-runtime` crate).
ZENOH_RUNTIME_ENV = "ZENOH_RUNTIME"

#: Every runtime handed over to ``app``, which keeps its default single worker thread.
ONE_WORKER_THREAD = "(rx: (handover: app), acc: (handover: app), tx: (handover: app), net: (handover: app))"

#: The process whose pid this names keeps Zenoh's default layout even through `run_main`: the
#: test runner, which hosts in-process routers and calls CLIs in-process (its children, the
#: services under test, have other pids and take the one-worker layout).
KEEP_DEFAULT_PID_ENV = "HANDOVER_ZENOH_DEFAULT_THREADS_PID"


def use_one_zenoh_thread() -> str | None:
    """Set `ZENOH_RUNTIME` to `ONE_WORKER_THREAD` unless the user set it (or this process is
    the one `KEEP_DEFAULT_PID_ENV` names); returns the value in force for this process."""
    if os.environ.get(KEEP_DEFAULT_PID_ENV) == str(os.getpid()):
        return os.environ.get(ZENOH_RUNTIME_ENV)
    return os.environ.setdefault(ZENOH_RUNTIME_ENV, ONE_WORKER_THREAD)


def keep_zenoh_default_threads() -> str | None:
    """In a process that hosts a router: drop `ONE_WORKER_THREAD` inherited from the
    launcher (a user's own value stays). Returns the value in force, None for Zenoh's default."""
    if os.environ.get(ZENOH_RUNTIME_ENV) == ONE_WORKER_THREAD:
        del os.environ[ZENOH_RUNTIME_ENV]
    return os.environ.get(ZENOH_RUNTIME_ENV)
