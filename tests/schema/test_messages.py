"""Bus schema: round trips, bounds, the topic table, schema evolution."""

from __future__ import annotations

import math

import msgspec
import pytest

import bus_schema
from bus_schema import TOPICS, DecodeError, EncodeError, decode, encode, encode_for, messages as m, topics
from tests.samples import SAMPLES

TOPIC_IDS = [t.suffix for t in TOPICS]


@pytest.mark.parametrize("topic", TOPICS, ids=TOPIC_IDS)
def test_round_trip_every_type(topic):
    original = SAMPLES[topic.suffix]
    data = encode_for(topic, original)
    assert decode(topic, data) == original


@pytest.mark.parametrize("topic", TOPICS, ids=TOPIC_IDS)
def test_every_message_has_the_common_header(topic):
    fields = topic.type.__struct_fields__
    assert fields[:3] == ("seq", "stamp_ns", "source")
    assert topic.type.__struct_config__.frozen


def test_keys_are_under_the_versioned_prefix_and_unique():
    keys = [t.key() for t in TOPICS]
    assert len(set(keys)) == len(keys) == 22
    assert all(k.startswith(f"handover/v{bus_schema.SCHEMA_VERSION}/") for k in keys)
    assert topics.topic_for_key("handover/v1/robot/joint_state") is topics.JOINT_STATE
    assert topics.topic_for_key("handover/v2/robot/joint_state") is None
    assert topics.topic_for_key("other/prefix/robot/joint_state", "other/prefix") is topics.JOINT_STATE
    assert topics.alive_key("bridge") == "handover/v1/alive/bridge"


def test_design_keys_all_present():
    wanted = {"robot/joint_state", "robot/joint_command", "sensors/wrist_wrench", "sensors/object_motion",
              "perception/skeleton", "perception/depth", "perception/human", "perception/object",
              "planner/transfer", "motion/goal", "motion/status", "motion/stop", "gripper/command",
              "gripper/state", "gripper/release", "supervisor/state", "sim/truth"}
    # Beyond DESIGN §4: the supervisor's episode summary, every service's heartbeat, the
    # simulated Kinect's ground truth and the simulation clock's steps and answers.
    assert {t.suffix for t in TOPICS} == wanted | {"supervisor/episode", "runtime/heartbeat", "sim/kinect_truth",
                                                   "sim/clock", "sim/clock_ready"}


def test_safety_keys_are_the_safety_relevant_ones():
    safety = {t.suffix for t in TOPICS if t.delivery == "safety"}
    assert safety == {"robot/joint_command", "motion/goal", "motion/stop", "gripper/command", "gripper/release"}


def _raw(topic, **overrides):
    doc = msgspec.to_builtins(SAMPLES[topic.suffix])
    doc.update(overrides)
    return msgspec.msgpack.encode(doc)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e300])
def test_non_finite_and_absurd_floats_rejected(bad):
    with pytest.raises(DecodeError, match=r"force_n\[1\]"):
        decode(topics.WRIST_WRENCH, _raw(topics.WRIST_WRENCH, force_n=[0.0, bad, 0.0]))


def test_grip_force_above_pinch_limit_rejected():
    with pytest.raises(DecodeError, match="140"):
        decode(topics.GRIPPER_COMMAND, _raw(topics.GRIPPER_COMMAND, grip_force_n=141.0))
    assert decode(topics.GRIPPER_COMMAND, _raw(topics.GRIPPER_COMMAND, grip_force_n=140.0)).grip_force_n == 140.0



def test_a_negative_finger_position_is_rejected():
    """The finger position is measured from fully open: never negative (issue 17)."""
    with pytest.raises(DecodeError, match="position_m"):
        decode(topics.GRIPPER_COMMAND, _raw(topics.GRIPPER_COMMAND, grip_force_n=5.0, position_m=-1.0))
    ok = decode(topics.GRIPPER_COMMAND, _raw(topics.GRIPPER_COMMAND, grip_force_n=5.0, position_m=0.0))
    assert ok.position_m == 0.0


@pytest.mark.parametrize("field,value,match", [
    ("seq", -1, "seq"),
    ("stamp_ns", "yesterday", "stamp_ns"),
    ("source", "", "source"),
    ("source", "x" * 65, "source"),
    ("source", "Bad Name!", "source"),
    ("names", ["j"] * 33, "names"),
    ("position_rad", ["a"] * 7, "position_rad"),
    ("backend", "ros2", "backend"),
])
def test_bad_joint_state_fields_rejected(field, value, match):
    with pytest.raises(DecodeError, match=match):
        decode(topics.JOINT_STATE, _raw(topics.JOINT_STATE, **{field: value}))


def test_missing_required_field_rejected():
    doc = msgspec.to_builtins(SAMPLES["motion/stop"])
    del doc["reason"]
    with pytest.raises(DecodeError, match="reason"):
        decode(topics.MOTION_STOP, msgspec.msgpack.encode(doc))


def test_depth_image_size_must_match():
    with pytest.raises(DecodeError, match="2\\*width\\*height"):
        decode(topics.DEPTH, _raw(topics.DEPTH, depth_mm=b"\x00" * 23))


def test_oversize_payload_rejected_before_decoding():
    with pytest.raises(DecodeError, match="cap"):
        decode(topics.SUPERVISOR_STATE, b"\x00" * (bus_schema.MAX_PAYLOAD_BYTES + 1))


def test_encode_refuses_wrong_type_and_oversize():
    with pytest.raises(EncodeError, match="carries JointState"):
        encode_for(topics.JOINT_STATE, SAMPLES["motion/stop"])
    huge_reason = m.MotionStop(seq=0, stamp_ns=0, source="t", reason="x" * (2 << 20))
    with pytest.raises(EncodeError, match="bus cap"):
        encode(huge_reason)


def test_numpy_values_encode_as_plain_numbers():
    np = pytest.importorskip("numpy")
    msg = m.WristWrench(seq=0, stamp_ns=0, source="t", force_n=tuple(np.array([1.0, 2.0, 3.0])))
    assert decode(topics.WRIST_WRENCH, encode(msg)).force_n == (1.0, 2.0, 3.0)


# --------------------------------------------------------------------------- evolution


class StopV1(msgspec.Struct, frozen=True, kw_only=True):
    """A former version of MotionStop: no `protective` field."""

    seq: int
    stamp_ns: int
    source: str
    reason: str


class StopV3(m.MotionStop, frozen=True, kw_only=True):
    """A future version of MotionStop with an added field (with a default, as the rules say)."""

    initiated_by_human: bool = False


def test_old_sender_new_receiver_gets_defaults():
    old = msgspec.msgpack.encode(StopV1(seq=1, stamp_ns=2, source="supervisor", reason="release"))
    new = decode(topics.MOTION_STOP, old)
    assert new.reason == "release" and new.protective is False


def test_new_sender_old_receiver_ignores_added_field():
    future = msgspec.msgpack.encode(StopV3(seq=1, stamp_ns=2, source="supervisor", reason="fault",
                                           protective=True, initiated_by_human=True))
    now = decode(topics.MOTION_STOP, future)
    assert now == m.MotionStop(seq=1, stamp_ns=2, source="supervisor", reason="fault", protective=True)
    old = msgspec.msgpack.Decoder(StopV1).decode(future)
    assert old.reason == "fault"


def test_every_field_is_bounded():
    """Every number carries bounds (so NaN/inf never decode); every str/list/bytes a max length."""
    from msgspec import inspect as mi

    def check(t, path):
        if isinstance(t, mi.FloatType):
            assert t.ge is not None or t.gt is not None, f"{path} has no lower bound"
            assert t.le is not None or t.lt is not None, f"{path} has no upper bound"
        elif isinstance(t, mi.IntType):
            assert (t.ge is not None or t.gt is not None) and (t.le is not None or t.lt is not None), path
        elif isinstance(t, mi.StrType):
            assert t.max_length is not None, f"{path} string has no max_length"
        elif isinstance(t, (mi.ListType, mi.VarTupleType)):
            assert t.max_length is not None, f"{path} list has no max_length"
            check(t.item_type, path + "[]")
        elif isinstance(t, mi.TupleType):
            for i, item in enumerate(t.item_types):
                check(item, f"{path}[{i}]")
        elif isinstance(t, mi.UnionType):
            for item in t.types:
                check(item, path)
        elif isinstance(t, mi.StructType):
            for f in t.fields:
                check(f.type, f"{path}.{f.name}")
        elif isinstance(t, mi.BytesType):
            assert t.max_length is not None, f"{path} bytes has no max_length"

    for topic in TOPICS:
        check(mi.type_info(topic.type), topic.type.__name__)
