"""Shared fixtures: a loopback bus with an in-process router, client nodes, process cleanup."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from services.runtime import ServiceNode
from services.runtime.testing import BusRouter, loopback_profile
from services.runtime.zenoh_threads import KEEP_DEFAULT_PID_ENV
from tests import checkout_guard

# This process hosts in-process routers (`bus`) and calls CLIs in-process: it keeps Zenoh's
# default threads whatever a CLI's `run_main` does (services/runtime/zenoh_threads.py).
os.environ[KEEP_DEFAULT_PID_ENV] = str(os.getpid())


@pytest.fixture
def bus():
    """A fresh loopback bus on a free port: yields (profile, router session)."""
    profile = loopback_profile()
    with BusRouter(profile) as router:
        yield profile, router


@pytest.fixture
def make_node(bus):
    """Factory for test-side ServiceNodes on the bus; all closed at teardown."""
    profile, _ = bus
    nodes: list[ServiceNode] = []

    def make(name: str = "tester") -> ServiceNode:
        node = ServiceNode(name, profile, install_signal_handlers=False)
        node.open()
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.close()


def pytest_configure(config):
    os.environ.setdefault("PYTHONUNBUFFERED", "1")


_CHECKOUT = Path(__file__).resolve().parent.parent


def pytest_sessionstart(session):
    """Snapshot the checkout when the session starts on a clean one (as in CI)."""
    before = checkout_guard.snapshot(_CHECKOUT)
    session.config._checkout_before = before if before is not None and checkout_guard.is_clean(before) else None


def pytest_sessionfinish(session, exitstatus):
    """Fail the run when the suite left the checkout changed (tests write only to temporary
    directories). Checked only when the session started on a clean checkout."""
    before = getattr(session.config, "_checkout_before", None)
    if before is None or getattr(session.config, "workerinput", None) is not None:
        return
    after = checkout_guard.snapshot(_CHECKOUT)
    changed = checkout_guard.changes(before, after or {})
    if changed:
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        text = "the test suite changed the checkout (tests must write only to temporary directories):\n  "
        text += "\n  ".join(changed[:50])
        if reporter is not None:
            reporter.write_line(text, red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
