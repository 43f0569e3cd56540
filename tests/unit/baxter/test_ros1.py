"""ROS 1 serialisation: fixed byte vectors written by hand from the wire-format rules, MD5 sums
against the published values, round trips, and decoders fuzzed with random and cut bytes."""

from __future__ import annotations

import hashlib
import random

import pytest

from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import (
    MESSAGE_TYPES,
    AssemblyState,
    Bool,
    EndEffectorCommand,
    Float64,
    Header,
    JointCommand,
    JointState,
    OpticalMotion,
    Vector3,
    Wrench,
    WrenchStamped,
)
from services.bridge.baxter.ros1 import Ros1DecodeError, Ros1EncodeError, Time, full_definition, md5sum

# Little-endian field by field (uint32 lengths before strings and variable arrays).
U32 = {0: "00000000", 1: "01000000", 2: "02000000", 3: "03000000", 4: "04000000", 5: "05000000",
       6: "06000000", 7: "07000000", 8: "08000000"}
F64 = {0.5: "000000000000e03f", -1.0: "000000000000f0bf", 1.0: "000000000000f03f", 2.0: "0000000000000040",
       3.0: "0000000000000840", 0.0: "0000000000000000", 0.2: "9a9999999999c93f"}

VECTORS = [
    (Bool(True), "01"),
    (Bool(False), "00"),
    (Float64(0.2), F64[0.2]),
    (Header(seq=7, stamp=Time(1, 2), frame_id="b"), U32[7] + U32[1] + U32[2] + U32[1] + "62"),
    (JointCommand(mode=1, command=(0.5, -1.0), names=("right_s0", "right_e1")),
     U32[1] + U32[2] + F64[0.5] + F64[-1.0] + U32[2]
     + U32[8] + b"right_s0".hex() + U32[8] + b"right_e1".hex()),
    (JointState(header=Header(seq=1, stamp=Time(3, 4), frame_id=""), name=("a",), position=(1.0,)),
     U32[1] + U32[3] + U32[4] + U32[0] + U32[1] + U32[1] + "61" + U32[1] + F64[1.0] + U32[0] + U32[0]),
    (WrenchStamped(wrench=Wrench(force=Vector3(1.0, 2.0, 3.0), torque=Vector3(0.0, 0.0, -1.0))),
     U32[0] * 4 + F64[1.0] + F64[2.0] + F64[3.0] + F64[0.0] + F64[0.0] + F64[-1.0]),
    (EndEffectorCommand(id=65538, command="go", args='{"f":1}', sender="s", sequence=3),
     "02000100" + U32[2] + "676f" + U32[7] + b'{"f":1}'.hex() + U32[1] + "73" + U32[3]),
    (AssemblyState(ready=True, enabled=True), "010100000000"),
    (AssemblyState(stopped=True, error=True, estop_button=1, estop_source=4), "000001010104"),
    (OpticalMotion(header=Header(seq=2, stamp=Time(5, 6), frame_id="o"), dx_counts=-3, dy_counts=4, dt=0.5,
                   surface_quality=200),
     U32[2] + U32[5] + U32[6] + U32[1] + "6f" + "fdffffff" + U32[4] + "0000003f" + "c8"),
]


@pytest.mark.parametrize(("msg", "hex_bytes"), VECTORS,
                         ids=[f"{type(m).__name__}{i}" for i, (m, _) in enumerate(VECTORS)])
def test_encoding_matches_the_hand_written_bytes(msg, hex_bytes):
    assert msg.to_bytes().hex() == hex_bytes
    assert type(msg).from_bytes(bytes.fromhex(hex_bytes)) == msg


def test_every_type_has_a_fixed_vector():
    covered = {type(m).TYPE for m, _ in VECTORS} | {"geometry_msgs/Vector3", "geometry_msgs/Wrench"}
    assert covered == set(MESSAGE_TYPES)


PUBLISHED_MD5 = {
    "std_msgs/Header": "2176decaecbce78abc3b96ef049fabed",
    "std_msgs/Bool": "8b94c1b53db61fb6aed406028ad6332a",
    "std_msgs/Float64": "fdb28210bfa9d7c91146260178d9a584",
    "sensor_msgs/JointState": "3066dcd76a6cfaef579bd0f34173e9fd",
    "geometry_msgs/Vector3": "4a842b65f413084dc2b10fb484ea7f17",
    "geometry_msgs/Wrench": "4f539cf138b23283b520fd271b567936",
    "geometry_msgs/WrenchStamped": "d78d3cb249ce23087ade7e7d0c40cfa7",
    "baxter_core_msgs/JointCommand": "19bfec8434dd568ab3c633d187c36f2e",
    "baxter_core_msgs/EndEffectorCommand": "c003234e90416f2ca02ac7837c42cbb7",
    "baxter_core_msgs/AssemblyState": "356d9dd237ce73b2667da9235f541933",
}


@pytest.mark.parametrize("type_name", sorted(PUBLISHED_MD5))
def test_md5_equals_the_published_sum(type_name):
    assert md5sum(type_name) == PUBLISHED_MD5[type_name]


@pytest.mark.parametrize("type_name", sorted(PUBLISHED_MD5))
def test_the_class_and_the_zenoh_key_announce_the_published_sum(type_name):
    # What goes on the wire: the class's sum and the md5 chunk of zenoh-bridge-ros1's key.
    assert MESSAGE_TYPES[type_name].md5sum() == PUBLISHED_MD5[type_name]
    assert topic_key("/robot/x", type_name).split("/")[1] == PUBLISHED_MD5[type_name]


def md5_of(text: str) -> str:
    return hashlib.md5(text.encode()).hexdigest()


def test_md5_follows_genmsg_constants_first_and_nested_md5():
    assert md5sum("baxter_core_msgs/JointCommand") == md5_of(
        "int32 POSITION_MODE=1\nint32 VELOCITY_MODE=2\nint32 TORQUE_MODE=3\nint32 RAW_POSITION_MODE=4\n"
        "int32 mode\nfloat64[] command\nstring[] names")
    assert md5sum("geometry_msgs/WrenchStamped") == md5_of(
        "2176decaecbce78abc3b96ef049fabed header\n4f539cf138b23283b520fd271b567936 wrench")
    # Our own type, computed by hand from its field lines (the Header's published sum first).
    expected = md5_of("2176decaecbce78abc3b96ef049fabed header\nint32 dx_counts\nint32 dy_counts\n"
                      "float32 dt\nuint8 surface_quality")
    assert md5sum("handover_msgs/OpticalMotion") == expected


def test_full_definition_appends_dependencies():
    text = full_definition("geometry_msgs/WrenchStamped")
    assert text.count("=" * 80) == 3
    assert "MSG: std_msgs/Header\n" in text and "MSG: geometry_msgs/Wrench\n" in text
    assert "MSG: geometry_msgs/Vector3\n" in text


SAMPLES = [m for m, _ in VECTORS] + [
    JointState(header=Header(seq=9), name=tuple(f"j{i}" for i in range(17)), position=tuple(range(17)),
               velocity=tuple(float(i) / 3 for i in range(17)), effort=()),
    EndEffectorCommand(command="go", args="{\"position\": 0.0, \"force\": 42.5}", sender="ünï"),
]


@pytest.mark.parametrize("msg", SAMPLES, ids=[type(m).__name__ for m in SAMPLES])
def test_round_trip_and_every_truncation_is_a_clear_error(msg):
    data = msg.to_bytes()
    assert type(msg).from_bytes(data) == msg
    for cut in range(len(data)):
        with pytest.raises(Ros1DecodeError):
            type(msg).from_bytes(data[:cut])
    with pytest.raises(Ros1DecodeError, match="size mismatch"):
        type(msg).from_bytes(data + b"\x00")


@pytest.mark.parametrize("cls", list(MESSAGE_TYPES.values()), ids=list(MESSAGE_TYPES))
def test_random_bytes_never_crash_the_decoder(cls):
    rng = random.Random(1234)
    decoded = 0
    for _ in range(400):
        data = bytes(rng.getrandbits(8) for _ in range(rng.randrange(0, 80)))
        try:
            cls.from_bytes(data)
            decoded += 1
        except Ros1DecodeError as exc:
            assert str(exc)
    # Mutations of a valid message: flip one byte.
    valid = cls().to_bytes()
    for i in range(len(valid)):
        mutated = bytearray(valid)
        mutated[i] ^= 0xFF
        try:
            cls.from_bytes(bytes(mutated))
        except Ros1DecodeError:
            pass


def test_huge_declared_length_is_refused_without_allocating():
    with pytest.raises(Ros1DecodeError, match="Invalid string length 2147483647"):
        JointState.from_bytes(bytes(12) + b"\xff\xff\xff\x7f")
    with pytest.raises(Ros1DecodeError, match="Invalid sequence length 2147483647"):
        JointState.from_bytes(bytes(16) + b"\xff\xff\xff\x7f" + bytes(8))


def test_bool_reads_like_genpy_and_bad_utf8_is_a_decode_error():
    # genpy and roscpp read any non-zero byte as true; so does rosbags.
    assert Bool.from_bytes(b"\x02") == Bool(True)
    with pytest.raises(Ros1DecodeError, match="std_msgs/Header: .*'utf-8' codec"):
        Header.from_bytes(bytes(12) + b"\x01\x00\x00\x00\xff")


def test_values_that_do_not_fit_are_encode_errors():
    with pytest.raises(Ros1EncodeError, match="AssemblyState: .*0 <= number <= 255"):
        AssemblyState(estop_button=300).to_bytes()
    with pytest.raises(Ros1EncodeError, match="JointCommand: .*number <= 2147483647"):
        JointCommand(mode=2**40).to_bytes()
    with pytest.raises(Ros1EncodeError, match="JointCommand: "):
        JointCommand(command=("a",)).to_bytes()
    with pytest.raises(Ros1EncodeError, match="Header: time secs 4294967296 is not a uint32"):
        Header(stamp=Time(2**32)).to_bytes()


def test_time_keeps_ros1_unsigned_seconds():
    # ROS 1 time is uint32 secs (rosbags' store holds it as int32 sec: the same bytes).
    msg = Header(stamp=Time(2**31 + 5, 7))
    assert msg.to_bytes().hex() == U32[0] + "05000080" + U32[7] + U32[0]
    assert Header.from_bytes(msg.to_bytes()) == msg
