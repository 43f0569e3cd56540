"""ServiceNode: alive means listening (the token follows the subscriptions); only waking
subscriptions wake `wait()`. Real Zenoh sessions on a loopback router in this process."""

from __future__ import annotations

import time

import pytest

from bus_schema import topics
from services.runtime.liveliness import alive_services
from services.runtime.node import ServiceNode, open_session
from services.runtime.testing import BusRouter, loopback_profile, wait_until


@pytest.fixture()
def bus():
    profile = loopback_profile()
    with BusRouter(profile):
        peer = open_session(profile, "client", timeout_s=5.0)
        try:
            yield profile, peer
        finally:
            peer.close()


def _put_stop(profile, peer, seq: int) -> None:
    from bus_schema import encode_for

    msg = topics.MOTION_STOP.type(seq=seq, stamp_ns=time.time_ns(), source="test", reason="test")
    peer.put(topics.MOTION_STOP.key(profile.prefix), encode_for(topics.MOTION_STOP, msg))


def test_token_only_after_ready_and_a_put_at_first_sight_is_heard(bus):
    profile, peer = bus
    node = ServiceNode("probe", profile, install_signal_handlers=False)
    with node:
        assert "probe" not in alive_services(peer, profile.prefix, 0.3)
        assert not node.is_ready
        stops = node.subscribe(topics.MOTION_STOP)
        node.ready()
        assert wait_until(lambda: "probe" in alive_services(peer, profile.prefix, 0.3), 5.0)
        _put_stop(profile, peer, 0)  # published the moment the token is seen
        assert wait_until(lambda: stops.stats.accepted == 1, 5.0)


def test_first_wait_declares_the_token(bus):
    profile, peer = bus
    with ServiceNode("probe2", profile, install_signal_handlers=False) as node:
        node.subscribe(topics.MOTION_STOP)
        node.wait(0.0)
        assert node.is_ready
        assert wait_until(lambda: "probe2" in alive_services(peer, profile.prefix, 0.3), 5.0)


def test_only_waking_subscriptions_wake_wait(bus):
    profile, peer = bus
    with ServiceNode("probe3", profile, install_signal_handlers=False) as node:
        quiet = node.subscribe(topics.MOTION_STOP, wake=False)
        node.ready()
        assert wait_until(lambda: "probe3" in alive_services(peer, profile.prefix, 0.3), 5.0)  # listening
        node.wait(0.0)  # clear
        _put_stop(profile, peer, 0)
        assert wait_until(lambda: quiet.stats.accepted == 1, 5.0)
        assert node.wait(0.05) is False, "a wake=False subscription woke the loop"
        assert quiet.latest() is not None
    with ServiceNode("probe4", profile, install_signal_handlers=False) as node:
        loud = node.subscribe(topics.MOTION_STOP)
        node.ready()
        assert wait_until(lambda: "probe4" in alive_services(peer, profile.prefix, 0.3), 5.0)
        node.wait(0.0)
        _put_stop(profile, peer, 1)
        assert wait_until(lambda: loud.stats.accepted == 1, 5.0)
        assert node.wait(0.05) is True
