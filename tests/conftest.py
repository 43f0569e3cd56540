"""Shared fixtures: a loopback bus with an in-process router, client nodes, process cleanup."""

from __future__ import annotations

import os

import pytest

from services.runtime import ServiceNode
from services.runtime.testing import BusRouter, loopback_profile
from services.runtime.zenoh_threads import ZENOH_RUNTIME_ENV


@pytest.fixture(autouse=True)
def _zenoh_runtime_env_unchanged():
    """A CLI's `run_main` called in this process sets the services' one-worker Zenoh layout
    (`services.runtime.zenoh_threads`); put the variable back so that it never decides the
    threads of the in-process router of a later test."""
    before = os.environ.get(ZENOH_RUNTIME_ENV)
    yield
    if before is None:
        os.environ.pop(ZENOH_RUNTIME_ENV, None)
    else:
        os.environ[ZENOH_RUNTIME_ENV] = before


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
