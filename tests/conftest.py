"""Shared fixtures: a loopback bus with an in-process router, client nodes, process cleanup."""

from __future__ import annotations

import os

import pytest

from services.runtime import ServiceNode
from services.runtime.testing import BusRouter, loopback_profile
from services.runtime.zenoh_threads import KEEP_DEFAULT_PID_ENV

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
