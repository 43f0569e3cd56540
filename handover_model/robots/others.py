"""Built-in descriptions of current arms: Franka Emika Panda, Universal Robots UR5 and the
low-cost SO-ARM101 (LeRobot / The Robot Studio). The figures and their sources: docs/robots.md.

Placement (`base_xyz_m`, scene frame `base`, m): the table top is at z = −0.23 and spans
x 0.264–0.864 (the giver's edge at 0.264), y −0.634–0.116; the task plane is y = −0.259. The
two industrial arms stand on a pedestal level with the table top just behind its near edge;
the SO-ARM101 (0.31 m of height span with the jaws pointing down) sits on a 0.265 m riser on
the table, near the transfer point, with the object on the table beside it, and its giver
stand-in sits (docs/robots.md#so-arm101).
"""

from __future__ import annotations

import math

from handover_model.robots.description import TOOL_FRAME_NAME, GiverStandIn, GripperSpec, RobotDescription

#: An average adult as the giver's stand-in (the person the arm replaces at the table).
ADULT_STAND_IN = GiverStandIn(height_m=1.75, arm_span_m=1.75, weight_kg=75.0, shoulder_x_task_m=-0.5)

PANDA = RobotDescription(
    name="panda",
    title="Franka Emika Panda with the Franka Hand",
    urdf="panda_description/urdf/panda.urdf",
    joints=tuple(f"panda_joint{i}" for i in range(1, 8)),
    tool_frame=TOOL_FRAME_NAME,
    tool_parent="panda_hand_tcp",
    tool_rpy_rad=(0.0, 0.0, math.pi),
    base_xyz_m=(0.20, -0.30, -0.23),
    home_rad=(0.404, -0.676, 0.545, -2.75, 0.388, 2.114, 1.423),
    acceleration_rad_s2=(3.0,),
    jerk_rad_s3=(30.0,),
    gripper=GripperSpec(
        name="Franka Hand", stroke_m=0.08, force_min_n=0.0, force_max_n=70.0, force_rate_n_s=25.0,
        loop_rate_hz=10.0,
        source="Franka Emika Panda datasheet: 70 N continuous, 140 N peak, 80 mm travel, 50 mm/s per finger; "
               "10 Hz: the gripper takes actions, not a stream (assumption)"),
    giver=ADULT_STAND_IN,
    body_capsules=(((0.20, -0.30, -0.93), (0.20, -0.30, -0.28), 0.10),),  # the pedestal
)

UR5 = RobotDescription(
    name="ur5",
    title="Universal Robots UR5 with a Robotiq 2F-85-like gripper",
    urdf="ur_description/urdf/ur5_robot.urdf",
    joints=("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
            "wrist_3_joint"),
    tool_frame=TOOL_FRAME_NAME,
    tool_parent="tool0",
    tool_xyz_m=(0.0, 0.0, 0.15),
    base_xyz_m=(0.20, -0.30, -0.23),
    home_rad=(0.628, -1.956, 1.881, -1.496, -1.571, 2.198),
    acceleration_rad_s2=(3.0,),
    jerk_rad_s3=(30.0,),
    gripper=GripperSpec(
        name="Robotiq 2F-85 (like)", stroke_m=0.085, force_min_n=20.0, force_max_n=235.0, force_rate_n_s=75.0,
        loop_rate_hz=50.0,
        source="Robotiq 2F-85 manual: 85 mm stroke, 20–235 N grip force, 20–150 mm/s; 50 Hz Modbus "
               "command/status cycle (assumption)"),
    giver=ADULT_STAND_IN,
    body_capsules=(((0.20, -0.30, -0.93), (0.20, -0.30, -0.28), 0.10),),  # the pedestal
)

SO_ARM101 = RobotDescription(
    name="so_arm101",
    title="SO-ARM101 (LeRobot), 5 joints and a one-jaw gripper",
    urdf="so_arm_description/urdf/so101.urdf",
    joints=("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"),
    tool_frame=TOOL_FRAME_NAME,
    tool_parent="gripper_frame_link",
    tool_rpy_rad=(0.0, 0.0, math.pi / 2),
    base_xyz_m=(0.51, -0.259, 0.01),
    home_rad=(1.009, 0.179, 1.007, 0.385, 2.629),
    velocity_rad_s=(3.0,),
    acceleration_rad_s2=(6.0,),
    jerk_rad_s3=(60.0,),
    gripper=GripperSpec(
        name="SO-ARM101 jaw (Feetech STS3215 servo)", stroke_m=0.06, force_min_n=0.0, force_max_n=10.0,
        force_rate_n_s=150.0, loop_rate_hz=50.0,
        source="Feetech STS3215: 19.5 kg·cm stall at 7.4 V, 0.222 s/60°; 10 N: stall force at the jaw "
               "derated to LeRobot's torque limit (assumption); 50 Hz bus cycle (assumption)"),
    giver=GiverStandIn(height_m=1.60, arm_span_m=1.60, weight_kg=55.0, shoulder_x_task_m=-0.25, posture="sitting"),
    object_pick_base_m=(0.62, -0.12, -0.17),
    link_radius_m=0.03,
    body_capsules=(((0.51, -0.259, -0.23), (0.51, -0.259, -0.01), 0.04),),  # the riser on the table
    workspace_min_m=(0.20, -1.30, -0.35),
    workspace_max_m=(1.30, 0.30, 0.80),
)
