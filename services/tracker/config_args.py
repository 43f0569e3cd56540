"""The tracker's configuration flags, shared by `handover-tracker` and the offline studies
(`handover-study evaluate`): Mincelli's corrections, the receiver's weight, the object's mass and
the simulated Kinect's set-up, applied over the profile's [services.tracker.config]."""

from __future__ import annotations

import argparse

from services.runtime import ProfileError, load_profile
from services.tracker.config import TrackerConfig, config_from_dict
from services.tracker.errors import TrackerConfigError


def add_config_flags(p: argparse.ArgumentParser) -> None:
    """Add the tracker's flags (group "tracker") to `p`."""
    g = p.add_argument_group("tracker")
    g.add_argument("--weight-kg", type=float, default=None, help="receiver's body weight from their profile (kg)")
    g.add_argument("--object-mass-kg", type=float, default=None, help="object mass from the task description (kg)")
    g.add_argument("--no-lag-correction", action="store_true", help="disable Mincelli's lag correction (a)")
    g.add_argument("--no-proximity-filter", action="store_true", help="disable Mincelli's robot-proximity filter (b)")
    g.add_argument("--proximity-filter", action="store_true",
                   help="enable (b), off by default: it doubled the median hand error (docs/tracker.md#defaults)")
    g.add_argument("--proximity-mode", choices=["hold", "predict"], default=None, help="what (b) does while engaged")
    g.add_argument("--sensor", choices=["bus", "sim", "ros1", "camera"], default=None,
                   help="skeleton and depth from the bus, from a simulated Kinect in this process, from "
                        "openni_tracker and a depth camera through the Zenoh ROS 1 bridge (docs/kinect_ros1.md), "
                        "or from a camera through a 2-D body-pose model (docs/camera.md)")
    g.add_argument("--publish-depth", action="store_true",
                   help="sensor = \"sim\" or \"ros1\": also publish perception/depth (for a recorder that "
                        "records depth)")
    g.add_argument("--posture", choices=["standing", "sitting"], default=None,
                   help="the simulated Kinect's receiver (sensor = \"sim\" only; must match the bridge's)")
    g.add_argument("--kinect-seed", dest="kinect_seed", type=int, default=None,
                   help="the simulated Kinect's noise seed (sensor = \"sim\" only)")


def config_from_args(args: argparse.Namespace, base: dict) -> TrackerConfig:
    """`base` (a [services.tracker.config] table) with the flags of `add_config_flags` applied.

    Raises:
        TrackerConfigError: an invalid value.
    """
    values = dict(base)
    if args.weight_kg is not None:
        values["weight_kg"] = args.weight_kg
    if args.object_mass_kg is not None:
        values["object_mass_kg"] = args.object_mass_kg
    if args.no_lag_correction:
        values["lag_correction"] = False
    if args.no_proximity_filter and getattr(args, "proximity_filter", False):
        raise TrackerConfigError("--proximity-filter and --no-proximity-filter contradict each other")
    if args.no_proximity_filter:
        values["proximity_filter"] = False
    if getattr(args, "proximity_filter", False):
        values["proximity_filter"] = True
    if args.proximity_mode is not None:
        values["proximity_mode"] = args.proximity_mode
    if getattr(args, "sensor", None) is not None:
        values["sensor"] = args.sensor
    if getattr(args, "publish_depth", False):
        values["publish_depth"] = True
    sim = values.get("sim_kinect") or {}
    if not isinstance(sim, dict):
        raise TrackerConfigError(f"invalid tracker config: sim_kinect must be a table, got {sim!r:.40}")
    sim = dict(sim)
    if getattr(args, "posture", None) is not None:
        sim["posture"] = args.posture
    if getattr(args, "kinect_seed", None) is not None:
        sim["seed"] = args.kinect_seed
    if sim:
        values["sim_kinect"] = sim
    return config_from_dict(values)


def profile_config(args: argparse.Namespace) -> dict:
    """[services.tracker.config] of the profile, or {} for the offline commands."""
    try:
        return load_profile(args).service_config("tracker")
    except (ProfileError, OSError, ValueError):  # offline commands work without a usable profile
        return {}
