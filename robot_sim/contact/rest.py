"""Plant steps that change nothing: the physics skipped while a one-episode plant rests.

A plant *rests* when one whole step (`robot_sim.contact.scalar_step.run_steps`) left every
variable of its physics bit for bit as it was: object position, velocity and acceleration,
stick/slip and pad state, the hand's position and velocity, the forces (pads, receiver,
wrist load), the mode, the actuator's finger and target. That happens, e.g., while the
object sits in the gripper before the receiver's contact (until then the handover scene's
plant has the `absent` receiver, whose hand is far away; the finger has settled). The
next step reads nothing else than that state, its reference sample and, every 40 ms, the
latched grip target; so while

- the receiver's reference sample is the same (bit-identical consecutive samples share one
  tuple in the plant's reference cache, so this is an identity check),
- a latch of the current command would leave the finger's target as it is,
- no step was taken elsewhere and the receiver was not replaced,

every further step would again change nothing, and `advance_scalar` replays only what a step
does besides the physics, exactly as the full step does it: the clock, the F/T samples (same
load, noise drawn in the same order), the optical sensor's accumulation (of a zero
displacement) and its reports. Outputs and state are those of full stepping, bit for bit
(`tests/unit/contact/test_fast_stepping.py`). The receiver holding the object in its hand
(a 1e-19 m dither of the hand's y) and a falling object never rest: they step in full.

*Sleep* (``plant.may_sleep``, off by default): where nobody judges the physics (the handover
scene between episodes, `robot_sim.handover_scene`), a plant that has stayed still for
`SLEEP_AFTER_TICKS` calls in a row (every speed ≤ `SLEEP_SPEED_M_S`, the object's acceleration
≤ `SLEEP_ACCEL_M_S2`, the finger on its target) is put to rest without the proof, as physics
engines put resting bodies to sleep: the receiver holding the object still, whose 1e-19 m
dither would otherwise be stepped at 1 kHz for ever. The sensors go on exactly as in a proven
rest (F/T samples of the frozen load with their noise, the optical sensor's reports); a new
reference sample, a grip command that moves the finger's target or ``may_sleep`` turned off
wakes it, and the physics steps in full again from the state it slept in.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from robot_sim.contact.scalar_step import run_steps

if TYPE_CHECKING:
    from robot_sim.contact.plant import ContactPlant
    from robot_sim.contact.receiver import ReceiverParams

__all__ = ["Rest", "advance_scalar", "reference_settled", "shared_repeats", "SLEEP_AFTER_TICKS",
           "SLEEP_SPEED_M_S", "SLEEP_ACCEL_M_S2"]

#: A sleeping plant's bound on every speed (object and hand, m/s) and on the object's acceleration (m/s²).
SLEEP_SPEED_M_S = 1e-9
SLEEP_ACCEL_M_S2 = 1e-6
#: Calls of `advance_scalar` in a row that end still before a plant may sleep (0.5 s at the bridge's 100 Hz).
SLEEP_AFTER_TICKS = 50

_PHYSICS = ("px", "py", "vx", "vy", "ax", "ay", "hx", "hy", "hvx", "hvy", "stuck", "left", "dropped", "mode",
            "grip_force_n", "pull_x", "pull_y", "wrist_x", "wrist_y", "grasp", "holds")


class Rest:
    """A fixed point: the reference sample it holds for, whether the optical sensor sees the
    object's surface there, the step index it is valid at, and whether a step proved it
    (False: a sleep, see the module docstring)."""

    __slots__ = ("reference", "visible", "step_index", "proven")

    def __init__(self, reference: tuple, visible: bool, step_index: int, proven: bool = True) -> None:
        self.reference, self.visible, self.step_index, self.proven = reference, visible, step_index, proven


def _physics(p: ContactPlant) -> tuple:
    act = p.actuator
    return tuple(getattr(p, name) for name in _PHYSICS) + (act.finger_m, act.target_m)


def _same_bits(a: object, b: object) -> bool:
    """Equal values of the same types, bit for bit (−0.0 is not 0.0, NaN never equal)."""
    if type(a) is float and type(b) is float:
        return a == b and (a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b))
    return a == b and repr(a) == repr(b)


def _may_rest(p: ContactPlant) -> bool:
    """Cheap test before a probe step: object, hand and finger still, no grip-command noise."""
    act = p.actuator
    return (p._grip_snr is None and p.vx == 0.0 and p.vy == 0.0 and p.hvx == 0.0 and p.hvy == 0.0
            and act.finger_m == act.target_m)


def _probe(p: ContactPlant, grip_command_n: float) -> Rest | None:
    """Run one full step; the rest it proves, or None."""
    before = _physics(p)
    k = p.step_index
    run_steps(p, grip_command_n, 1)
    after = _physics(p)
    if not _same_bits(before, after) or not all(math.isfinite(v) for v in after if isinstance(v, float)):
        return None
    return Rest(p._reference_at(k), _visible(p), p.step_index)


def _visible(p: ContactPlant) -> bool:
    """Whether the optical sensor sees the object's surface in the plant's state."""
    c, obj = p.config, p.config.obj
    finger = p.actuator.finger_m
    return (not p.left and abs(p.px) <= obj.optical_face_x_m and abs(p.py) <= obj.optical_face_y_m
            and (0.0 if -finger < 0.0 else -finger) <= c.sensors.optical_max_gap_m)


def _still(p: ContactPlant) -> bool:
    """Every speed within `SLEEP_SPEED_M_S`, the object's acceleration within `SLEEP_ACCEL_M_S2`,
    the finger on its target, no grip-command noise."""
    act, v, a = p.actuator, SLEEP_SPEED_M_S, SLEEP_ACCEL_M_S2
    return (p._grip_snr is None and act.finger_m == act.target_m and abs(p.vx) <= v and abs(p.vy) <= v
            and abs(p.hvx) <= v and abs(p.hvy) <= v and abs(p.ax) <= a and abs(p.ay) <= a)


def _rest_steps(p: ContactPlant, rest: Rest, n: int) -> int:
    """Replay up to `n` resting steps; the number left when the reference sample changed."""
    opt, ft = p.optical, p.ft
    ft_every, opt_every = p._ft_every, p._opt_every
    k, cache, base = p.step_index, p._ref_cache, p._ref_base
    acc_x, acc_y = opt._acc_x, opt._acc_y
    while n > 0:
        if 0 <= k - base < len(cache):
            reference = cache[k - base]
        else:
            reference = p._reference_at(k)
            cache, base = p._ref_cache, p._ref_base
        if reference is not rest.reference:
            break
        acc_x, acc_y = acc_x + 0.0, acc_y + 0.0  # the full step's accumulation of a zero displacement
        k += 1
        n -= 1
        if k % ft_every == 0:
            ft.sample(p.wrist_x, p.wrist_y)
            p.ft_fresh = True
        if k % opt_every == 0:
            opt._acc_x, opt._acc_y = acc_x, acc_y
            opt.report(rest.visible)
            acc_x, acc_y, p.optical_fresh = opt._acc_x, opt._acc_y, True
    opt._acc_x, opt._acc_y, p.step_index = acc_x, acc_y, k
    rest.step_index = k
    return n


def advance_scalar(p: ContactPlant, grip_command_n: float, n: int) -> None:
    """Run `n` plant steps with the grip command `grip_command_n` (N) on a one-episode plant:
    replayed while it rests (see the module docstring), in full otherwise."""
    rest = p._rest
    # A latch of this command (every 40 ms) must leave the finger's target as it is.
    latch_keeps = _same_bits(p.actuator.target_for(grip_command_n), p.actuator.target_m)
    if rest is not None and (rest.step_index != p.step_index or not latch_keeps
                             or not (rest.proven or p.may_sleep)):
        rest = p._rest = None
    if rest is None and n > 0 and latch_keeps:
        if _may_rest(p):
            rest = p._rest = _probe(p, grip_command_n)
            n -= 1
        elif p.may_sleep and p.still_ticks >= SLEEP_AFTER_TICKS:
            rest = p._rest = Rest(p._reference_at(p.step_index), _visible(p), p.step_index, proven=False)
    if rest is not None:
        n = _rest_steps(p, rest, n)
        if n:
            p._rest = None
            if not rest.proven:  # woken by a new reference sample: still again before another sleep
                p.still_ticks = 0
    if n:
        run_steps(p, grip_command_n, n)
        p.still_ticks = p.still_ticks + 1 if p.may_sleep and _still(p) else 0


def shared_repeats(columns: Sequence[np.ndarray], previous: list[tuple]) -> list[tuple]:
    """Reference samples as tuples of floats from their six columns (arrays of shape (m,)),
    a sample bit-identical to the one before it (`previous`: the last one of the preceding
    block, if any) being the same tuple object: a resting plant checks its reference by
    identity."""
    out = list(zip(*[c.tolist() for c in columns]))
    bits = np.stack(columns, axis=1).view(np.uint64)
    if previous and np.array_equal(np.array(previous[0], dtype=float).view(np.uint64), bits[0]):
        out[0] = previous[0]
    for j in (np.flatnonzero((bits[1:] == bits[:-1]).all(axis=1)) + 1).tolist():
        out[j] = out[j - 1]
    return out


def reference_settled(receiver: ReceiverParams, t_s: float) -> bool:
    """Whether every window of the receiver's behaviour (reach, pull, retract, grasp, let-go, lift)
    has ended by time `t_s` (s) or never starts: its reference (a function of the windows'
    progress τ = clip((t − start)/duration, 0, 1) only, see `reference`) is then the same,
    bit for bit, at every later time. One episode (floats) only."""
    p = receiver
    for start_s, duration_s in ((p.reach_start_s, p.reach_duration_s), (p.pull_start_s, p.pull_duration_s),
                                (p.retract_start_s, p.retract_duration_s), (p.grasp_start_s, p.grasp_build_s),
                                (p.letgo_start_s, p.letgo_duration_s), (p.lift_start_s, p.lift_duration_s)):
        if start_s != math.inf and np.clip((t_s - start_s) / duration_s, 0.0, 1.0) != 1.0:
            return False
    return True
