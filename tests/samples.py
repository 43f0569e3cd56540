"""One valid, fully populated sample message per bus topic (for round trips and fuzzing)."""

from __future__ import annotations

from bus_schema import TOPICS, Topic, messages as m

H = {"seq": 7, "stamp_ns": 1_763_000_000_123_456_789, "source": "test-node"}
J7 = ["right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"]


def sample(topic: Topic) -> m.Message:
    t = topic.type
    if t is m.JointState:
        return t(**H, names=J7, position_rad=[0.1 * i for i in range(7)], velocity_rad_s=[0.0] * 7,
                 effort_nm=[1.0] * 7, holding=False, backend="sim", enabled=True)
    if t is m.JointCommand:
        return t(**H, names=J7, position_rad=[0.0, -0.5, 0.0, 1.2, 0.0, 0.3, 0.0], goal_id="g1")
    if t is m.WristWrench:
        return t(**H, force_n=(1.5, -2.0, 0.25), torque_nm=(0.01, 0.02, -0.03))
    if t is m.ObjectMotion:
        return t(**H, displacement_counts=(3, -12), counts_per_m=15748.0, dt_s=0.001,
                 surface_valid=True, velocity_m_s=(0.01, -0.02), accel_y_m_s2=1.5)
    if t is m.Skeleton:
        return t(**H, tracked=True, user_id=1, joints=[
            m.SkeletonJoint(name=n, position_m=(1.0, -0.4, 0.1 * i), confidence=0.9)
            for i, n in enumerate(m.SKELETON_JOINTS)])
    if t is m.DepthImage:
        return t(**H, width=4, height=3, depth_mm=bytes(range(24)), fx=285.0, fy=285.0, cx=2.0, cy=1.5,
                 camera_position_m=(0.0, 0.0, 0.8), camera_orientation_xyzw=(0.0, 0.0, 0.0, 1.0))
    if t is m.HumanState:
        return t(**H, tracked=True, hand_position_m=(0.8, -0.3, 0.1), hand_raw_position_m=(0.82, -0.3, 0.1),
                 correction="lag", torso_position_m=(1.2, -0.45, 0.2), height_m=1.8, arm_span_m=1.85,
                 shoulder_height_m=1.45, posture="standing", weight_kg=75.0, frame_age_s=0.12)
    if t is m.ObjectEstimate:
        return t(**H, found=True, position_m=(0.7, -0.5, -0.17), size_m=(0.07, 0.07, 0.12), mass_kg=0.2)
    if t is m.TransferTarget:
        return t(**H, position_task_m=(0.05, 0.35), position_base_m=(0.61, -0.26, 0.12), cost=12.5,
                 active_constraints=["table"], reach_duration_s=1.1, peak_speed_m_s=0.6,
                 object_mass_kg=0.2, receiver_posture="sitting")
    if t is m.MotionGoal:
        return t(**H, goal_id="reach-1", kind="transfer", position_base_m=(0.6, -0.26, 0.1),
                 orientation_xyzw=(0.0, 0.7071, 0.0, 0.7071), duration_s=1.2, peak_speed_m_s=0.5,
                 receiver_hand_position_m=(0.9, -0.26, 0.1))
    if t is m.MotionStatus:
        return t(**H, goal_id="reach-1", state="moving", reason="", progress=0.4, tool_speed_m_s=0.3)
    if t is m.MotionStop:
        return t(**H, reason="release", protective=False)
    if t is m.GripperCommand:
        return t(**H, grip_force_n=12.0, position_m=0.024, mode="slip")
    if t is m.GripperState:
        return t(**H, mode="hold", grip_force_n=12.0, measured_grip_force_n=11.5, controller="FS1",
                 sensors_fresh=False, released=False, reason="wrist_wrench stale for 0.31 s")
    if t is m.ReleaseEvent:
        return t(**H, grip_force_n=0.0, pull_force_n=3.2, controller="FS1")
    if t is m.SupervisorState:
        return t(**H, phase="transfer", episode_id=3, reason="reached", elapsed_s=0.8, grip_request="transfer")
    if t is m.EpisodeSummary:
        return t(**H, episode_id=3, outcome="released", reason="released to the receiver",
                 transfer_point_base_m=(0.6, -0.26, 0.1), receiver_posture="standing",
                 phase_durations_s={"reach": 1.2, "transfer": 0.9}, peak_grip_force_n=11.0,
                 force_overshoot_n=1.0, release_to_stop_s=0.012, replans=1,
                 faults=["recorder: liveliness lost"])
    if t is m.Heartbeat:
        return t(**H, uptime_s=12.5, beats=250)
    if t is m.SimTruth:
        return t(**H, object_position_m=(0.6, -0.26, 0.1), object_velocity_m_s=(0.0, 0.0, -0.1),
                 held_by="both", dropped=False, slip_m=0.002, grip_force_n=10.0,
                 receiver_hand_position_m=(0.65, -0.26, 0.1), receiver_pull_n=1.5,
                 tool_position_m=(0.6, -0.26, 0.12), tool_speed_m_s=0.0)
    if t is m.KinectTruth:
        return t(**H, hand_position_m=(0.9, -0.26, 0.1), torso_position_m=(1.1, -0.45, 0.3))
    if t is m.ClockGrant:
        return t(**H, step=42, time_ns=1_234_000_000, due=["gripper", "motion"])
    if t is m.ClockReady:
        return t(**H, done_ns=1_234_000_000, next_ns=1_244_000_000, events=True, leaving=False, pid=4242)
    raise KeyError(f"no sample for {t.__name__}: add one to tests/samples.py")


SAMPLES = {topic.suffix: sample(topic) for topic in TOPICS}
