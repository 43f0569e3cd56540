"""The review entities of a recording: a short scripted handover published to a real recorder,
read back from the .rrd (entity paths exist, numbers equal what was published)."""

from __future__ import annotations

import signal
import time

import numpy as np
import pytest

from bus_schema import messages as m, topics
from services.recorder.blueprint import BASE_FRAME
from services.recorder.core import SKELETON_BONES
from services.recorder.readback import (entity_row_counts, read_component, read_scalars, read_static_component,
                                        read_text_log)
from services.runtime.testing import ServiceProcess, wait_alive

pytestmark = pytest.mark.integration

TOOL_PATH = [(0.5 + 0.01 * i, -0.2, 0.1 + 0.002 * i) for i in range(30)]  # 1 cm steps along x
OBJECT = (0.62, -0.21, 0.08)
TARGET = (0.61, -0.26, 0.12)
GOAL = (0.8, -0.2, 0.16)
HAND, HAND_RAW = (0.85, -0.25, 0.1), (0.88, -0.25, 0.1)
#: Skeleton joints (`base` frame, m): a different position per joint, so order and values count.
SKELETON = {n: (1.0 + 0.01 * i, -0.4 - 0.02 * i, 0.9 - 0.1 * i) for i, n in enumerate(m.SKELETON_JOINTS)}


def _publish_handover(node):
    pub = {t: node.publisher(t) for t in (
        topics.SIM_TRUTH, topics.SUPERVISOR_STATE, topics.MOTION_GOAL, topics.TRANSFER, topics.SKELETON,
        topics.HUMAN, topics.GRIPPER_COMMAND, topics.GRIPPER_STATE, topics.GRIPPER_RELEASE,
        topics.WRIST_WRENCH, topics.OBJECT_MOTION)}
    time.sleep(0.3)
    pub[topics.SUPERVISOR_STATE].put(phase="plan", episode_id=1)
    pub[topics.TRANSFER].put(position_task_m=(0.05, 0.35), position_base_m=TARGET, cost=3.0)
    pub[topics.SIM_TRUTH].put(object_position_m=OBJECT, tool_position_m=TOOL_PATH[0])
    time.sleep(0.05)
    pub[topics.MOTION_GOAL].put(goal_id="reach-1", kind="transfer", position_base_m=GOAL)
    pub[topics.SUPERVISOR_STATE].put(phase="reach", episode_id=1)
    pub[topics.SKELETON].put(tracked=True, joints=[m.SkeletonJoint(name=n, position_m=p) for n, p in SKELETON.items()])
    pub[topics.HUMAN].put(tracked=True, hand_position_m=HAND, hand_raw_position_m=HAND_RAW, correction="lag")
    forces = []
    for i, tool in enumerate(TOOL_PATH[1:], start=1):
        pub[topics.SIM_TRUTH].put(object_position_m=OBJECT, tool_position_m=tool)
        grip = 20.0 - 0.5 * i
        forces.append(grip)
        mode = "grasp" if i < 10 else "slip" if i < 29 else "release"
        pub[topics.GRIPPER_COMMAND].put(grip_force_n=grip, mode=mode)
        pub[topics.GRIPPER_STATE].put(mode=mode, grip_force_n=grip, measured_grip_force_n=grip - 1.0)
        pub[topics.WRIST_WRENCH].put(force_n=(0.1 * i, 2.0, 0.0))
        pub[topics.OBJECT_MOTION].put(displacement_counts=(0, 1), counts_per_m=15748.0, dt_s=0.01,
                                      velocity_m_s=(0.0, 0.001 * i), accel_y_m_s2=0.05 * i)
        time.sleep(0.01)
    pub[topics.SUPERVISOR_STATE].put(phase="transfer", episode_id=1)
    pub[topics.GRIPPER_RELEASE].put(grip_force_n=5.5, pull_force_n=3.0, controller="SG")
    pub[topics.SUPERVISOR_STATE].put(phase="released", episode_id=1, reason="release event")
    return forces


def test_review_entities_hold_what_was_published(bus, make_node, tmp_path):
    profile, router = bus
    out = tmp_path / "review.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(out), "--no-urdf"]) as rec:
        wait_alive(router, profile, {"recorder"})
        forces = _publish_handover(make_node())
        time.sleep(0.5)
        rec.proc.send_signal(signal.SIGTERM)
        assert rec.proc.wait(30) == 0, rec.log_text()

    counts = entity_row_counts(out, include_static=False)
    for entity in ("/world/tool", "/world/tool_path", "/world/truth/object", "/world/transfer_target",
                   "/world/motion/goal", "/world/motion/goal_arrow", "/world/skeleton/raw",
                   "/world/skeleton/bones", "/world/human/hand_corrected", "/world/human/hand_raw",
                   "/world/human/hand_correction", "/world/release", "/signals/gripper_mode",
                   "/signals/release_grip_force_n", "/events"):
        assert counts.get(entity, 0) > 0, f"{entity} missing from the recording"

    # Trajectory: the last tool path strip is the published tool positions (1 cm ≥ 5 mm spacing).
    strips = read_component(out, "world/tool_path", "LineStrips3D:strips")
    np.testing.assert_allclose(np.array(strips[-1][1][0]), np.array(TOOL_PATH), atol=1e-6)
    tool = read_component(out, "world/tool", "Points3D:positions")
    assert len(tool) == len(TOOL_PATH)
    np.testing.assert_allclose([p[1][0] for p in tool], TOOL_PATH, atol=1e-6)
    np.testing.assert_allclose(read_component(out, "world/truth/object", "Points3D:positions")[0][1][0], OBJECT,
                               atol=1e-6)
    np.testing.assert_allclose(read_component(out, "world/transfer_target", "Points3D:positions")[0][1][0], TARGET,
                               atol=1e-6)
    np.testing.assert_allclose(read_component(out, "world/motion/goal", "Points3D:positions")[0][1][0], GOAL,
                               atol=1e-6)
    arrow = read_component(out, "world/motion/goal_arrow", "Arrows3D:vectors")[0][1][0]
    np.testing.assert_allclose(arrow, np.subtract(GOAL, TOOL_PATH[0]), atol=1e-6)
    # Human: the 15 raw joints at the published positions, in the `base` frame (the 3-D view's
    # target frame), and the 15 bones between the published joints.
    joints = read_component(out, "world/skeleton/raw", "Points3D:positions")
    assert len(joints) == 1
    np.testing.assert_allclose(joints[0][1], list(SKELETON.values()), atol=1e-6)
    bones = read_component(out, "world/skeleton/bones", "LineStrips3D:strips")[0][1]
    np.testing.assert_allclose(bones, [[SKELETON[a], SKELETON[b]] for a, b in SKELETON_BONES], atol=1e-6)
    for entity in ("world/skeleton/raw", "world/skeleton/bones", "world/human/hand_corrected", "world/truth/object"):
        assert read_static_component(out, entity, "CoordinateFrame:frame") == [[BASE_FRAME]], entity
    np.testing.assert_allclose(read_component(out, "world/human/hand_corrected", "Points3D:positions")[0][1][0],
                               HAND, atol=1e-6)
    np.testing.assert_allclose(read_component(out, "world/human/hand_correction", "Arrows3D:vectors")[0][1][0],
                               np.subtract(HAND, HAND_RAW), atol=1e-6)
    # Release marker at the last tool position; grip force at release as a point series.
    np.testing.assert_allclose(read_component(out, "world/release", "Points3D:positions")[0][1][0], TOOL_PATH[-1],
                               atol=1e-6)
    assert read_scalars(out, "/signals/release_grip_force_n")["/signals/release_grip_force_n"][1].tolist() == [5.5]

    # Gripper signals: command, measured, F_sx, F_sy, a_y, slip velocity, mode.
    s = read_scalars(out, "/bus")
    assert s["/bus/gripper/command/grip_force_n"][1].tolist() == forces
    assert s["/bus/gripper/state/measured_grip_force_n"][1].tolist() == [f - 1.0 for f in forces]
    np.testing.assert_allclose(s["/bus/sensors/wrist_wrench/force_n/0"][1], [0.1 * i for i in range(1, 30)])
    assert set(s["/bus/sensors/wrist_wrench/force_n/1"][1].tolist()) == {2.0}
    np.testing.assert_allclose(s["/bus/sensors/object_motion/accel_y_m_s2"][1], [0.05 * i for i in range(1, 30)])
    np.testing.assert_allclose(s["/bus/sensors/object_motion/velocity_m_s/1"][1], [0.001 * i for i in range(1, 30)])
    modes = read_scalars(out, "/signals/gripper_mode")["/signals/gripper_mode"][1].tolist()
    assert modes == [0.0] * 9 + [1.0] * 19 + [2.0]

    # Text log: phase changes in order, gripper mode changes, the release.
    events = read_text_log(out)
    phases = [e for e in events if e.startswith("supervisor:")]
    assert phases == ["supervisor: plan", "supervisor: reach", "supervisor: transfer",
                      "supervisor: released (release event)"]
    assert [e for e in events if e.startswith("gripper:")] == ["gripper: grasp", "gripper: slip", "gripper: release"]
    assert any(e.startswith("RELEASE by SG: grip 5.5 N, pull 3.0 N") for e in events)
    # Every row has both timelines: sender stamp and receive time.
    assert _timelines(out, "/world/tool") == {"time", "receive_time"}
    assert _timelines(out, "/events") == {"time", "receive_time"}


def _timelines(path, entity):
    from services.recorder.readback import _reader

    names = set()
    for chunk in _reader(path).stream():
        if chunk.entity_path == entity and not chunk.is_static:
            names |= set(chunk.timeline_names)
    return names
