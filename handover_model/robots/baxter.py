"""Baxter (Rethink Robotics): the thesis's robot, the stack's default arm.

Frames: Baxter's `base` frame is the scene frame itself (x forward, y left, z up, metres,
origin at the torso centre, 0.93 m above the floor on the standard pedestal). The right arm
has the seven joints of `RIGHT_ARM_JOINTS`; the tool frame is `right_gripper` (between the
fingertips of the electric gripper, 0.1327 m beyond `right_gripper_base`).

The Baxter hardware backend (`services.bridge.baxter`) and the tests import the constants;
everything else reads the arm from the active description (`handover_model.robots.active`).
"""

from __future__ import annotations

from handover_model import scene
from handover_model.robots.description import Capsule, GiverStandIn, GripperSpec, RobotDescription

RIGHT_ARM_JOINTS: tuple[str, ...] = ("right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1",
                                     "right_w2")
TOOL_FRAME = "right_gripper"

#: A comfortable, reachable right-arm posture (rad) used as the sim's start and the retract
#: pose: gripper in front of the robot, about table height.
RIGHT_ARM_HOME_RAD: tuple[float, ...] = (0.0, -0.55, 0.0, 1.28, 0.0, 0.26, 0.0)

#: (from frame, to frame, radius m): the right arm's links, shoulder to fingertips.
ARM_LINK_CAPSULES: tuple[Capsule, ...] = (
    Capsule("right_upper_shoulder", "right_lower_shoulder", 0.075),
    Capsule("right_lower_shoulder", "right_upper_elbow", 0.070),
    Capsule("right_upper_elbow", "right_lower_elbow", 0.065),
    Capsule("right_lower_elbow", "right_upper_forearm", 0.060),
    Capsule("right_upper_forearm", "right_lower_forearm", 0.055),
    Capsule("right_lower_forearm", "right_wrist", 0.050),
    Capsule("right_wrist", "right_gripper_base_link", 0.050),
    Capsule("right_gripper_base_link", TOOL_FRAME, 0.035),
)

BAXTER = RobotDescription(
    name="baxter",
    title="Rethink Robotics Baxter (right arm, electric parallel gripper)",
    urdf="baxter_description/urdf/baxter.urdf",
    joints=RIGHT_ARM_JOINTS,
    tool_frame=TOOL_FRAME,
    home_rad=RIGHT_ARM_HOME_RAD,
    acceleration_rad_s2=(3.0,),
    jerk_rad_s3=(30.0,),
    gripper=GripperSpec(
        name="Baxter electric parallel gripper with the thesis's spring pad",
        stroke_m=0.10, force_min_n=0.0, force_max_n=140.0, force_rate_n_s=50.0, loop_rate_hz=25.0,
        source="thesis §3.6 (25 Hz position loop, 5 N/cm pad spring, 0.1 m/s finger speed); "
               "140 N: ISO/TS 15066 hand limit"),
    giver=GiverStandIn(height_m=1.90, arm_span_m=2.00, weight_kg=100.0, shoulder_x_task_m=-0.5),
    object_pick_base_m=(float(scene.OBJECT_PICK_BASE_M[0]), float(scene.OBJECT_PICK_BASE_M[1]),
                        float(scene.OBJECT_PICK_BASE_M[2])),
    capsules=ARM_LINK_CAPSULES,
    body_capsules=(((0.0, 0.0, -0.35), (0.0, 0.0, 0.30), 0.17),),  # the torso (the head is not drawn)
)


def arm_model():
    """Baxter's cached pinocchio model (`handover_model.robots.ArmModel`)."""
    from handover_model.robots.model import arm_model_of

    return arm_model_of(BAXTER)


def urdf_path():
    """Baxter's URDF in example-robot-data (ROS_PACKAGE_PATH set so that meshes resolve)."""
    from handover_model.robots.urdf import urdf_path as path_of

    return path_of(BAXTER)
