"""The planner as a real process on a loopback bus: HumanState in, TransferTarget out."""

from __future__ import annotations

import queue
import time

import numpy as np
import pytest

from bus_schema import topics as T
from bus_schema.codec import decode, encode
from bus_schema.messages import HumanState, ObjectEstimate
from handover_model import scene
from services.planner.config import load_config
from services.planner.core import plan_for_receiver, receiver_from_human_state
from services.runtime.testing import BusRouter, ServiceProcess, client_session, loopback_profile, wait_alive
from tests.integration.supervised_windows import outputs_per_window

pytestmark = pytest.mark.integration

def msgspec_fields(msg) -> dict:
    """A message's fields by name."""
    return {f: getattr(msg, f) for f in msg.__struct_fields__}


TORSO = (float(scene.RECEIVER_TORSO_BASE_XY_M[0]), float(scene.RECEIVER_TORSO_BASE_XY_M[1]), 0.3)


def _human(seq: int, torso=TORSO) -> HumanState:
    return HumanState(seq=seq, stamp_ns=time.time_ns(), source="tracker", tracked=True,
                      torso_position_m=torso, height_m=1.78, arm_span_m=1.80, weight_kg=72.0,
                      posture="standing")


def test_planner_process_answers_a_human_state_and_replans_when_the_receiver_moves():
    profile = loopback_profile()
    with BusRouter(profile):
        session = client_session(profile)
        received: queue.Queue = queue.Queue()
        sub = session.declare_subscriber(
            T.TRANSFER.key(profile.prefix),
            lambda s: received.put(decode(T.TRANSFER, s.payload.to_bytes())),
        )
        human_pub = session.declare_publisher(T.HUMAN.key(profile.prefix))
        object_pub = session.declare_publisher(T.OBJECT.key(profile.prefix))
        try:
            with ServiceProcess("services.planner", profile, name="planner") as proc:
                wait_alive(session, profile, {"planner"}, timeout_s=20.0)
                human_pub.put(b"\x00garbage")  # must be dropped, not crash the service

                def first_target(torso, mass=None, deadline_s=10.0):
                    end = time.monotonic() + deadline_s
                    seq = 0
                    while time.monotonic() < end:
                        if mass is not None:
                            object_pub.put(encode(ObjectEstimate(seq=seq, stamp_ns=0, source="tracker",
                                                                 found=True, mass_kg=mass)))
                        human_pub.put(encode(_human(seq, torso)))
                        seq += 1
                        try:
                            msg = received.get(timeout=0.1)
                        except queue.Empty:
                            continue
                        if mass is None or msg.object_mass_kg == pytest.approx(mass):
                            return msg
                    raise AssertionError("no TransferTarget within the deadline:\n" + proc.log_text())

                target = first_target(TORSO)
                cfg = load_config({})
                expected = plan_for_receiver(
                    cfg, receiver_from_human_state(_human(0), cfg, cfg.frame.frame()), cfg.object_mass_kg
                )
                assert target.source == "planner"
                np.testing.assert_allclose(target.position_task_m, expected.position_task_m, atol=1e-6)
                np.testing.assert_allclose(target.position_base_m, expected.position_base_m, atol=1e-6)
                assert target.reach_duration_s == pytest.approx(expected.reach.duration_s)
                assert target.receiver_posture == "standing"

                # The receiver steps 15 cm back: a new point farther along +x.
                while not received.empty():
                    received.get_nowait()
                moved = (TORSO[0] + 0.15, TORSO[1], TORSO[2])
                end = time.monotonic() + 10.0
                new = None
                while time.monotonic() < end and new is None:
                    human_pub.put(encode(_human(100, moved)))
                    try:
                        msg = received.get(timeout=0.1)
                    except queue.Empty:
                        continue
                    if msg.position_task_m[0] > target.position_task_m[0] + 0.01:
                        new = msg
                assert new is not None, proc.log_text()
                # A heavy object from the tracker: handed over closer to the robot.
                heavy = first_target(moved, mass=0.8)
                assert heavy.position_task_m[0] < new.position_task_m[0]
                assert proc.proc.poll() is None
            assert proc.proc.returncode == 0, proc.log_text()
            assert "planned (first plan)" in proc.log_text()
        finally:
            sub.undeclare()
            session.close()


def test_the_planner_rests_outside_an_episode_and_wakes_for_the_next_one(bus, make_node):
    """Issue 16: while the supervisor is outside an episode (``done``) the planner looks at its
    inputs every 0.5 s, so it republishes its plan about twice a second instead of five times;
    in an episode (``pick``), and once the supervisor has been silent for a second after a
    ``done``, five times again. Human states go out at 30 Hz and supervisor states at 10 Hz
    for 3 s per window."""
    profile, router = bus
    node = make_node()
    targets = node.subscribe(T.TRANSFER, queue_size=1000)
    human_pub, state_pub = node.publisher(T.HUMAN), node.publisher(T.SUPERVISOR_STATE)
    human = {k: v for k, v in msgspec_fields(_human(0)).items() if k not in ("seq", "stamp_ns", "source")}
    with ServiceProcess("services.planner", profile, name="planner") as proc:
        wait_alive(node.session, profile, {"planner"}, timeout_s=20.0)

        # The first plan, and the planner hears the supervisor; resting; in an episode; resting
        # again (the last word before the silence); silent (after 1 s its last state says
        # nothing); unsupervised.
        counts = outputs_per_window(targets, lambda: human_pub.put(**human), state_pub, [
            (1.0, "done"), (3.0, "done"), (3.0, "pick"), (1.0, "done"), (1.5, None), (3.0, None)],
            state_every=3, settle_s=0.0)
        resting, in_episode, unsupervised = counts[1], counts[2], counts[5]
        assert proc.proc.poll() is None, proc.log_text()
    assert 4 <= resting <= 8, (resting, in_episode, unsupervised)
    assert in_episode >= 12, (resting, in_episode, unsupervised)
    assert unsupervised >= 12, (resting, in_episode, unsupervised)
