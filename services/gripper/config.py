"""Typed configuration of the gripper service (`[services.gripper.config]` in a deploy profile).

Example (deploy/sim.toml)::

    [services.gripper.config]
    controller = "FS1"          # any name of services.gripper.controllers.registry.CONTROLLER_NAMES
    rate_hz = 100.0             # thesis: 10, 25 or 100 Hz; up to 1 kHz
    wrench_timeout_s = 0.05     # wrist wrench older than this: hold, never open
    motion_timeout_s = 0.05     # optical motion older than this: hold, never open
"""

from __future__ import annotations

from typing import Annotated, Any

import msgspec
from msgspec import Meta

from services.gripper.controllers.common import ABSOLUTE_MAX_GRIP_FORCE_N
from services.gripper.controllers.registry import CONTROLLER_NAMES
from services.gripper.errors import GripperConfigError

#: Control rates the thesis uses (Hz): the system's object-transfer loop (10 Hz, Fig. 30),
#: the gripper position loop (25 Hz) and the F/T sensor (100 Hz).
THESIS_RATES_HZ = (10.0, 25.0, 100.0)

Seconds = Annotated[float, Meta(gt=0.0, le=5.0)]
ForceN = Annotated[float, Meta(ge=0.0, le=ABSOLUTE_MAX_GRIP_FORCE_N)]
ParamValue = Annotated[float, Meta(ge=-1e6, le=1e6)]


class GripperConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Gripper service settings (SI units).

    Attributes:
        controller: release controller by registry name (e.g. ``FS1``, ``HI``, ``SG``).
        controller_params: parameter overrides passed to the controller's factory (floats).
        rate_hz: control rate, Hz (1–1000). The controller steps at most this often, as
            soon as a new wrist-wrench sample has arrived; with no new sample a watchdog
            tick runs every 1/rate_hz to judge freshness. Per-step gains (k_i of eq 3.19)
            are per control step, as in the thesis.
        wrench_timeout_s: wrist wrench older than this (local receive time) is stale, s.
        motion_timeout_s: optical object motion older than this is stale, s.
        require_motion: the controller needs the optical sensor (True for every law that
            uses a_y or slip velocity); False lets force-only laws (HI, baselines) run with
            a_y = 0 when no motion data arrives.
        hold_grip_force_n: while holding on stale/bad data before the release, the command
            is at least this force, N (never lower than the last command: holding never opens).
        max_grip_force_n: clamp of every command, N (≤ 140 N, ISO/TS 15066 hand limit).
        release_confirm_s: a zero command must last this long before the release is
            declared (latched, one release event), s.
        state_rate_hz: gripper/state publication rate, Hz (also published on every change).
        spring_stiffness_n_m: spring of eq 3.21, N/m (thesis: 5 N/cm).
        contact_position_m: gripper position x0 where the pad touches the object, m from
            fully open.
        max_position_m: largest position command, m from fully open.
        rearm_on_new_episode: a new supervisor episode id resets the controller and the
            release latch.
        step_in_callback: run a due control step, and publish its command, in the bus
            callback that received the wrist wrench, skipping the hand-off to the main
            thread. Off by default: measured, it saves nothing (same median, no better p99,
            docs/gripper.md) and a blocking publish inside Zenoh's receive thread can stall
            reception under load.
    """

    controller: str = "FS1"
    controller_params: dict[str, ParamValue] = {}
    rate_hz: Annotated[float, Meta(ge=1.0, le=1000.0)] = 100.0
    wrench_timeout_s: Seconds = 0.05
    motion_timeout_s: Seconds = 0.05
    require_motion: bool = True
    hold_grip_force_n: ForceN = 10.0
    max_grip_force_n: Annotated[float, Meta(gt=0.0, le=ABSOLUTE_MAX_GRIP_FORCE_N)] = ABSOLUTE_MAX_GRIP_FORCE_N
    release_confirm_s: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.05
    state_rate_hz: Annotated[float, Meta(ge=1.0, le=1000.0)] = 100.0
    spring_stiffness_n_m: Annotated[float, Meta(gt=0.0, le=1e6)] = 500.0
    contact_position_m: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.0
    max_position_m: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.1
    rearm_on_new_episode: bool = True
    step_in_callback: bool = False

    @property
    def period_s(self) -> float:
        """Control period 1/rate_hz, s."""
        return 1.0 / self.rate_hz


def parse_config(table: dict[str, Any]) -> GripperConfig:
    """Validate a config table (from the profile, with CLI overrides applied).

    Raises:
        GripperConfigError: naming the bad key and what to check.
    """
    try:
        cfg = msgspec.convert(table, GripperConfig)
    except msgspec.ValidationError as exc:
        raise GripperConfigError(f"invalid [services.gripper.config]: {exc}") from None
    if cfg.controller not in CONTROLLER_NAMES:
        raise GripperConfigError(
            f"invalid [services.gripper.config]: unknown controller {cfg.controller!r}; "
            f"choose one of: {', '.join(CONTROLLER_NAMES)}"
        )
    if cfg.hold_grip_force_n > cfg.max_grip_force_n:
        raise GripperConfigError(
            "invalid [services.gripper.config]: hold_grip_force_n "
            f"({cfg.hold_grip_force_n} N) exceeds max_grip_force_n ({cfg.max_grip_force_n} N)"
        )
    if cfg.max_position_m <= cfg.contact_position_m:
        raise GripperConfigError(
            "invalid [services.gripper.config]: max_position_m must exceed contact_position_m "
            "(check the gripper travel)"
        )
    return cfg
