"""Shared fixtures: one PlaCo model per test session (loading Baxter takes ~1.5 s)."""

from __future__ import annotations

import numpy as np
import pytest

from services.motion.config import MotionConfig


@pytest.fixture(scope="session")
def motion_config() -> MotionConfig:
    return MotionConfig()


@pytest.fixture(scope="session")
def arm_ik(motion_config):
    from services.motion.ik import ArmIk

    return ArmIk(motion_config)


@pytest.fixture(scope="session")
def pin_arm():
    """Pinocchio's model of the arm (independent FK for checks)."""
    from handover_model.robots import baxter

    return baxter.arm_model()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)
