"""One episode's deploy profile: the base profile (``deploy/sim.toml``) with the draw written in.

Every service that simulates or assumes the receiver and the object gets the same values:

- the bridge's scene (`[services.bridge.config.contact]`): behaviour and its parameters, pull
  angle, object mass and friction, body height and posture, hand reach time, F/T noise, seed;
- the tracker (`[services.tracker.config]`): the receiver's body weight (a camera cannot
  weigh; the profile value reaches the planner through `perception/human`), the object's mass
  from the task description, and its simulated Kinect's body and seed;
- the planner's default object mass (the tracker's estimate overrides it);
- the supervisor: one episode.

The profile is checked by loading it with the launcher's own loader before it is used.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from services.runtime.profile import load_profile_file, resolve_profile_path
from services.studies.evaluation.errors import EvaluationError
from services.studies.evaluation.population import EpisodeDraw


def read_base_profile(profile: str | Path) -> tuple[Path, dict[str, Any]]:
    """(path, TOML table) of the base profile (a name under deploy/ or a path).

    Raises:
        EvaluationError: (bad input) it cannot be read, or it does not simulate the handover
            scene with the tracker's own simulated Kinect.
    """
    try:
        path = resolve_profile_path(profile)
        load_profile_file(path)
        table = tomllib.loads(path.read_text())
    except Exception as exc:  # noqa: BLE001 - any reading or validation failure is the user's input
        raise EvaluationError(f"--profile {str(profile)!r}: {exc}", bad_input=True) from None
    services = table.get("services", {})
    contact = services.get("bridge", {}).get("config", {}).get("contact", {})
    tracker = services.get("tracker", {}).get("config", {})
    if contact.get("scenario") != "handover" or not contact.get("enabled", False):
        raise EvaluationError(f"--profile {path}: the evaluation needs the simulated handover scene "
                              "([services.bridge.config.contact] enabled, scenario = \"handover\"), "
                              "as deploy/sim.toml has", bad_input=True)
    if tracker.get("sensor") != "sim":
        raise EvaluationError(f"--profile {path}: the evaluation needs the tracker's own simulated Kinect "
                              "([services.tracker.config] sensor = \"sim\"), as deploy/sim.toml has", bad_input=True)
    return path, table


def episode_table(base: dict[str, Any], draw: EpisodeDraw, robot: str | None = None) -> dict[str, Any]:
    """The base profile's table with `draw` written in (the base is not changed); with `robot`,
    the arm of that name with its built-in description (the base's ``[robot]`` table replaced,
    as `handover-up --robot` does)."""
    table = copy.deepcopy(base)
    if robot is not None:
        table["robot"] = {"model": robot}
    services = table["services"]
    contact = services["bridge"]["config"]["contact"]
    contact.update({
        "behaviour": draw.behaviour, "receiver": dict(draw.receiver), "pull_angle_deg": draw.pull_angle_deg,
        "object_mass_kg": draw.object_mass_kg, "mu_static": draw.mu_static, "mu_kinetic": draw.mu_kinetic,
        "seed": draw.sim_seed, "height_m": draw.height_m, "posture": draw.posture,
        "hand_reach_duration_s": draw.hand_reach_duration_s, "ft_noise_std_n": draw.ft_noise_std_n,
        "ft_bias_std_n": draw.ft_bias_std_n,
    })
    tracker = services["tracker"].setdefault("config", {})
    tracker.update({"weight_kg": draw.weight_kg, "object_mass_kg": draw.object_mass_kg})
    tracker.setdefault("sim_kinect", {}).update({"height_m": draw.height_m, "posture": draw.posture,
                                                 "seed": draw.sim_seed})
    if "planner" in services:
        services["planner"].setdefault("config", {})["object_mass_kg"] = draw.object_mass_kg
    if "supervisor" in services:
        services["supervisor"].setdefault("config", {})["episodes"] = 1
    return table


def write_episode_profile(base: dict[str, Any], draw: EpisodeDraw, path: Path, robot: str | None = None) -> Path:
    """Write the episode's profile to `path` and check it loads; the path.

    Raises:
        EvaluationError: the written profile does not load (names the file and the reason).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"# Episode {draw.episode} of an evaluation run (services.studies.evaluation): "
                    "the base profile with the episode's draw.\n" + tomli_w.dumps(episode_table(base, draw, robot)))
    try:
        load_profile_file(path)
    except Exception as exc:  # noqa: BLE001 - the launcher's own loader says what is wrong
        raise EvaluationError(f"episode {draw.episode}: its profile {path} does not load: {exc}") from None
    return path
