"""The grip controller's interface: sensor sample, grip controller, modes (a shared contract).

The gripper service's controllers implement it; the contact simulator, the thesis model mode
and the bridge's sim backend run controllers through it. These names do not change without a
note in the changelog.

Frames and signs (DESIGN §5, thesis Fig. 15): the *gripper frame* of the transfer loop has
x along the pull, toward the receiver, and y DOWN. A positive `accel_y_m_s2` means the object
accelerates downward (falling). Forces measured at the wrist are the load the object puts on
the gripper: an object at rest in the gripper reads `force_y_n = W = M g > 0`,
`force_x_n = 0`; a receiver pulling toward itself makes `force_x_n > 0` (thesis eq 3.5,
F_s is the friction force between pads and object).

Every per-episode field is a float64 numpy array of shape (n_episodes,): a controller is
written once with numpy operations and serves one episode (n = 1, e.g. the bridge) and a
Monte-Carlo batch (n = 10 000) alike. Python floats also work wherever numpy accepts them.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Mode", "SensorSample", "GripController"]


class Mode(IntEnum):
    """System mode of thesis §3.4.1 (Fig. 16), judged from ground truth.

    GRASP: the object sticks to the pads (no relative motion, grip force > 0).
    SLIP: the object slides relative to the pads while the pads still press on it.
    RELEASE: the pads exert no force on the object (grip force zero, or the object has
    left the pads' extent).
    """

    GRASP = 0
    SLIP = 1
    RELEASE = 2


@dataclass(frozen=True, slots=True)
class SensorSample:
    """What a grip controller sees at one control tick (gripper frame, SI units).

    Attributes:
        time_s: episode time of this sample (s), shared by all episodes of a batch.
        force_x_n: F_sx, wrist force along x (toward the receiver), N, latest F/T sample
            (the F/T sensor runs at its own rate, 100 Hz by default; between samples the
            last value is held). Noise and bias included.
        force_y_n: F_sy, wrist force along y (down), N; equals the object weight at rest.
        accel_y_m_s2: a_y, downward acceleration of the object relative to the gripper,
            estimated from the optical (mouse-type) sensor, m/s²; 0 while the sensor
            cannot see the object surface.
        slip_velocity_x_m_s: object velocity relative to the pads along x, from the
            optical sensor, m/s.
        slip_velocity_y_m_s: object velocity relative to the pads along y (down), m/s.
        optical_valid: True where the object surface is over the optical sensor, so the
            two slip velocities and `accel_y_m_s2` mean something (bool array).
        grip_force_n: the gripper's own estimate of the grip force it applies, from its
            measured finger position through the spring of thesis eq 3.21, N.
        force_fresh: True if a new F/T sample arrived since the previous control tick.
        optical_fresh: True if a new optical report arrived since the previous tick.
    """

    time_s: float
    force_x_n: np.ndarray
    force_y_n: np.ndarray
    accel_y_m_s2: np.ndarray
    slip_velocity_x_m_s: np.ndarray
    slip_velocity_y_m_s: np.ndarray
    optical_valid: np.ndarray
    grip_force_n: np.ndarray
    force_fresh: bool = True
    optical_fresh: bool = True

    @property
    def n_episodes(self) -> int:
        """Number of episodes carried by this sample."""
        return int(np.shape(self.force_x_n)[0]) if np.ndim(self.force_x_n) else 1


@runtime_checkable
class GripController(Protocol):
    """A grip-force law, stepped at the controller's own period.

    `period_s` is the control period (s); the simulator calls `step` every `period_s`
    (rounded to whole plant steps) with the newest `SensorSample`. `step` returns the
    commanded grip force (N, ≥ 0), an array of shape (n_episodes,); the gripper actuator
    (spring + 25 Hz position loop + speed limit) then turns the command into the force
    really applied. `reset(n_episodes)` prepares a fresh run of `n_episodes` episodes.
    """

    period_s: float

    def reset(self, n_episodes: int = 1) -> None: ...

    def step(self, sample: SensorSample) -> np.ndarray: ...
