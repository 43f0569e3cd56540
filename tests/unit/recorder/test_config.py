"""`[services.recorder.config]`: defaults (no depth, primitive robot), validation, subscribed keys."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from bus_schema import TOPICS, topics
from services.recorder.config import RecorderConfig, parse_config, recorded_topics
from services.recorder.errors import RecorderError

DEPLOY = Path(__file__).resolve().parents[3] / "deploy"


def test_defaults_leave_depth_out_and_draw_the_robot_with_primitives():
    config = parse_config({})
    assert config == RecorderConfig()
    assert config.depth_every == 0 and config.robot_model == "primitives" and config.flush_period_s == 1.0
    assert topics.DEPTH not in recorded_topics(config.depth_every)
    assert set(recorded_topics(config.depth_every)) == set(TOPICS) - {topics.DEPTH, topics.CLOCK, topics.CLOCK_READY}


def test_depth_is_subscribed_only_when_asked():
    assert topics.DEPTH in recorded_topics(1)
    assert parse_config({"depth_every": 1}).depth_every == 1
    assert recorded_topics(3) == tuple(t for t in TOPICS if t not in (topics.CLOCK, topics.CLOCK_READY))


@pytest.mark.parametrize("table, words", [
    ({"depth_every": -1}, "depth_every"),
    ({"depth_every": 1.5}, "depth_every"),
    ({"robot_model": "cad"}, "robot_model"),
    ({"flush_period_s": 0.0}, "flush_period_s"),
    ({"colour": "red"}, "colour"),
    ({"urdf": True}, "robot_model"),  # the old key names its replacement
])
def test_bad_settings_name_the_key(table, words):
    with pytest.raises(RecorderError, match=words):
        parse_config(table)


@pytest.mark.parametrize("profile", sorted(p.name for p in DEPLOY.glob("*.toml")))
def test_every_deploy_profile_has_a_valid_recorder_table(profile):
    services = tomllib.loads((DEPLOY / profile).read_text()).get("services", {})
    table = services.get("recorder", {}).get("config", {})
    config = parse_config(table)
    assert config.depth_every == 0  # the profiles record no depth images by default
