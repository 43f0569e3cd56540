"""openni_tracker's skeleton from real ROS 1 ``/tf`` bytes: frame assembly, out-of-order joints
(dropped, counted), unusable transforms, and the receiver's choice among several users."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import SKELETON_JOINTS
from handover_model import scene
from services.bridge.baxter.messages import Header, Vector3
from services.bridge.baxter.ros1 import Time
from services.tracker.ros1.calibration import parse_calibration
from services.tracker.ros1.messages import TFMessage, Transform, TransformStamped
from services.tracker.ros1.skeleton import ReceiverChooser, SkeletonAssembler, UserFrame, joint_samples

FRAME = "openni_depth_frame"
#: Camera 1 m up, pitched 90 degrees down: camera (x, y, z) → base (0.2 + z, y, 1 - x).
POSE = parse_calibration({"position_m": [0.2, 0.0, 1.0], "rpy_deg": [0.0, 90.0, 0.0]}, "test")
CENTRE = np.array([0.5, 0.0, 0.0])


def body_in_camera(offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    """15 distinct joint positions (m, camera frame)."""
    return np.array([[1.0 + 0.01 * i, -0.2 + 0.03 * i, 0.5 + 0.02 * i] for i in range(15)]) + offset


def wire(joints_camera: np.ndarray, user: int, stamp_ns: int, frame: str = FRAME) -> list[bytes]:
    """openni_tracker's bytes for one frame: one TFMessage per joint, 1 µs apart."""
    out = []
    for i, (name, p) in enumerate(zip(SKELETON_JOINTS, joints_camera, strict=True)):
        header = Header(seq=i, stamp=Time.from_ns(stamp_ns + 1000 * i), frame_id=frame)
        out.append(TFMessage((TransformStamped(header, f"{name}_{user}", Transform(Vector3(*map(float, p)))),))
                   .to_bytes())
    return out


def feed(assembler: SkeletonAssembler, payloads: list[bytes], rx_s: float = 1.0) -> int:
    bad = 0
    for data in payloads:
        samples, n_bad = joint_samples(TFMessage.from_bytes(data), FRAME, rx_s)
        bad += n_bad
        for s in samples:
            assembler.add(s)
    return bad


def test_a_frame_from_real_bytes_lands_in_base_through_the_calibration():
    assembler = SkeletonAssembler(POSE, 0.015)
    body = body_in_camera()
    feed(assembler, wire(body, 1, 10**9))
    [frame] = assembler.complete()
    assert frame.user == 1 and frame.stamp_ns == 10**9 + 14_000
    expected = np.column_stack([0.2 + body[:, 2], body[:, 1], 1.0 - body[:, 0]])
    np.testing.assert_allclose(frame.joints_m, expected, atol=1e-12)
    # torso (index 2) of the first joint rows: camera (1.02, -0.14, 0.54) → base (0.74, -0.14, -0.02)
    np.testing.assert_allclose(frame.torso_m, [0.74, -0.14, -0.02], atol=1e-12)
    assert assembler.complete() == []  # nothing new since


def test_a_frame_completes_only_once_all_15_joints_came():
    assembler = SkeletonAssembler(POSE, 0.015)
    payloads = wire(body_in_camera(), 1, 10**9)
    feed(assembler, payloads[:10])
    assert assembler.complete() == []
    feed(assembler, payloads[10:])
    assert len(assembler.complete()) == 1


def test_out_of_order_joints_are_dropped_and_counted():
    assembler = SkeletonAssembler(POSE, 0.015)
    old, new = wire(body_in_camera(), 1, 10**9), wire(body_in_camera((0.1, 0, 0)), 1, 10**9 + 33_000_000)
    feed(assembler, new)
    [frame] = assembler.complete()
    feed(assembler, old)  # the older frame arrives late
    assert assembler.out_of_order == 15
    assert assembler.complete() == []
    np.testing.assert_allclose(frame.joints_m, POSE.to_base(body_in_camera((0.1, 0, 0))))
    feed(assembler, new[:1])  # a repeated joint is not newer either
    assert assembler.out_of_order == 16


def test_joints_of_two_frames_are_not_mixed_into_one():
    assembler = SkeletonAssembler(POSE, 0.015)
    first = wire(body_in_camera(), 1, 10**9)
    second = wire(body_in_camera((0.2, 0, 0)), 1, 10**9 + 33_000_000)
    feed(assembler, first[:14])  # the first frame's last joint is lost
    feed(assembler, second[14:])
    assert assembler.complete() == []  # 14 joints of one frame, 1 of the next: 33 ms apart
    feed(assembler, second[:14])
    [frame] = assembler.complete()
    np.testing.assert_allclose(frame.joints_m, POSE.to_base(body_in_camera((0.2, 0, 0))))


def test_other_frames_on_tf_are_ignored_and_unusable_joints_counted():
    tf = TFMessage((
        TransformStamped(Header(frame_id="base"), "right_gripper", Transform(Vector3(1, 2, 3))),  # the robot's
        TransformStamped(Header(frame_id="camera_link"), "head_1", Transform(Vector3(1, 0, 0))),  # wrong parent
        TransformStamped(Header(frame_id=FRAME), "neck_1", Transform(Vector3(float("nan"), 0, 0))),
        TransformStamped(Header(frame_id=FRAME), "torso_1", Transform(Vector3(1e3, 0, 0))),
        TransformStamped(Header(frame_id="/" + FRAME), "/left_hand_2", Transform(Vector3(1, 0, 0))),
        TransformStamped(Header(frame_id=FRAME), "left_hand_x", Transform(Vector3(1, 0, 0))),
        TransformStamped(Header(frame_id=FRAME), "left_hand_65536", Transform(Vector3(1, 0, 0))),  # id too large
    ))
    samples, bad = joint_samples(TFMessage.from_bytes(tf.to_bytes()), FRAME, 2.0)
    assert bad == 4
    assert [(s.user, s.joint, s.position_m) for s in samples] == [(2, "left_hand", (1.0, 0.0, 0.0))]


def frame_at(user: int, torso_xy: tuple[float, float], rx_s: float) -> UserFrame:
    joints = np.zeros((15, 3))
    joints[SKELETON_JOINTS.index("torso")] = (*torso_xy, 0.1)
    return UserFrame(user, int(rx_s * 1e9), rx_s, joints)


def test_the_receiver_is_the_user_nearest_the_transfer_region():
    chooser = ReceiverChooser(CENTRE, max_distance_m=1.5, margin_m=0.3, lost_s=0.5)
    near, far = frame_at(2, (1.0, 0.0), 0.0), frame_at(1, (1.6, 0.9), 0.0)  # 0.5 m and 1.41 m away
    assert chooser.choose([far, near], 0.0) is near
    assert chooser.receiver == 2
    assert chooser.distance_m(far) == pytest.approx(np.hypot(1.1, 0.9), abs=1e-12)


def test_the_choice_is_stable_and_switches_only_past_the_margin_or_on_loss():
    chooser = ReceiverChooser(CENTRE, max_distance_m=1.5, margin_m=0.3, lost_s=0.5)
    assert chooser.choose([frame_at(1, (1.0, 0.0), 0.0), frame_at(2, (1.2, 0.0), 0.0)], 0.0).user == 1
    # User 2 steps closer than user 1, but by less than the margin: user 1 stays the receiver.
    for k in range(1, 30):
        t = k / 30
        chosen = chooser.choose([frame_at(1, (1.0, 0.0), t), frame_at(2, (0.85, 0.0), t)], t)
        assert chosen is not None and chosen.user == 1
    # User 2 comes 0.4 m nearer than user 1: beyond the margin, it takes over.
    assert chooser.choose([frame_at(1, (1.0, 0.0), 1.0), frame_at(2, (0.6, 0.0), 1.0)], 1.0).user == 2
    # User 2 is lost (no frame for more than 0.5 s): user 1 becomes the receiver again.
    assert chooser.choose([frame_at(1, (1.0, 0.0), 1.2)], 1.2) is None  # user 2 still counts, no frame
    assert chooser.choose([frame_at(1, (1.0, 0.0), 1.6)], 1.6).user == 1
    assert chooser.switches == 3


def test_nobody_beyond_the_maximum_distance_is_the_receiver():
    chooser = ReceiverChooser(CENTRE, max_distance_m=1.5, margin_m=0.3, lost_s=0.5)
    assert chooser.choose([frame_at(1, (2.5, 0.0), 0.0)], 0.0) is None
    assert chooser.receiver is None
    # The receiver walking out of the region is not the receiver any more.
    chooser.choose([frame_at(2, (1.0, 0.0), 0.1)], 0.1)
    assert chooser.receiver == 2
    assert chooser.choose([frame_at(2, (2.2, 0.0), 0.2)], 0.2) is None and chooser.receiver is None


def test_the_default_transfer_centre_is_the_table_and_prefers_the_scenes_receiver():
    from services.tracker.ros1.config import Ros1KinectConfig

    config = Ros1KinectConfig()
    chooser = ReceiverChooser(config.transfer_centre_m, config.max_receiver_distance_m, config.switch_margin_m,
                              config.user_lost_s)
    receiver = frame_at(1, tuple(scene.RECEIVER_TORSO_BASE_XY_M), 0.0)
    bystander = frame_at(2, tuple(scene.RECEIVER_TORSO_BASE_XY_M + (0.6, 0.9)), 0.0)  # deploy/baxter_fake.toml's
    assert chooser.choose([bystander, receiver], 0.0) is receiver
    assert chooser.distance_m(receiver) < 0.6 < chooser.distance_m(bystander) - config.switch_margin_m


def test_users_whose_frames_never_complete_are_forgotten():
    assembler = SkeletonAssembler(POSE, 0.015)
    for user in range(1, 200):  # a flood of partial skeletons (one joint each)
        feed(assembler, wire(body_in_camera(), user, 10**9)[:1], rx_s=1.0)
    feed(assembler, wire(body_in_camera(), 500, 10**9), rx_s=1.4)
    assert assembler.prune(1.6, lost_s=0.5) == list(range(1, 200))
    assert [f.user for f in assembler.complete()] == [500]


def test_a_half_arrived_first_frame_holds_the_first_choice_until_it_completes():
    """The tracker may subscribe in the middle of openni_tracker's frame: the receiver's first
    frame lacks its first joints while the bystander's is whole. The bystander must not be
    chosen (not even for one frame) while the receiver's frame is still arriving."""
    assembler = SkeletonAssembler(POSE, 0.015)
    chooser = ReceiverChooser(CENTRE, max_distance_m=1.5, margin_m=0.3, lost_s=0.5)
    receiver, bystander = body_in_camera(), body_in_camera((0.0, 0.9, 0.0))  # 0.9 m to the side
    feed(assembler, wire(receiver, 1, 10**9)[5:], rx_s=1.0)  # the tail of user 1's frame
    feed(assembler, wire(bystander, 2, 10**9), rx_s=1.0)
    frames = assembler.complete()
    assert [f.user for f in frames] == [2] and assembler.pending(1.0) == [1]
    assert chooser.choose(frames, 1.0, assembler.pending(1.0)) is None and chooser.receiver is None
    feed(assembler, wire(receiver, 1, 10**9 + 33_000_000), rx_s=1.033)
    frames = assembler.complete()
    assert [f.user for f in frames] == [1] and assembler.pending(1.033) == []
    assert chooser.choose(frames, 1.033, assembler.pending(1.033)).user == 1
    assert chooser.switches == 1


def test_a_user_whose_frames_never_complete_holds_the_choice_only_briefly():
    assembler = SkeletonAssembler(POSE, 0.015)
    chooser = ReceiverChooser(CENTRE, max_distance_m=1.5, margin_m=0.3, lost_s=0.5)
    feed(assembler, wire(body_in_camera(), 1, 10**9)[:14], rx_s=1.0)  # never its 15th joint
    feed(assembler, wire(body_in_camera((0.0, 0.9, 0.0)), 2, 10**9), rx_s=1.0)
    frames = assembler.complete()
    assert chooser.choose(frames, 1.0, assembler.pending(1.0)) is None
    feed(assembler, wire(body_in_camera((0.0, 0.9, 0.0)), 2, 10**9 + 300_000_000), rx_s=1.3)
    frames = assembler.complete()
    assert assembler.pending(1.3) == []  # user 1 waited for more than FIRST_FRAME_WAIT_S
    assert chooser.choose(frames, 1.3, assembler.pending(1.3)).user == 2
