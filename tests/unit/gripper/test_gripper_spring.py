"""Eq 3.21 spring: force <-> position."""

import numpy as np
import pytest

from services.gripper.errors import GripperError
from services.gripper.spring import GripSpring


def test_force_by_hand():
    s = GripSpring(stiffness_n_m=500.0, contact_position_m=0.02, max_position_m=0.1)
    assert s.force_n(0.02) == 0.0
    assert s.force_n(0.01) == 0.0
    assert s.force_n(0.03) == pytest.approx(5.0)  # 5 N/cm × 1 cm
    np.testing.assert_allclose(s.force_n([0.0, 0.04]), [0.0, 10.0])


def test_position_inverts_force_and_saturates():
    s = GripSpring(contact_position_m=0.02, max_position_m=0.1)
    forces = np.array([0.0, 1.0, 7.5, 39.0])
    np.testing.assert_allclose(s.force_n(s.position_m(forces)), forces)
    assert s.position_m(-3.0) == pytest.approx(0.02)
    assert s.max_force_n == pytest.approx(40.0)
    assert s.position_m(100.0) == pytest.approx(0.1)


def test_bad_spring():
    with pytest.raises(GripperError):
        GripSpring(stiffness_n_m=0.0)
    with pytest.raises(GripperError):
        GripSpring(contact_position_m=0.1, max_position_m=0.05)
    with pytest.raises(GripperError):
        GripSpring().position_m(float("nan"))
