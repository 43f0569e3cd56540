"""The tracker as a real process on a loopback bus: skeleton + depth + joint state in,
HumanState and ObjectEstimate out; garbage and silence handled."""

from __future__ import annotations

import queue
import time

import numpy as np
import pytest

from bus_schema import topics as T
from bus_schema.codec import decode, encode
from bus_schema.messages import DepthImage, JointState, Skeleton
from handover_model import scene
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from robot_sim.kinect import KinectScenario, KinectSim
from services.runtime.testing import BusRouter, ServiceProcess, client_session, loopback_profile, wait_alive, wait_until
from tests.integration.supervised_windows import outputs_per_window

pytestmark = pytest.mark.integration


def test_tracker_process_publishes_human_and_object_and_survives_garbage_and_silence():
    profile = loopback_profile()
    sim = KinectSim(seed=2, scenario=KinectScenario())
    q = np.array(RIGHT_ARM_HOME_RAD)
    frames = [sim.step(k / 30.0, q) for k in range(6)]
    with BusRouter(profile):
        session = client_session(profile)
        humans: queue.Queue = queue.Queue()
        objects: queue.Queue = queue.Queue()
        subs = [
            session.declare_subscriber(T.HUMAN.key(profile.prefix),
                                       lambda s: humans.put(decode(T.HUMAN, s.payload.to_bytes()))),
            session.declare_subscriber(T.OBJECT.key(profile.prefix),
                                       lambda s: objects.put(decode(T.OBJECT, s.payload.to_bytes()))),
        ]
        pubs = {t: session.declare_publisher(t.key(profile.prefix)) for t in (T.SKELETON, T.DEPTH, T.JOINT_STATE)}
        try:
            with ServiceProcess("services.tracker", profile, name="tracker",
                                args=["--weight-kg", "68", "--sensor", "bus"]) as proc:
                wait_alive(session, profile, {"tracker"}, timeout_s=30.0)
                pubs[T.SKELETON].put(b"\x93garbage")  # dropped, not a crash
                pubs[T.DEPTH].put(b"\x00")
                seq = 0
                got_tracked = False
                end = time.monotonic() + 15.0
                while time.monotonic() < end and not (got_tracked and not objects.empty()):
                    f = frames[seq % len(frames)]
                    pubs[T.JOINT_STATE].put(encode(JointState(seq=seq, stamp_ns=0, source="sim",
                                                              names=list(RIGHT_ARM_JOINTS),
                                                              position_rad=list(q), velocity_rad_s=[0.0] * 7)))
                    pubs[T.DEPTH].put(encode(DepthImage(seq=seq, stamp_ns=0, source="sim", **f.depth_fields)))
                    pubs[T.SKELETON].put(encode(Skeleton(seq=seq, stamp_ns=0, source="sim", **f.skeleton_fields)))
                    seq += 1
                    time.sleep(1 / 30)
                    while not humans.empty():
                        h = humans.get()
                        if h.tracked:
                            got_tracked = True
                            last = h
                assert proc.proc.poll() is None, proc.log_text()
                assert got_tracked, proc.log_text()
                truth_hand = frames[-1].truth.right_hand_m
                assert np.linalg.norm(np.array(last.hand_raw_position_m) - truth_hand) < 0.4
                assert last.weight_kg == pytest.approx(68.0)
                obj = objects.get(timeout=5.0)
                assert obj.found
                np.testing.assert_allclose(obj.position_m, scene.OBJECT_PICK_BASE_M, atol=0.03)
                # Silence: within about a second the tracker says the person is not tracked.
                def untracked() -> bool:
                    try:
                        return not humans.get(timeout=0.2).tracked
                    except queue.Empty:
                        return False
                assert wait_until(untracked, 3.0), proc.log_text()
                assert proc.proc.poll() is None
        finally:
            for s in subs:
                s.undeclare()
            for p in pubs.values():
                p.undeclare()
            session.close()


def test_a_replay_ends_by_itself_after_publishing_its_last_frame(bus, make_node, tmp_path):
    """`--replay FILE`: the tracker publishes from the file at its times and stops at its end;
    the last skeleton's estimate is published before it stops (the tick that reaches the end
    still counts)."""
    from bus_schema.messages import SKELETON_JOINTS, Skeleton, SkeletonJoint
    from services.tracker.replay import ReplayWriter

    profile, router = bus
    body = KinectSim(0).body.joints(np.array([0.7, -0.3, 0.2]))

    def skeleton(k: int, hand_x_m: float) -> Skeleton:
        joints = [SkeletonJoint(name=n, position_m=tuple(float(v) for v in (
            (hand_x_m, -0.3, 0.2) if n == "right_hand" else body[n]))) for n in SKELETON_JOINTS]
        return Skeleton(seq=k, stamp_ns=k, source="replay", tracked=True, user_id=1, joints=joints)

    path = tmp_path / "three.trk"
    with ReplayWriter(path) as writer:
        for k, hand_x_m in enumerate((0.70, 0.71, 0.95)):  # the last frame's hand is far off
            writer.write(0.2 + 0.1 * k, T.SKELETON, skeleton(k, hand_x_m))
    node = make_node()
    humans = node.subscribe(T.HUMAN, queue_size=1000)
    with ServiceProcess("services.tracker", profile, name="tracker",
                        args=["--replay", str(path), "--no-lag-correction"]) as proc:
        assert proc.proc.wait(30) == 0, proc.log_text()
    time.sleep(0.3)
    raw_x = [rx.msg.hand_raw_position_m[0] for rx in humans.drain() if rx.msg.tracked]
    assert raw_x and raw_x[-1] == pytest.approx(0.95), raw_x


def test_the_object_is_detected_at_full_rate_only_while_the_supervisor_locates_it(bus, make_node):
    """Issue 16: with a supervisor past ``locate`` the tracker detects the object on every 15th
    depth frame (2 Hz at 30 Hz) instead of every 3rd; in ``locate``, and once the supervisor
    has been silent for a second after a ``reach``, every 3rd again. Depth frames are sent at
    30 Hz and states at 15 Hz for 3 s per window: 90 frames, 6 detections resting, 30 at full
    rate."""
    profile, router = bus
    sim = KinectSim(seed=2, scenario=KinectScenario())
    q = np.array(RIGHT_ARM_HOME_RAD)
    frame = sim.step(0.0, q)
    node = make_node()
    objects = node.subscribe(T.OBJECT, queue_size=1000)
    pubs = {t: node.publisher(t) for t in (T.SKELETON, T.DEPTH, T.JOINT_STATE, T.SUPERVISOR_STATE)}
    with ServiceProcess("services.tracker", profile, name="tracker", args=["--sensor", "bus"]) as proc:
        wait_alive(node.session, profile, {"tracker"}, timeout_s=30.0)

        def send_frame() -> None:
            pubs[T.JOINT_STATE].put(names=list(RIGHT_ARM_JOINTS), position_rad=list(q), velocity_rad_s=[0.0] * 7)
            pubs[T.DEPTH].put(**frame.depth_fields)
            pubs[T.SKELETON].put(**frame.skeleton_fields)

        # The tracker hears the supervisor; resting; locating; resting again (the last word
        # before the silence); silent (after 1 s its last state says nothing); unsupervised.
        counts = outputs_per_window(objects, send_frame, pubs[T.SUPERVISOR_STATE], [
            (1.0, "reach"), (3.0, "reach"), (3.0, "locate"), (1.0, "reach"), (1.5, None), (3.0, None)])
        resting, locating, unsupervised = counts[1], counts[2], counts[5]
        assert proc.proc.poll() is None, proc.log_text()
    assert 3 <= resting <= 10, (resting, locating, unsupervised)
    assert locating >= 20, (resting, locating, unsupervised)
    assert unsupervised >= 20, (resting, locating, unsupervised)
