"""The bridge's own protective stop when the supervisor's liveliness token goes mid-episode
(`services.bridge.supervisor_loss`, and `ArmLoop` braking on it)."""

from __future__ import annotations

import pytest

from bus_schema.messages import PHASES_OUTSIDE_EPISODE
from services.bridge.supervisor_loss import SupervisorLoss
from tests.unit.bridge.test_arm_loop import PERIOD_S, _command, moving_arm


@pytest.mark.parametrize("phase", ["locate", "pick", "plan", "reach", "transfer", "released", "retract", "hold"])
def test_the_token_going_during_an_episode_asks_for_one_stop(phase):
    loss = SupervisorLoss()
    loss.token(True)
    loss.state(phase, 3)
    assert loss.due(loss.take_tokens()) is None  # alive: nothing to do
    loss.token(False)
    assert loss.pending()
    reason = loss.due(loss.take_tokens())
    assert reason == f"supervisor lost: its liveliness token went during {phase} (episode 3)"
    assert not loss.pending() and loss.stops == 1
    loss.token(False)  # the same loss told again (a second DELETE): no second stop
    assert loss.due(loss.take_tokens()) is None and loss.stops == 1


@pytest.mark.parametrize("phase", sorted(PHASES_OUTSIDE_EPISODE))
def test_a_supervisor_that_leaves_between_episodes_asks_for_nothing(phase):
    loss = SupervisorLoss()
    loss.token(True)
    loss.state("transfer", 1)
    loss.state(phase, 1)  # its last state, before its token went
    loss.token(False)
    assert loss.due(loss.take_tokens()) is None and loss.stops == 0


def test_a_token_that_goes_before_any_state_asks_for_nothing():
    loss = SupervisorLoss()
    loss.token(True)
    loss.token(False)
    assert loss.due(loss.take_tokens()) is None and loss.stops == 0


def test_a_new_supervisor_episode_after_a_loss_can_be_stopped_again():
    loss = SupervisorLoss()
    loss.state("reach", 1)
    loss.token(False)
    assert loss.due(loss.take_tokens()) is not None
    loss.token(True)
    loss.state("reach", 1)
    loss.token(False)
    assert loss.due(loss.take_tokens()) is not None and loss.stops == 2


def test_the_arm_brakes_protectively_at_the_first_tick_after_the_loss_and_says_so_once():
    backend, inbox, arm, target, t = moving_arm("reach")
    moving = backend.read().velocity_rad_s[0]
    arm.supervisor_loss.token(False)
    t += PERIOD_S
    _command(inbox, t, target, seq=50)  # motion still sends its goal's commands: ignored
    state = arm.tick(t, inbox)
    assert arm.brake.active and arm.brake.protective and state["holding"]
    assert arm.brake.ignored_commands == 1
    assert 0.0 <= state["velocity_rad_s"][0] < moving
    reason = arm.take_own_stop()
    assert reason is not None and "supervisor lost" in reason and "during reach (episode 1)" in reason
    assert arm.take_own_stop() is None  # sent once
    for k in range(10):  # braked to rest and held; the goal's commands stay ignored
        t += PERIOD_S
        _command(inbox, t, target, seq=60 + k)
        state = arm.tick(t, inbox)
    assert state["velocity_rad_s"][0] == pytest.approx(0.0, abs=1e-9) and arm.take_own_stop() is None


def test_a_last_done_state_drained_in_the_same_tick_as_the_loss_stops_nothing():
    backend, inbox, arm, target, t = moving_arm("reach")
    t += PERIOD_S
    inbox.supervisor.put(t, episode_id=1, phase="done")  # its last state, then its token goes
    arm.supervisor_loss.token(False)
    arm.tick(t, inbox)
    assert not arm.brake.active and arm.take_own_stop() is None


class DrainWithArrivals:
    """A supervisor subscription whose drain lets more arrive meanwhile: the supervisor's last
    state and its token's end, both landing while the loop drains."""

    def __init__(self, inbox_queue, loss: SupervisorLoss, t: float) -> None:
        self.queue, self.loss, self.t = inbox_queue, loss, t
        self.armed = True

    def put(self, rx_s, **fields):
        return self.queue.put(rx_s, **fields)

    def drain(self):
        out = self.queue.drain()
        if self.armed:  # after this drain took the states, the last one and the token's end land
            self.armed = False
            self.queue.put(self.t, episode_id=1, phase="done")
            self.loss.token(False)
        return out


def test_a_last_state_and_the_tokens_end_landing_during_the_drain_stop_nothing():
    """The token changes are taken before the states: a `done` that lands with the token's end
    while the loop drains is seen first at the next tick, and nothing stops."""
    backend, inbox, arm, target, t = moving_arm("reach")
    drain = DrainWithArrivals(inbox.supervisor, arm.supervisor_loss, t)
    object.__setattr__(inbox, "supervisor", drain)
    for _ in range(3):
        t += PERIOD_S
        arm.tick(t, inbox)
    assert not drain.armed and arm.supervisor_loss.phase == "done"
    assert not arm.brake.active and arm.take_own_stop() is None and arm.supervisor_loss.stops == 0
