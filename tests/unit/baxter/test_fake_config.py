"""The fake Baxter's config: its kinect table gets the kinect service's own checks."""

from __future__ import annotations

import pytest

from services.bridge.baxter.errors import BaxterConfigError
from services.bridge.baxter.fake import parse_fake_config


def test_a_two_value_hand_target_is_refused_naming_the_table():
    with pytest.raises(BaxterConfigError, match=r"fake_baxter\.config\.kinect\]: hand_target_base_m needs 3"):
        parse_fake_config({"kinect": {"enabled": True, "hand_target_base_m": [0.5, 0.1]}})


def test_a_valid_kinect_table_is_kept():
    cfg = parse_fake_config({"kinect": {"enabled": True, "posture": "sitting", "hand_target_base_m": [0.5, 0.1, 0.2]}})
    assert cfg.kinect.enabled and cfg.kinect.posture == "sitting"
    assert tuple(cfg.kinect.hand_target_base_m) == (0.5, 0.1, 0.2)
