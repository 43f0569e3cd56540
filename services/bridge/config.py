"""Typed configuration of the bridge (`[services.bridge.config]` in a deploy profile)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from services.bridge.baxter.config import BaxterConfig
from services.bridge.errors import BridgeConfigError
from services.bridge.franka.config import FrankaConfig


ReceiverBehaviour = Literal["taking", "dropping", "bumping", "hesitating", "absent"]


class ContactConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The contact plant run by the sim backend (`[services.bridge.config.contact]`).

    Attributes:
        enabled: simulate gripper, object, receiver and sensors (else only the arm).
        scenario: ``handover`` — the whole scene (`robot_sim.handover_scene`): the object
            waits on the table, the pick closes the fingers on it, the receiver reaches for it
            when the robot brings it close, and the contact starts when the hand arrives (the
            profile `deploy/sim.toml` uses this); ``transfer`` — only the transfer: the object
            starts between the pads and the receiver's timeline starts with the bridge
            (gripper tests and standalone controller runs).
        behaviour: receiver behaviour.
        pull_angle_deg: pull direction φ, deg (> 0 pulls downward, thesis Fig. 21).
        object_mass_kg: object mass, kg.
        mu_static, mu_kinetic: friction coefficients of the two pads together.
        initial_grip_force_n: grip before any gripper command arrives, N.
        seed: noise seed of the plant.
        receiver: extra behaviour parameters (e.g. ``reach_start_s = 2.0``), see
            `robot_sim.contact.receiver`.
        height_m, posture: the receiver's body in the ``handover`` scene (its reach and where
            its hand rests), m. The simulated Kinect service renders the same receiver: give
            it the same values (`[services.kinect.config]`; the launcher passes
            ``--posture``/``--seed`` to both).
        hand_reach_duration_s: how long the receiver's hand takes to reach the presented
            object in the ``handover`` scene (minimum-jerk), s.
        ft_noise_std_n: white noise of the wrist F/T sensor per axis, N.
        ft_bias_std_n: the F/T sensor's per-episode bias per axis is drawn from N(0, σ), N.
    """

    enabled: bool = False
    scenario: Literal["transfer", "handover"] = "transfer"
    behaviour: ReceiverBehaviour = "taking"
    pull_angle_deg: Annotated[float, Meta(ge=-90.0, le=90.0)] = 0.0
    object_mass_kg: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.2
    mu_static: Annotated[float, Meta(gt=0.0, le=3.0)] = 0.6
    mu_kinetic: Annotated[float, Meta(gt=0.0, le=3.0)] = 0.5
    initial_grip_force_n: Annotated[float, Meta(ge=0.0, le=140.0)] = 10.0
    seed: Annotated[int, Meta(ge=0, le=2**32 - 1)] = 0
    receiver: dict[str, float] = {}
    height_m: Annotated[float, Meta(ge=1.2, le=2.2)] = 1.75
    posture: Literal["standing", "sitting"] = "standing"
    hand_reach_duration_s: Annotated[float, Meta(ge=0.2, le=5.0)] = 1.0
    ft_noise_std_n: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.03
    ft_bias_std_n: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.05


class BridgeConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Bridge settings.

    Attributes:
        backend: ``sim`` (robot_sim in real time), ``baxter`` (the real robot, see
            docs/baxter.md; run it with ``python -m services.bridge.baxter``) or ``franka``
            (a Panda / FR3 through franky, docs/franka.md; ``python -m services.bridge.franka``).
        rate_hz: joint-state publication and servo rate, Hz.
        command_timeout_s: hold the arm when no fresh joint command arrived for this long, s
            (the default arm's own time-out is 0.2 s).
        servo_time_constant_s: first-order lag of the simulated joint servo, s.
        sim_robot_command_timeout_s: the simulated robot's own joint-command time-out, s: when
            the bridge's loop stalls (starved of CPU, frozen) for longer than two periods, the
            simulated arm goes on with its last command this long and then holds, as the default arm's
            controller does (its ``joint_command_timeout``, 0.2 s), instead of freezing with
            the bridge.
        limit_tolerance_rad: how far outside a joint limit a command may be before it is
            rejected (rounding), rad.
        stop_deceleration_rad_s2: on `motion/stop` the bridge brakes every joint with this
            deceleration, rad/s², then holds.
        initial_position_rad: start posture of the simulated arm (7 values), rad; empty for
            the default home posture.
        stop_wakes_loop: a `motion/stop` wakes the loop at once for an extra tick (brake
            engaged and joint state published within ~1 ms of the stop's arrival); False:
            the stop waits for the next tick of the 100 Hz grid (up to one period later; the
            baseline of tests/bench/test_bench_bridge_stop.py).
        contact: the contact plant (gripper, object, receiver, sensors).
        baxter: the Baxter backend (ROS 1 topics over Zenoh, safety on hardware).
        franka: the Franka backend (robot address, joint names and limits, the Hand).
    """

    backend: Literal["sim", "baxter", "franka"] = "sim"
    rate_hz: Annotated[float, Meta(ge=1.0, le=1000.0)] = 100.0
    command_timeout_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.2
    servo_time_constant_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.05
    sim_robot_command_timeout_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.2
    limit_tolerance_rad: Annotated[float, Meta(ge=0.0, le=0.1)] = 1e-3
    stop_deceleration_rad_s2: Annotated[float, Meta(gt=0.0, le=1000.0)] = 40.0
    initial_position_rad: Annotated[list[Annotated[float, Meta(ge=-10.0, le=10.0)]], Meta(max_length=7)] = []
    stop_wakes_loop: bool = True
    contact: ContactConfig = ContactConfig()
    baxter: BaxterConfig = BaxterConfig()
    franka: FrankaConfig = FrankaConfig()


def parse_config(table: dict[str, Any]) -> BridgeConfig:
    """Validate a config table.

    Raises:
        BridgeConfigError: naming the bad key (e.g. ``Expected `float` >= 1.0 - at `$.rate_hz```).
    """
    if "kinect" in table:
        raise BridgeConfigError(
            "invalid [services.bridge.config]: the simulated Kinect is its own service now: move "
            "[services.bridge.config.kinect] to [services.kinect.config] (module services.sim_kinect), "
            "or delete it where no Kinect is simulated"
        )
    try:
        cfg = msgspec.convert(table, BridgeConfig)
    except msgspec.ValidationError as exc:
        raise BridgeConfigError(f"invalid [services.bridge.config]: {exc}") from None
    if cfg.initial_position_rad and len(cfg.initial_position_rad) != 7:
        raise BridgeConfigError(
            "invalid [services.bridge.config]: initial_position_rad needs 7 values (right_s0…right_w2)"
        )
    return cfg
