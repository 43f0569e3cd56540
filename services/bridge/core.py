"""Pure logic of the bridge: joint-command validation and the command time-out.

No I/O and no clock of its own: callers pass the local monotonic time (s).

Rules:
- A command must name only joints of the arm, each once, with as many positions as names,
  every position inside the joint's limits (± a small tolerance). A command that breaks a
  rule is rejected with a one-line reason; the arm then holds where it is (no motion from a
  bad command) until the next valid command.
- A command may name a subset of the joints: the others keep their last target.
- When no valid command arrived for `command_timeout_s`, the arm holds its position
  (the default arm's own behaviour; 0.2 s by default).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from handover_model.robots import JointLimits


@dataclass(frozen=True)
class Decision:
    """What the arm should do this tick.

    Attributes:
        target_rad: the servo target (7,), or None to hold the current position.
        feedforward_rad_s: the commanded joint velocities (7,) (zeros when not given).
        holding: the arm holds (time-out, rejected command, or no command yet).
        reason: why it holds ("" when following commands).
    """

    target_rad: np.ndarray | None
    holding: bool
    reason: str
    feedforward_rad_s: np.ndarray | None = None


class CommandRejected(ValueError):
    """A joint command broke a rule (the message says which)."""


class CommandGate:
    """Validates joint commands and applies the command time-out.

    Args:
        joint_names: the arm's joints, in servo order.
        limits: their limits (rad).
        command_timeout_s: hold after this long without a valid command, s.
        limit_tolerance_rad: accepted excursion past a limit, rad.
        max_step_rad: a command whose target is farther than this from the previous target
            (from the measured position when there is none: holding, or the first command)
            is rejected (a jump, not a trajectory), rad; None: no such rule (the
            simulated arm); hardware backends whose robot would fault on a jump set it.
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        limits: JointLimits,
        command_timeout_s: float = 0.2,
        limit_tolerance_rad: float = 1e-3,
        max_step_rad: float | None = None,
    ) -> None:
        self.joint_names = tuple(joint_names)
        self._index = {name: i for i, name in enumerate(self.joint_names)}
        self.lower_rad = limits.lower_rad - limit_tolerance_rad
        self.upper_rad = limits.upper_rad + limit_tolerance_rad
        self._clip_lower = limits.lower_rad
        self._clip_upper = limits.upper_rad
        self.command_timeout_s = command_timeout_s
        self.max_step_rad = max_step_rad
        self._velocity_limit = limits.velocity_rad_s
        self._target_rad: np.ndarray | None = None
        self._feedforward_rad_s = np.zeros(len(self.joint_names))
        self._last_valid_s: float | None = None
        self._rejected_reason = ""
        self.accepted = 0
        self.rejected = 0

    def validate(self, names: Sequence[str], position_rad: Sequence[float],
                 velocity_rad_s: Sequence[float] = ()) -> list[tuple[int, float]]:
        """Check a command; return (joint index, position) pairs.

        Raises:
            CommandRejected: unknown or repeated joint, length mismatch, empty command,
                non-finite or out-of-limit position, velocity above the joint's limit.
        """
        if velocity_rad_s and len(velocity_rad_s) != len(names):
            raise CommandRejected(
                f"joint command has {len(names)} names but {len(velocity_rad_s)} velocities"
            )
        if len(names) != len(position_rad):
            raise CommandRejected(
                f"joint command has {len(names)} names but {len(position_rad)} positions"
            )
        if not names:
            raise CommandRejected("joint command names no joint")
        pairs: list[tuple[int, float]] = []
        seen: set[str] = set()
        for name, value in zip(names, position_rad, strict=True):
            index = self._index.get(name)
            if index is None:
                raise CommandRejected(
                    f"joint command names unknown joint {name!r} (this arm has {', '.join(self.joint_names)})"
                )
            if name in seen:
                raise CommandRejected(f"joint command names {name!r} twice")
            seen.add(name)
            value = float(value)
            if not np.isfinite(value) or not self.lower_rad[index] <= value <= self.upper_rad[index]:
                raise CommandRejected(
                    f"joint command {name}={value:.4f} rad is outside its limits "
                    f"[{self._clip_lower[index]:.4f}, {self._clip_upper[index]:.4f}] rad"
                )
            pairs.append((index, value))
        for (index, _), v in zip(pairs, velocity_rad_s, strict=False):
            if not abs(float(v)) <= self._velocity_limit[index] * 1.05:
                raise CommandRejected(
                    f"joint command velocity {self.joint_names[index]}={float(v):.3f} rad/s exceeds "
                    f"the joint's limit {self._velocity_limit[index]:.2f} rad/s"
                )
        return pairs

    def offer(self, names: Sequence[str], position_rad: Sequence[float], now_s: float,
              current_rad: np.ndarray, velocity_rad_s: Sequence[float] = ()) -> str | None:
        """Take a command received at `now_s`.

        Args:
            velocity_rad_s: optional feed-forward velocities (same order as `names`); joints
                a command does not name get zero feed-forward.
            current_rad: the arm's current positions (7,), the base for partial commands
                when no target exists yet.

        Returns:
            None when accepted, else the one-line reason it was rejected (the arm then holds).
        """
        try:
            pairs = self.validate(names, position_rad, velocity_rad_s)
        except CommandRejected as exc:
            self.rejected += 1
            self._target_rad = None
            self._last_valid_s = None
            self._rejected_reason = f"rejected command: {exc}"
            return str(exc)
        base = self._target_rad if self._target_rad is not None else np.asarray(current_rad, float)
        target = base.copy()
        for index, value in pairs:
            target[index] = value
        step = self._too_far(target, base)
        if step is not None:
            self.rejected += 1
            self._target_rad = None
            self._last_valid_s = None
            self._rejected_reason = f"rejected command: {step}"
            return step
        feedforward = np.zeros(len(self.joint_names))
        for (index, _), v in zip(pairs, velocity_rad_s, strict=False):
            feedforward[index] = float(v)
        self._feedforward_rad_s = feedforward
        self._target_rad = np.clip(target, self._clip_lower, self._clip_upper)
        self._last_valid_s = now_s
        self._rejected_reason = ""
        self.accepted += 1
        return None

    def _too_far(self, target_rad: np.ndarray, reference_rad: np.ndarray) -> str | None:
        """Why `target_rad` is too far from `reference_rad` for `max_step_rad`, or None."""
        if self.max_step_rad is None:
            return None
        step = np.abs(target_rad - np.asarray(reference_rad, float))
        worst = int(np.argmax(step))
        if step[worst] <= self.max_step_rad:
            return None
        return (f"joint command {self.joint_names[worst]} jumps {step[worst]:.3f} rad "
                f"(at most {self.max_step_rad:.3f} rad per command: send a trajectory, not a jump)")

    def decide(self, now_s: float) -> Decision:
        """The servo target for this tick, or hold."""
        if self._last_valid_s is None or self._target_rad is None:
            return Decision(None, True, self._rejected_reason or "no joint command yet")
        age_s = now_s - self._last_valid_s
        if age_s > self.command_timeout_s:
            self._target_rad = None
            self._last_valid_s = None
            self._rejected_reason = (
                f"no joint command for {age_s * 1e3:.0f} ms (time-out {self.command_timeout_s * 1e3:.0f} ms)"
            )
            return Decision(None, True, self._rejected_reason)
        return Decision(self._target_rad, False, "", self._feedforward_rad_s)


class StopBrake:
    """The bridge's own reaction to `motion/stop` (release interrupt or protective stop).

    The stop does not depend on the motion service being alive: the bridge brakes the arm at
    once with a bounded deceleration and then holds it. Every joint's speed falls by
    `deceleration_rad_s2 · dt` per tick until zero (a joint at 1 rad/s stops in 25 ms at
    40 rad/s²). After a stop, joint commands are ignored unless they belong to a goal the
    supervisor sent *after* the stop (`goal_after_stop`, from `motion/goal`): a goal sent just
    before the stop, whose commands arrive after it, cannot move the arm again. "After" is by
    the senders' stamps when the goal and the stop come from the same source (a goal delayed
    on the bus, or a copy the supervisor sent before the stop, arrives after it but was sent
    before it), else by arrival. A protective stop is latched for the rest of the episode: no
    goal ends it, only `new_episode`.

    Args:
        deceleration_rad_s2: braking deceleration of every joint, rad/s² (> 0).
    """

    def __init__(self, deceleration_rad_s2: float = 40.0) -> None:
        if not deceleration_rad_s2 > 0:
            raise ValueError(f"deceleration_rad_s2 must be > 0, got {deceleration_rad_s2}")
        self.deceleration_rad_s2 = float(deceleration_rad_s2)
        self.active = False
        self.protective = False
        self.reason = ""
        self.ignored_commands = 0
        self.stale_goals = 0
        self._goals_after_stop: set[str] = set()
        self._newest_stop_ns: dict[str, int] = {}
        self._velocity_rad_s: np.ndarray | None = None

    def engage(self, reason: str, velocity_rad_s: np.ndarray, protective: bool = False,
               source: str = "", stamp_ns: int = 0) -> None:
        """A stop arrived (from `source`, stamped `stamp_ns`): brake from the measured joint
        velocities (rad/s)."""
        if stamp_ns > 0:
            self._newest_stop_ns[source] = max(stamp_ns, self._newest_stop_ns.get(source, 0))
        if not self.active:
            self._velocity_rad_s = np.nan_to_num(np.asarray(velocity_rad_s, dtype=float)).copy()
        self.active = True
        self.protective = self.protective or protective
        self.reason = reason
        self._goals_after_stop.clear()

    def goal_after_stop(self, goal_id: str, source: str = "", stamp_ns: int = 0) -> None:
        """Goal `goal_id` arrived on `motion/goal` (from `source`, stamped `stamp_ns`); while
        stopped, only goals sent after the stop may end it."""
        if not self.active or self.protective:
            return
        if stamp_ns > 0 and stamp_ns <= self._newest_stop_ns.get(source, 0):
            self.stale_goals += 1
            return  # sent before the stop, arrived after it: not a new goal
        self._goals_after_stop.add(goal_id)

    def new_episode(self) -> None:
        """A new supervisor episode: a protective stop may now be ended by a new goal."""
        self.protective = False

    def admit(self, goal_id: str) -> bool:
        """Whether a joint command of `goal_id` may reach the arm (ends the stop when the
        goal was sent after it)."""
        if self.active:
            if self.protective or goal_id not in self._goals_after_stop:
                self.ignored_commands += 1
                return False
            self.active = False
            self.reason = ""
            self._velocity_rad_s = None
            self._goals_after_stop.clear()
        return True

    def step(self, dt_s: float) -> np.ndarray:
        """Joint velocities (rad/s) for the next `dt_s`: each one brought toward zero by at
        most the deceleration."""
        assert self._velocity_rad_s is not None, "step() before engage()"
        v = self._velocity_rad_s
        dv = self.deceleration_rad_s2 * max(dt_s, 0.0)
        self._velocity_rad_s = np.sign(v) * np.maximum(np.abs(v) - dv, 0.0)
        return self._velocity_rad_s.copy()

    @property
    def at_rest(self) -> bool:
        """The brake has brought every joint to zero speed."""
        return self._velocity_rad_s is not None and not np.any(self._velocity_rad_s)
