"""Typed configuration of the simulated Kinect (`[services.kinect.config]` for the stand-alone service,
`[services.tracker.config.sim_kinect]` for the tracker's own, `[services.fake_baxter.config.kinect]`)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from services.sim_kinect.errors import KinectConfigError


class KinectConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The simulated Kinect (`[services.kinect.config]`; the fake Baxter's
    `[services.fake_baxter.config.kinect]` has the same fields).

    Attributes:
        enabled: render depth and produce the skeleton (robot_sim.kinect) at `rate_hz`.
        rate_hz: frame rate, Hz (Kinect: 30).
        height_m: receiver's height, m, 1.2–2.2 (the body model's range; must match the bridge's scene receiver,
            `[services.bridge.config.contact].height_m`).
        posture: standing or sitting (must match the bridge's scene receiver).
        scene: ``handover`` — the receiver's right hand and the object follow the latest
            `sim/truth` (`receiver_hand_position_m`, `object_position_m`, published by the
            bridge's handover scene), so the body the tracker sees is the hand that takes
            the object; ``none`` — the Kinect's own scripted reach (`hand_target_base_m`)
            and the object waiting on the table (transfer scenario, arm-only sim).
        hand_target_base_m: where the receiver's right hand reaches in the scripted reach
            (``base`` frame, m); empty: the hand stays at rest.
        reach_start_s, reach_duration_s: when and how long the scripted reach takes, s from
            the first frame.
        seed: noise seed (skeleton errors, depth noise).
    """

    enabled: bool = True
    rate_hz: Annotated[float, Meta(gt=0.0, le=60.0)] = 30.0
    height_m: Annotated[float, Meta(ge=1.2, le=2.2)] = 1.75
    posture: Literal["standing", "sitting"] = "standing"
    scene: Literal["handover", "none"] = "none"
    hand_target_base_m: Annotated[list[Annotated[float, Meta(ge=-5.0, le=5.0)]], Meta(max_length=3)] = []
    reach_start_s: Annotated[float, Meta(ge=0.0, le=600.0)] = 0.5
    reach_duration_s: Annotated[float, Meta(gt=0.0, le=60.0)] = 1.5
    seed: Annotated[int, Meta(ge=0, le=2**32 - 1)] = 0


def parse_config(table: dict[str, Any], where: str = "[services.kinect.config]") -> KinectConfig:
    """Validate a config table.

    Raises:
        KinectConfigError: naming the bad key (e.g. ``Expected `float` <= 60.0 - at `$.rate_hz```).
    """
    try:
        cfg = msgspec.convert(table, KinectConfig)
    except msgspec.ValidationError as exc:
        raise KinectConfigError(f"invalid {where}: {exc}") from None
    if cfg.hand_target_base_m and len(cfg.hand_target_base_m) != 3:
        raise KinectConfigError(f"invalid {where}: hand_target_base_m needs 3 values (x, y, z)")
    return cfg
