"""Which person in view is the receiver (pure: no I/O).

Rule (the ROS 1 path's, `services.tracker.ros1.skeleton.ReceiverChooser`, for a camera that
gives no person ids): only people whose torso is within ``max_distance_m`` of the transfer
region's centre (horizontally, in `base`) can be the receiver. The receiver stays the same
person from frame to frame (the person whose torso is nearest the receiver's last torso,
within `SAME_PERSON_M`) unless another is nearer the centre by more than ``margin_m``; with no
receiver yet (or the receiver gone), the person nearest the centre becomes it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: A torso this close to the receiver's torso of the previous frame is the same person, m.
SAME_PERSON_M = 0.4


class ReceiverRule:
    """The receiver among each frame's people, stable across frames (see the module docstring).

    Args:
        centre_m: (3,) the transfer region's centre, m, `base`.
        max_distance_m: farther from it (horizontally) is never the receiver, m.
        margin_m: another person takes over only when nearer the centre by more than this, m.
    """

    def __init__(self, centre_m: Sequence[float], max_distance_m: float, margin_m: float) -> None:
        self.centre_xy = np.asarray(centre_m, float)[:2]
        self.max_distance_m, self.margin_m = max_distance_m, margin_m
        self.receiver_torso_m: np.ndarray | None = None
        self.switches = 0

    def distance_m(self, torso_m: np.ndarray) -> float:
        """Horizontal distance (m) of a torso from the transfer centre."""
        return float(np.linalg.norm(np.asarray(torso_m, float)[:2] - self.centre_xy))

    def choose(self, torsos_m: Sequence[np.ndarray]) -> int | None:
        """The receiver's index among this frame's torsos ((3,) each, `base`), or None.

        A new receiver (none before, or another person than the last frame's) counts as a switch.
        """
        distances = [self.distance_m(t) for t in torsos_m]
        candidates = [i for i, d in enumerate(distances) if d <= self.max_distance_m]
        if not candidates:
            self.receiver_torso_m = None
            return None
        best = min(candidates, key=lambda i: (distances[i], i))
        same = None
        if self.receiver_torso_m is not None:
            gaps = {i: float(np.linalg.norm(np.asarray(torsos_m[i], float) - self.receiver_torso_m))
                    for i in candidates}
            nearest = min(gaps, key=lambda i: gaps[i])
            if gaps[nearest] <= SAME_PERSON_M:
                same = nearest
        if same is not None and distances[best] >= distances[same] - self.margin_m:
            chosen = same
        else:
            chosen = best
            self.switches += 1
        self.receiver_torso_m = np.asarray(torsos_m[chosen], float).copy()
        return chosen

    def reset(self) -> None:
        """Forget the receiver (nobody in view, or the camera lost)."""
        self.receiver_torso_m = None
