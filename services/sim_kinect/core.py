"""Pure logic of the simulated Kinect: what to render from the latest bus inputs, and the
bus fields of a rendered frame. No I/O: `services.sim_kinect.node` does the bus wiring.

Inputs (all optional and possibly stale; the renderer uses the latest of each):

- the arm posture, from `robot/joint_state` (names → the arm's joint order, rad);
- in the ``handover`` scene, the receiver's right hand and the object centre, from
  `sim/truth` (m, `base` frame).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from handover_model import robots
from services.runtime.repeat import RepeatGate, settled_key
from services.sim_kinect.config import KinectConfig

#: Bound of the `Vec3M` bus fields, m.
POSITION_BOUND_M = 100.0


def make_kinect_sim(config: KinectConfig) -> Any:
    """The seeded `robot_sim.kinect.KinectSim` for `config` (loads the arm's model: ~1 s)."""
    from robot_sim.kinect import KinectScenario, KinectSim

    target: tuple[float, float, float] | None = None
    if config.hand_target_base_m:  # three values (checked when the config is loaded)
        x, y, z = config.hand_target_base_m
        target = (x, y, z)
    scenario = KinectScenario(height_m=config.height_m, posture=config.posture,
                              hand_target_base_m=target, reach_start_s=config.reach_start_s,
                              reach_duration_s=config.reach_duration_s)
    return KinectSim(config.seed, scenario)


def arm_posture_rad(names: Sequence[str], position_rad: Sequence[float]) -> np.ndarray | None:
    """The active arm's joints (n,), rad, in its description's order, from a joint state
    with any joint order; None when one of its joints is missing, a value is not finite or
    names and values differ in number."""
    if len(names) != len(position_rad):
        return None
    by_name = dict(zip(names, position_rad, strict=True))
    try:
        q = np.array([float(by_name[n]) for n in robots.active().joints])
    except KeyError:
        return None
    return q if np.all(np.isfinite(q)) else None


@dataclass(frozen=True)
class SceneInput:
    """What another model says about the receiver's hand and the object (m, `base`); None
    fields: the Kinect's own model decides (scripted reach, object on the table)."""

    right_hand_m: np.ndarray | None = None
    object_position_m: np.ndarray | None = None


def scene_input(scene: str, receiver_hand_position_m: Sequence[float] | None,
                object_position_m: Sequence[float] | None) -> SceneInput:
    """The scene input of one frame.

    Args:
        scene: ``handover`` (follow `sim/truth`) or ``none`` (ignore it).
        receiver_hand_position_m, object_position_m: the latest `sim/truth` fields (m,
            `base`), None before the first `sim/truth`.
    """
    if scene != "handover" or receiver_hand_position_m is None or object_position_m is None:
        return SceneInput()
    hand = np.asarray(receiver_hand_position_m, float)
    obj = np.asarray(object_position_m, float)
    if hand.shape != (3,) or obj.shape != (3,) or not (np.all(np.isfinite(hand)) and np.all(np.isfinite(obj))):
        return SceneInput()
    return SceneInput(hand.copy(), obj.copy())


def _bounded(value: float) -> float:
    """`value` within ±`POSITION_BOUND_M`: NaN → 0, ±inf → ±bound (NumPy's ``nan_to_num``
    then ``clip``, in plain floats: three values cost less in Python than through NumPy)."""
    if -POSITION_BOUND_M <= value <= POSITION_BOUND_M:
        return value
    if value != value:  # NaN
        return 0.0
    return POSITION_BOUND_M if value > 0.0 else -POSITION_BOUND_M


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    x, y, z = np.asarray(v, float).tolist()
    return (_bounded(x), _bounded(y), _bounded(z))


#: `sim/kinect_truth` goes out when the body moved by more than 1 nm (`settled_key`) or this
#: often, s: a still receiver's truth is not repeated 30 times a second to the recorder.
KINECT_TRUTH_REPEAT_S = 0.1


def truth_fields(frame: Any) -> dict[str, tuple[float, float, float]]:
    """`bus_schema.messages.KinectTruth` fields of a `robot_sim.kinect.KinectFrame`: the true
    right hand and torso of the body it rendered (m, `base`)."""
    return {"hand_position_m": _vec(frame.truth.right_hand_m),
            "torso_position_m": _vec(frame.truth.joints_m["torso"])}


class TruthGate:
    """Which frames' `sim/kinect_truth` go out: those whose body moved by more than 1 nm
    (`settled_key`), and one every `KINECT_TRUTH_REPEAT_S` of a still body."""

    def __init__(self, repeat_s: float = KINECT_TRUTH_REPEAT_S) -> None:
        self._gate = RepeatGate(repeat_s)

    def due(self, frame: Any, now_s: float) -> dict[str, tuple[float, float, float]] | None:
        """The truth fields of `frame` if they must be published at `now_s` (monotonic s), else None."""
        fields = truth_fields(frame)
        return fields if self._gate.due(settled_key(fields.values()), now_s) else None
