"""The ROS 1 message types the Baxter backend speaks.

The standard types (std_msgs, sensor_msgs, geometry_msgs) are the ROS 1 Noetic definitions
that rosbags' type store ships; Baxter's (baxter_core_msgs, from Rethink's ``baxter_common``)
are written here as in their package and registered into the store. The MD5 sums of all of
them equal the published ones (tests check each against its well-known value).
``handover_msgs/OpticalMotion`` is this project's own type for the optical slip sensor (no
standard message carries mouse-sensor counts); its definition is here and in docs/baxter.md,
and the robot-side sensor node must publish exactly it.

Units follow ROS: SI, radians, metres, newtons; ``time`` stamps are the sender's clock.
"""

from __future__ import annotations

from dataclasses import dataclass

from services.bridge.baxter.ros1 import Ros1Message, Time, message_class


@message_class("std_msgs/Header")
@dataclass(frozen=True)
class Header(Ros1Message):
    seq: int = 0
    stamp: Time = Time()
    frame_id: str = ""


@message_class("std_msgs/Bool")
@dataclass(frozen=True)
class Bool(Ros1Message):
    data: bool = False


@message_class("std_msgs/Float64")
@dataclass(frozen=True)
class Float64(Ros1Message):
    data: float = 0.0


@message_class("sensor_msgs/JointState")
@dataclass(frozen=True)
class JointState(Ros1Message):
    header: Header = Header()
    name: tuple[str, ...] = ()
    position: tuple[float, ...] = ()
    velocity: tuple[float, ...] = ()
    effort: tuple[float, ...] = ()


@message_class("geometry_msgs/Vector3")
@dataclass(frozen=True)
class Vector3(Ros1Message):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@message_class("geometry_msgs/Wrench")
@dataclass(frozen=True)
class Wrench(Ros1Message):
    force: Vector3 = Vector3()
    torque: Vector3 = Vector3()


@message_class("geometry_msgs/WrenchStamped")
@dataclass(frozen=True)
class WrenchStamped(Ros1Message):
    header: Header = Header()
    wrench: Wrench = Wrench()


JOINT_COMMAND_MSG = """\
int32 mode
float64[] command
string[]  names

int32 POSITION_MODE=1
int32 VELOCITY_MODE=2
int32 TORQUE_MODE=3
int32 RAW_POSITION_MODE=4
"""


@message_class("baxter_core_msgs/JointCommand", JOINT_COMMAND_MSG)
@dataclass(frozen=True)
class JointCommand(Ros1Message):
    POSITION_MODE = 1
    VELOCITY_MODE = 2
    TORQUE_MODE = 3
    RAW_POSITION_MODE = 4

    mode: int = 1
    command: tuple[float, ...] = ()
    names: tuple[str, ...] = ()


END_EFFECTOR_COMMAND_MSG = """\
## Command to be sent to an end effector
uint32 id       # target end effector id
string command  # operation to perform
# Well known commands:
string   CMD_NO_OP           = no_op
string   CMD_SET             = set
string   CMD_CONFIGURE       = configure
string   CMD_REBOOT          = reboot
string   CMD_RESET           = reset
string   CMD_CALIBRATE       = calibrate
string   CMD_CLEAR_CALIBRATION = clear_calibration
string   CMD_PREPARE_TO_GRIP = prepare_to_grip
string   CMD_GRIP            = grip
string   CMD_RELEASE         = release
string   CMD_GO              = go
string   CMD_STOP            = stop
#
string args     # JSON arguments to the command
#
string sender   # optional identifier, returned in state when the command is handled
uint32 sequence # optional sequence number, return in state when the command is handled
"""


@message_class("baxter_core_msgs/EndEffectorCommand", END_EFFECTOR_COMMAND_MSG)
@dataclass(frozen=True)
class EndEffectorCommand(Ros1Message):
    CMD_GO = "go"
    CMD_CALIBRATE = "calibrate"
    CMD_STOP = "stop"

    id: int = 0
    command: str = ""
    args: str = ""
    sender: str = ""
    sequence: int = 0


ASSEMBLY_STATE_MSG = """\
bool ready               # true if enabled and ready to operate, e.g., not homing
bool enabled             # true if enabled
bool stopped             # true if stopped -- e-stop asserted
bool error               # true if a component of the assembly has an error
#
# The following are specific to the robot top-level assembly:
uint8  estop_button      # One of the following:
  uint8   ESTOP_BUTTON_UNPRESSED = 0   # Robot is not stopped and button is not pressed
  uint8   ESTOP_BUTTON_PRESSED   = 1
  uint8   ESTOP_BUTTON_UNKNOWN   = 2   # STATE_UNKNOWN when estop was asserted by a non-user source
  uint8   ESTOP_BUTTON_RELEASED  = 3   # Was pressed, is now known to be released, but robot is still stopped.
#
uint8  estop_source      # If stopped is true, the source of the e-stop.  One of the following:
  uint8  ESTOP_SOURCE_NONE      = 0   # e-stop is not asserted
  uint8  ESTOP_SOURCE_USER      = 1   # e-stop source is user input (the red button)
  uint8  ESTOP_SOURCE_UNKNOWN   = 2   # e-stop source is unknown
  uint8  ESTOP_SOURCE_FAULT     = 3   # MotorController asserted e-stop in response to a joint fault
  uint8  ESTOP_SOURCE_BRAIN     = 4   # MotorController asserted e-stop in response to a lapse of the brain heartbeat
"""


@message_class("baxter_core_msgs/AssemblyState", ASSEMBLY_STATE_MSG)
@dataclass(frozen=True)
class AssemblyState(Ros1Message):
    ready: bool = False
    enabled: bool = False
    stopped: bool = False
    error: bool = False
    estop_button: int = 0
    estop_source: int = 0


OPTICAL_MOTION_MSG = """\
# Optical (mouse-type) sensor on the gripper's finger pad: the object's displacement over the
# pad since the previous message, in sensor counts (sensor frame: x, y on the pad).
Header header          # stamp: end of the sample; frame_id: the sensor's frame
int32 dx_counts        # displacement along the sensor x since the previous message, counts
int32 dy_counts        # displacement along the sensor y since the previous message, counts
float32 dt             # time covered by this message, s
uint8 surface_quality  # the sensor's surface quality (SQUAL register); 0: no surface seen
"""


@message_class("handover_msgs/OpticalMotion", OPTICAL_MOTION_MSG)
@dataclass(frozen=True)
class OpticalMotion(Ros1Message):
    header: Header = Header()
    dx_counts: int = 0
    dy_counts: int = 0
    dt: float = 0.0
    surface_quality: int = 0


#: Every type the backend speaks, by ROS name.
MESSAGE_TYPES: dict[str, type[Ros1Message]] = {
    cls.TYPE: cls
    for cls in (Header, Bool, Float64, JointState, Vector3, Wrench, WrenchStamped, JointCommand,
                EndEffectorCommand, AssemblyState, OpticalMotion)
}

__all__ = [
    "AssemblyState", "Bool", "EndEffectorCommand", "Float64", "Header", "JointCommand",
    "JointState", "MESSAGE_TYPES", "OpticalMotion", "Time", "Vector3", "Wrench", "WrenchStamped",
]
