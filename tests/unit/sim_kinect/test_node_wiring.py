"""The Kinect's 30 Hz loop reads the 100 Hz inputs with latest(): they must not wake it."""

from __future__ import annotations

from typing import Any

from bus_schema import topics
from services.sim_kinect import node as kinect_node
from services.sim_kinect.config import KinectConfig


class _FakeNode:
    """Records subscriptions; stops at the first wait (the disabled service's idle loop)."""

    instances: list[_FakeNode] = []

    def __init__(self, name: str, profile: Any) -> None:
        self.subscriptions: dict[str, bool] = {}
        self.should_stop = False
        _FakeNode.instances.append(self)

    def __enter__(self) -> _FakeNode:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def subscribe(self, topic: Any, queue_size: int = 256, wake: bool = True) -> None:
        self.subscriptions[topic.suffix] = wake

    def publisher(self, topic: Any) -> None:
        return None

    def wait(self, timeout_s: float) -> bool:
        self.should_stop = True
        return False


def test_the_100_hz_inputs_do_not_wake_the_kinect(monkeypatch):
    monkeypatch.setattr(kinect_node, "ServiceNode", _FakeNode)
    assert kinect_node.run_kinect(profile=None, config=KinectConfig(enabled=False)) == 0
    subs = _FakeNode.instances[-1].subscriptions
    assert subs == {topics.JOINT_STATE.suffix: False, topics.SIM_TRUTH.suffix: False}
