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
