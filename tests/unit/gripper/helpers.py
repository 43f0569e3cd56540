"""Small helpers for the gripper tests: build SensorSamples by hand."""

from __future__ import annotations

import numpy as np

from handover_model.grip import SensorSample


def sample(time_s=0.0, fx=0.0, fy=0.0, ay=0.0, vx=0.0, vy=0.0, n=None):
    """A SensorSample; every field is broadcast to (n,), n taken from the array arguments."""
    arrays = [np.atleast_1d(np.asarray(v, dtype=float)) for v in (fx, fy, ay, vx, vy)]
    size = n if n is not None else max(a.size for a in arrays)
    fx_a, fy_a, ay_a, vx_a, vy_a = (np.broadcast_to(a, (size,)).copy() for a in arrays)
    return SensorSample(
        time_s=time_s, force_x_n=fx_a, force_y_n=fy_a, accel_y_m_s2=ay_a,
        slip_velocity_x_m_s=vx_a, slip_velocity_y_m_s=vy_a,
        optical_valid=np.ones(size, dtype=bool), grip_force_n=np.zeros(size),
    )
