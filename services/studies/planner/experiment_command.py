"""`handover-study experiment`: the candidate transfer positions of the thesis's human–robot
experiment (§2.5.1) for a given receiver.

    handover-study experiment --receiver 1.75,1.76,70 --receiver-posture sitting [--json]
"""

from __future__ import annotations

import argparse
import json

from services.planner.scene_args import (
    EMPTY_CUP_KG,
    FULL_CUP_KG,
    add_scene_args,
    config_from_args,
    plan_from_args,
    scene_from_args,
)
from services.studies.planner.experiment import four_positions, heavy_light_positions

DESCRIPTION = "The candidate transfer positions of the thesis's human-robot experiment (§2.5.1)."


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The dyad's flags, `--profile` and `--json`."""
    add_scene_args(p)
    p.add_argument("--profile", default="sim",
                   help="profile whose [services.planner.config] is used (default: sim)")
    p.add_argument("--json", action="store_true", help="print the answer as JSON")


def run(args: argparse.Namespace) -> int:
    """Plan for the empty and the full cup and print the candidates (or JSON)."""
    cfg = config_from_args(args)
    giver, receiver, geometry, settings = scene_from_args(args, cfg)
    frame = cfg.frame.frame()
    light = plan_from_args(args, cfg, giver, receiver, geometry, settings, EMPTY_CUP_KG)
    task = "task 2 (receiver sitting)" if receiver.posture == "sitting" else "task 1 (receiver standing)"
    rows = {task: four_positions(light, settings, frame)}
    heavy = plan_from_args(args, cfg, giver, receiver, geometry, settings, FULL_CUP_KG, spill=True)
    rows["tasks 3/4 (full cup 335 g vs empty cup 65 g)"] = heavy_light_positions(heavy, light, settings, frame)
    if args.json:
        print(json.dumps({k: [vars(c) | {"cost": c.cost if c.feasible else None} for c in v]
                          for k, v in rows.items()}))
        return 0
    for title, cands in rows.items():
        print(title)
        for c in cands:
            x, z = c.position_task_m
            b = ", ".join(f"{v:.3f}" for v in c.position_base_m)
            cost = f"{c.cost:7.1f}" if c.feasible else "unreachable"
            print(f"  {c.name}: task ({x * 100:+6.1f}, {z * 100:5.1f}) cm  base ({b}) m  "
                  f"E_DJT {cost}  {c.description}")
    return 0
