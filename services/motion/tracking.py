"""Live tracking of a Cartesian reach: one PlaCo IK step per control tick.

The path time advances by the (clamped) tick period, not the wall clock: a tick that comes
late (the process starved of CPU) pauses the path instead of making the target jump further
than one IK step can follow. After the path's end the IK gets `planning.CONVERGE_TICKS`
more ticks to converge on the goal pose; one that ends within `transfer_end_tolerance_m` of it
then is held there (`planning.ends_close_enough`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.motion.config import MotionConfig
from services.motion.errors import IkError
from services.motion.ik import ArmIk
from services.motion.paths import CartesianReach
from services.motion.planning import CONVERGE_TICKS, ends_close_enough


@dataclass(frozen=True)
class TrackingStep:
    """Outcome of one IK step along the reach.

    Attributes:
        q_rad: the joints to command (n,), rad; None when the IK step failed.
        failure: why tracking failed ('' while it goes well): the IK raised, fell behind the
            path, or did not converge on the goal pose after the path's end.
        progress: path time over path duration, in [0, 1) while on the path.
        on_path: the path has not ended yet.
        converged: after the path's end, the tool is within the goal tolerances.
    """

    q_rad: np.ndarray | None
    failure: str = ""
    progress: float = 0.0
    on_path: bool = False
    converged: bool = False


class CartesianTracker:
    """Follows one `CartesianReach` from the joints `q0_rad` where it was planned.

    Args:
        config: service configuration (tracking and goal tolerances).
        ik: the PlaCo IK of the arm.
        reach: the planned reach.
        q0_rad: joints (n,), rad, at the reach's start.
    """

    def __init__(self, config: MotionConfig, ik: ArmIk, reach: CartesianReach, q0_rad: np.ndarray) -> None:
        self.config = config
        self.ik = ik
        self.reach = reach
        self.q0_rad = q0_rad.copy()
        self.path_time_s = 0.0
        self._started = False
        self._ticks_after_end = 0

    @property
    def remaining_s(self) -> float:
        """Path time left until the reach's end, s (0 after it)."""
        return max(0.0, self.reach.duration_s - self.path_time_s)

    def advance_time(self, dt_s: float) -> None:
        """Move the path time on by one tick of `dt_s` s (the first tick stays at time 0)."""
        if self._started:
            self.path_time_s += dt_s
        self._started = True

    def step(self, q_commanded_rad: np.ndarray | None, dt_s: float) -> TrackingStep:
        """One IK step toward the path's pose at the current path time, from the last
        commanded joints (from `q0_rad` at time 0 or before any command)."""
        cfg = self.config
        elapsed = self.path_time_s
        p, rotation, _ = self.reach.pose_at(elapsed)
        q_from = self.q0_rad if elapsed <= 0.0 or q_commanded_rad is None else q_commanded_rad
        try:
            result = self.ik.track_step(p, rotation, q_from, dt_s)
        except IkError as exc:
            return TrackingStep(None, failure=f"IK failed while tracking the path: {exc}")
        if elapsed < self.reach.duration_s:
            if (result.position_error_m > cfg.tracking_tolerance_m
                    or result.orientation_error_rad > cfg.tracking_tolerance_rad):
                return TrackingStep(
                    result.q_rad, failure=f"IK fell {result.position_error_m * 1000:.0f} mm behind the path"
                )
            return TrackingStep(result.q_rad, progress=elapsed / self.reach.duration_s, on_path=True)
        self._ticks_after_end += 1
        converged = (result.position_error_m <= cfg.position_tolerance_m
                     and result.orientation_error_rad <= cfg.orientation_tolerance_rad)
        if not converged and self._ticks_after_end > CONVERGE_TICKS:
            if ends_close_enough(result.position_error_m, result.orientation_error_rad, cfg):
                return TrackingStep(result.q_rad, converged=True)  # the IK's best, near enough
            return TrackingStep(
                result.q_rad, failure=f"IK ended {result.position_error_m * 1000:.1f} mm from the goal"
            )
        return TrackingStep(result.q_rad, converged=converged)
