"""Recorder's message → entity mapping."""

from __future__ import annotations

from bus_schema import TOPICS, topics
from services.recorder.core import event_key, message_rows, numeric_fields
from tests.samples import SAMPLES


def test_numeric_fields_flatten_tuples_and_skip_header():
    fields = dict(numeric_fields(SAMPLES["sensors/wrist_wrench"]))
    assert fields == {"force_n/0": 1.5, "force_n/1": -2.0, "force_n/2": 0.25,
                      "torque_nm/0": 0.01, "torque_nm/1": 0.02, "torque_nm/2": -0.03}


def test_every_topic_maps_to_entities():
    for topic in TOPICS:
        rows = message_rows(topic, SAMPLES[topic.suffix])
        logged = rows.scalars + rows.points + rows.logs
        assert logged, topic.suffix
        assert all(isinstance(path, str) and path for path, _ in logged)


def test_joint_state_gets_one_series_per_joint():
    paths = [p for p, _ in message_rows(topics.JOINT_STATE, SAMPLES["robot/joint_state"]).scalars]
    assert sum(p.startswith("robot/joint_position/") for p in paths) == 7
    assert "robot/joint_position/right_e1" in paths


def test_events_only_when_they_change():
    state = SAMPLES["supervisor/state"]
    assert event_key(state) == ("transfer", "reached")
    assert any(p == "events" for p, _ in message_rows(topics.SUPERVISOR_STATE, state).logs)
    assert not any(p == "events" for p, _ in message_rows(topics.SUPERVISOR_STATE, state, log_event_text=False).logs)
    assert event_key(SAMPLES["robot/joint_state"]) is None
