"""Recorder's message → entity mapping: whole messages per key (`bus_columns`), review entities
(`derived`), events."""

from __future__ import annotations

import msgspec
import numpy as np
import pyarrow as pa
import rerun as rr

from bus_schema import TOPICS, messages as m, topics
from services.recorder.bus_columns import bus_record_batch, field_plans, numeric_series
from services.recorder.core import event_key, numeric_fields
from services.recorder.derived import derived_columns
from services.recorder.review import EventLog
from tests.samples import SAMPLES


def _batch(topic, msgs):
    stamps = np.arange(len(msgs), dtype=np.int64) + 10
    return bus_record_batch(topic, msgs, stamps, stamps + 1)


def test_numeric_fields_flatten_tuples_and_skip_header():
    fields = dict(numeric_fields(SAMPLES["sensors/wrist_wrench"]))
    assert fields == {"force_n/0": 1.5, "force_n/1": -2.0, "force_n/2": 0.25,
                      "torque_nm/0": 0.01, "torque_nm/1": 0.02, "torque_nm/2": -0.03}


def test_every_field_of_every_topic_is_a_column_with_the_message_values():
    for topic in TOPICS:
        msg = SAMPLES[topic.suffix]
        batch = _batch(topic, [msg, msg])
        assert batch.num_rows == 2
        assert batch.column("time").cast(pa.int64()).to_pylist() == [10, 11]
        assert batch.column("receive_time").cast(pa.int64()).to_pylist() == [11, 12]
        stored = {p.name for p in field_plans(topic.type)}
        # Every field but the stamp (the time index) and raw bytes (the depth image) is stored.
        expected = set(msg.__struct_fields__) - {"stamp_ns", "depth_mm"}
        assert stored == expected, topic.suffix
        for plan in field_plans(topic.type):
            column = batch.column(f"/bus/{topic.suffix}:{plan.component}")
            assert column.to_pylist()[0] == _builtin(getattr(msg, plan.name)), (topic.suffix, plan.name)


def _builtin(value):
    value = msgspec.json.decode(msgspec.json.encode(value))  # tuples → lists, structs → dicts
    return list(value.items()) if isinstance(value, dict) else value  # Arrow maps: (key, value) pairs


def test_numeric_series_are_the_numeric_fields():
    """The plotted components are exactly those `numeric_fields` (and seq) name."""
    for topic in TOPICS:
        plotted = {p.name for p in field_plans(topic.type) if numeric_series(p)}
        named = {path.split("/")[0] for path, _ in numeric_fields(SAMPLES[topic.suffix])}
        assert plotted - {"seq"} >= named, topic.suffix


def test_tuples_are_instances_and_optional_fields_null():
    goal = SAMPLES["motion/goal"]
    batch = _batch(topics.MOTION_GOAL, [goal, msgspec.structs.replace(goal, position_base_m=None)])
    assert batch.column("/bus/motion/goal:MotionGoal:position_base_m").to_pylist() == [[0.6, -0.26, 0.1], None]
    wrench = _batch(topics.WRIST_WRENCH, [SAMPLES["sensors/wrist_wrench"]])
    assert wrench.schema.field("/bus/sensors/wrist_wrench:WristWrench:force_n").type == pa.list_(pa.float64())
    meta = wrench.schema.field("/bus/sensors/wrist_wrench:WristWrench:force_n").metadata
    assert meta[b"rerun:entity_path"] == b"/bus/sensors/wrist_wrench"
    assert meta[b"rerun:component"] == b"WristWrench:force_n"


def test_joint_state_gets_one_series_per_joint():
    msg = SAMPLES["robot/joint_state"]
    derived = {d.entity: d for d in derived_columns(topics.JOINT_STATE, [msg, msg, msg])}
    columns = derived["robot/joint_position"].columns
    scalars = next(c for c in columns if "Scalars:scalars" in str(c.component_descriptor()))
    rows = scalars.as_arrow_array().to_pylist()
    assert len(rows) == 3 and all(r == msg.position_rad for r in rows)


def test_review_entities_only_for_rows_that_have_them():
    human = SAMPLES["perception/human"]
    untracked = msgspec.structs.replace(human, tracked=False)
    derived = {d.entity: d for d in derived_columns(topics.HUMAN, [untracked, human, untracked])}
    assert set(derived) == {"world/human/hand_corrected", "world/human/hand_raw", "world/human/hand_correction"}
    assert derived["world/human/hand_corrected"].rows.tolist() == [1]
    assert derived_columns(topics.HUMAN, [untracked]) == []
    assert derived_columns(topics.WRIST_WRENCH, [SAMPLES["sensors/wrist_wrench"]]) == []  # plotted from bus/


def test_events_only_when_they_change():
    state = SAMPLES["supervisor/state"]
    assert event_key(state) == ("transfer", "reached")
    log = EventLog()
    rows, texts, _ = log.rows("supervisor/state", [state, state, msgspec.structs.replace(state, phase="release"),
                                                   state])
    assert rows == [0, 2, 3]
    assert texts[0] == "supervisor: transfer (reached)"
    assert log.rows("supervisor/state", [state]) == ([], [], [])  # unchanged since the last batch
    assert event_key(SAMPLES["robot/joint_state"]) is None
    stop = SAMPLES["motion/stop"]
    rows, _, levels = log.rows("motion/stop", [stop, msgspec.structs.replace(stop, seq=stop.seq + 1)])
    assert rows == [0, 1] and set(levels) == {rr.TextLogLevel.WARN}


def test_gripper_mode_codes():
    modes = [msgspec.structs.replace(SAMPLES["gripper/state"], mode=mode) for mode in ("grasp", "slip", "hold")]
    derived = derived_columns(topics.GRIPPER_STATE, modes)
    values = next(c for c in derived[0].columns).as_arrow_array().to_pylist()
    assert derived[0].entity == "signals/gripper_mode" and values == [[0.0], [1.0], [3.0]]
    assert isinstance(SAMPLES["gripper/state"], m.GripperState)
