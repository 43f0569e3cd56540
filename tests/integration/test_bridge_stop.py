"""The bridge acts on `motion/stop` at once: the stop's arrival wakes its loop, which brakes
and publishes the joint state without waiting for the next 10 ms tick.

Timing is not asserted here (tests/bench/test_bench_bridge_stop.py measures it); these tests
assert what the bridge does: the first joint state after the stop shows the brake engaged,
and the bridge ran extra ticks for the stops (none with ``--stop-on-tick``).
"""

from __future__ import annotations

import random
import re
import time
from dataclasses import dataclass

import numpy as np
import pytest

from bus_schema import topics
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration
J = list(RIGHT_ARM_JOINTS)
HOME = np.array(RIGHT_ARM_HOME_RAD)
PERIOD_S = 0.01


@dataclass(frozen=True)
class StopTrial:
    """One stop.

    Attributes:
        latency_s: from publishing the stop to receiving the first joint state with the brake
            engaged (s, the test's monotonic clock).
        not_braking_after: joint states published after the stop was sent (bridge's stamp)
            that still showed no brake: at most the one whose tick ran while the stop was in
            transit.
        braking_speed_rad_s: largest joint speed in the first braking state, rad/s.
        speed_before_rad_s: largest joint speed in the last state before the stop, rad/s.
    """

    latency_s: float
    not_braking_after: int
    braking_speed_rad_s: float
    speed_before_rad_s: float


class StopRig:
    """A test node that moves the bridge's arm and stops it (publishers and subscriptions)."""

    def __init__(self, node) -> None:
        self.states = node.subscribe(topics.JOINT_STATE, queue_size=5000)
        self.commands = node.publisher(topics.JOINT_COMMAND)
        self.goals = node.publisher(topics.MOTION_GOAL)
        self.stops = node.publisher(topics.MOTION_STOP)
        self.rng = random.Random(7)
        assert wait_until(lambda: self.states.latest() is not None, 10.0)

    def trial(self, index: int) -> StopTrial:
        goal_id = f"bench-{index}"
        # A goal sent after the previous stop lets its commands move the arm again.
        self.goals.put(goal_id=goal_id, kind="joint", joint_target_rad=list(HOME))
        time.sleep(0.005)
        speed_rad_s = 0.8 if index % 2 == 0 else -0.8
        start = np.array(self.states.latest().msg.position_rad)
        for k in range(20):  # 0.2 s of a steady joint-0 motion with feed-forward
            target = start.copy()
            target[0] += speed_rad_s * PERIOD_S * (k + 5)
            ff = np.zeros(7)
            ff[0] = speed_rad_s
            self.commands.put(names=J, position_rad=list(target), velocity_rad_s=list(ff), goal_id=goal_id)
            time.sleep(PERIOD_S)
        assert wait_until(lambda: not self.states.latest().msg.holding, 2.0), "the arm never followed"
        time.sleep(self.rng.uniform(0.0, PERIOD_S))  # stops land at random phases of the bridge's tick
        self.states.drain()
        before = self.states.latest().msg
        sent_ns = time.time_ns()
        t0 = time.monotonic()
        self.stops.put(reason="release", protective=False)
        assert wait_until(lambda: any(rx.msg.holding for rx in self._peek()), 2.0), "no braking joint state"
        after = self._peek()
        k = next(i for i, rx in enumerate(after) if rx.msg.holding)
        braking = after[k]
        # States published after the stop was sent (the bridge's wall-clock stamp, same
        # machine) that still show no brake.
        late = sum(1 for rx in after[:k] if rx.msg.stamp_ns > sent_ns)
        time.sleep(0.05)  # let the brake bring the arm to rest
        return StopTrial(latency_s=braking.rx_monotonic - t0, not_braking_after=late,
                         braking_speed_rad_s=float(np.abs(braking.msg.velocity_rad_s).max()),
                         speed_before_rad_s=float(np.abs(before.velocity_rad_s).max()))

    def _peek(self) -> list:
        got = self.states.drain()
        self._seen = getattr(self, "_seen", [])
        self._seen.extend(got)
        return self._seen

    def reset(self) -> None:
        self._seen = []


def run_trials(node, n: int) -> list[StopTrial]:
    rig = StopRig(node)
    out = []
    for i in range(n):
        rig.reset()
        out.append(rig.trial(i))
    return out


def stop_ticks_from_log(text: str) -> int:
    """`stop_ticks` of the bridge's "bridge stopped" log line."""
    found = re.findall(r"stop_ticks=(\d+)", text)
    assert found, "no 'bridge stopped' line with stop_ticks in the bridge's log"
    return int(found[-1])


@pytest.mark.parametrize("stop_on_tick", [False, True])
def test_first_joint_state_after_a_stop_shows_the_brake(bus, make_node, stop_on_tick):
    profile, router = bus
    args = ["--no-contact"] + (["--stop-on-tick"] if stop_on_tick else [])
    bridge = ServiceProcess("services.bridge", profile, args)
    with bridge:
        wait_alive(router, profile, {"bridge"}, timeout_s=30)
        trials = run_trials(make_node(), 8)
    assert bridge.proc.returncode == 0
    for t in trials:
        assert t.speed_before_rad_s > 0.3  # the arm was moving
        # The next state after the stop arrived shows the brake (one state may leave between the
        # send and the arrival; two when this machine delays the stop by a tick) …
        assert t.not_braking_after <= 2, trials
        assert t.braking_speed_rad_s < t.speed_before_rad_s  # … and slowing down
    assert sum(t.not_braking_after <= 1 for t in trials) >= 6, trials  # … most within one tick
    stop_ticks = stop_ticks_from_log(bridge.log_text())
    if stop_on_tick:
        assert stop_ticks == 0
    else:
        assert stop_ticks >= 1  # most stops arrive while the loop waits: it wakes for them
