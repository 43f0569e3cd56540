"""Service processes run Zenoh on one worker thread, the router keeps Zenoh's own layout,
and a user's `ZENOH_RUNTIME` wins (`services.runtime.zenoh_threads`). The layout is read once
per process, so each case looks at a fresh process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from services.launcher.processes import RouterProcess
from services.runtime.zenoh_config import zenoh_config_dict
from services.runtime import open_session
from services.runtime.testing import BusRouter, loopback_profile, wait_until
from services.runtime.zenoh_threads import (
    KEEP_DEFAULT_PID_ENV,
    ONE_WORKER_THREAD,
    ZENOH_RUNTIME_ENV,
    use_one_zenoh_thread,
)

_CLIENT = """
import json, os, sys, time
from pathlib import Path
from services.runtime import open_session, run_main
from services.runtime.testing import loopback_profile

def threads():
    return sorted((t / "comm").read_text().strip() for t in Path("/proc/self/task").iterdir())

def run(args):
    session = open_session(loopback_profile(int(sys.argv[1])), "client")
    deadline = time.monotonic() + 5.0  # Zenoh starts a link's threads as the link comes up
    names = threads()
    wanted = {"rx-0", "rx-1", "tx-0"} if os.environ.get("ZENOH_RUNTIME", "").startswith("(rx") else {"app-0"}
    while not wanted <= set(names):
        if time.monotonic() > deadline:
            break
        time.sleep(0.05)
        names = threads()
    session.close()
    print(json.dumps({"threads": names, "env": os.environ.get("ZENOH_RUNTIME")}))
    return 0

raise SystemExit(run_main(run, None, "probe"))
"""


def _env(value: str | None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != ZENOH_RUNTIME_ENV}
    if value is not None:
        env[ZENOH_RUNTIME_ENV] = value
    return env


def _thread_names(task_dir: Path) -> list[str]:
    """The names of a process's threads; a thread that ends while being read is skipped."""
    names = []
    for task in task_dir.iterdir():
        try:
            names.append((task / "comm").read_text().strip())
        except OSError:
            continue
    return names


def _zenoh_workers(threads: list[str]) -> list[str]:
    return [t for t in threads if t.split("-")[0] in {"app", "acc", "tx", "rx", "net"}]


def _service_probe(env_value: str | None) -> dict:
    profile = loopback_profile()
    port = int(profile.endpoint.rsplit(":", 1)[1])
    with BusRouter(profile):
        out = subprocess.run([sys.executable, "-c", _CLIENT, str(port)], env=_env(env_value),
                             capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_service_process_runs_zenoh_on_one_worker_thread():
    got = _service_probe(None)
    assert got["env"] == ONE_WORKER_THREAD
    workers = _zenoh_workers(got["threads"])
    assert "app-0" in workers, workers
    # No receive, transmit, accept or network runtime of its own: app's threads do it all
    # (app-1.. are Tokio's blocking-task threads, idle while the session runs).
    assert all(w.startswith("app-") for w in workers), workers


def test_a_users_zenoh_runtime_setting_is_kept():
    got = _service_probe("(rx: (worker_threads: 2))")
    assert got["env"] == "(rx: (worker_threads: 2))"
    workers = _zenoh_workers(got["threads"])
    assert "rx-0" in workers and "tx-0" in workers, workers


def test_the_router_process_keeps_two_receive_workers(monkeypatch):
    """The launcher's environment carries the services' layout; its router drops it."""
    monkeypatch.setenv(ZENOH_RUNTIME_ENV, ONE_WORKER_THREAD)
    profile = loopback_profile()
    router = RouterProcess(json.dumps(zenoh_config_dict(profile, "router")))
    router.start()
    try:
        session = open_session(profile, "client")  # Zenoh starts its link threads with a link
        try:
            task_dir = Path(f"/proc/{router.proc.pid}/task")
            threads: list[str] = []

            def link_threads_up() -> bool:
                # Tokio names each worker as it starts, in no fixed order: wait for all three.
                threads[:] = sorted(_thread_names(task_dir))
                return {"rx-0", "rx-1", "tx-0"} <= set(threads)

            wait_until(link_threads_up, 5.0)
        finally:
            session.close()
    finally:
        router.stop(5.0)
    workers = _zenoh_workers(threads)
    assert {"rx-0", "rx-1", "tx-0"} <= set(workers), workers


def test_a_process_that_hosts_a_router_refuses_the_one_worker_layout(monkeypatch):
    monkeypatch.setenv(ZENOH_RUNTIME_ENV, ONE_WORKER_THREAD)
    with pytest.raises(RuntimeError, match="keeps Zenoh's default threads"), BusRouter(loopback_profile()):
        pass


def test_the_process_named_to_keep_the_default_layout_is_left_alone(monkeypatch):
    """The test runner hosts in-process routers: a CLI run in it must not pick the layout."""
    monkeypatch.setenv(ZENOH_RUNTIME_ENV, "")  # recorded, so that teardown restores it
    monkeypatch.delenv(ZENOH_RUNTIME_ENV)
    monkeypatch.setenv(KEEP_DEFAULT_PID_ENV, str(os.getpid()))
    assert use_one_zenoh_thread() is None and ZENOH_RUNTIME_ENV not in os.environ
    monkeypatch.setenv(KEEP_DEFAULT_PID_ENV, str(os.getpid() + 1))  # another process's pid
    assert use_one_zenoh_thread() == ONE_WORKER_THREAD
