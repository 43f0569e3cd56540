"""The bridge's config: the Kinect moved out, the scene receiver's body stays."""

from __future__ import annotations

import pytest

from services.bridge.backend import make_backend
from services.bridge.cli import main as bridge_main
from services.bridge.config import ContactConfig, parse_config
from services.bridge.errors import BridgeConfigError


def test_the_kinect_table_moved_out_of_the_bridge():
    with pytest.raises(BridgeConfigError, match=r"services\.kinect\.config"):
        parse_config({"kinect": {"enabled": True}})
    assert parse_config({}).stop_wakes_loop


def test_the_scene_receivers_body_comes_from_the_contact_table():
    backend = make_backend("sim", contact=ContactConfig(enabled=True, scenario="handover", posture="sitting",
                                                       height_m=1.6))
    size = backend.scene.body.size
    assert (size.posture, size.height_m) == ("sitting", 1.6)


def test_bridge_cli_no_longer_takes_kinect_flags(capsys):
    with pytest.raises(SystemExit) as exc:
        bridge_main(["--kinect"])
    assert exc.value.code == 2
    assert "--kinect" in capsys.readouterr().err


def test_the_scene_takes_the_hand_reach_and_the_force_sensor_noise_from_the_contact_table():
    backend = make_backend("sim", contact=ContactConfig(enabled=True, scenario="handover", hand_reach_duration_s=0.7,
                                                       ft_noise_std_n=0.2, ft_bias_std_n=0.0))
    assert backend.scene.params.reach_duration_s == 0.7
    sensors = backend.scene._config.sensors
    assert (sensors.ft_noise_std_n, sensors.ft_bias_std_n) == (0.2, 0.0)


@pytest.mark.parametrize("key, value", [("hand_reach_duration_s", 0.1), ("ft_noise_std_n", -0.01),
                                        ("ft_bias_std_n", 6.0)])
def test_out_of_range_scene_values_are_refused_with_their_key(key, value):
    with pytest.raises(BridgeConfigError, match=key):
        parse_config({"contact": {key: value}})
