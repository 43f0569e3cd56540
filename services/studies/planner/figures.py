"""Figures of the DJT planner (matplotlib, Agg backend).

`handover-study figures planner [--out docs/img]` writes:
- ``planner_figure3.png``: thesis Figure 3's case (both actors H = 187 cm, L = 190 cm,
  W = 80 kg, object 0.2 kg): E_DJT map over the region both can reach, optimum marked;
- ``planner_findings.png``: the thesis's findings as the model reproduces them (object mass
  sweep; postures);
- ``planner_robot.png``: the robot giver (§2.5) with a standing and a sitting receiver and
  the four candidate positions of the human–robot experiment.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from services.planner.anthropometrics import FIGURE3_ACTOR, ROBOT_AS_HUMAN  # noqa: E402
from services.planner.djt.settings import DJTSettings  # noqa: E402
from services.planner.plot import draw_plan  # noqa: E402
from services.planner.scene_args import EMPTY_CUP_KG  # noqa: E402
from services.planner.transfer_plan import DyadGeometry, TransferPlan, plan_transfer  # noqa: E402
from services.studies.planner.experiment import four_positions  # noqa: E402


def figure3(out: Path) -> TransferPlan:
    plan = plan_transfer(FIGURE3_ACTOR, FIGURE3_ACTOR, 0.2)
    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    draw_plan(ax, plan, "Thesis Fig. 3 case: both H=187 cm, L=190 cm, W=80 kg; object 0.2 kg")
    fig.tight_layout()
    fig.savefig(out / "planner_figure3.png", dpi=120)
    plt.close(fig)
    return plan


def findings(out: Path) -> None:
    a = FIGURE3_ACTOR
    sit = replace(a, posture="sitting")
    masses = np.linspace(0.0, 1.0, 21)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10.0, 4.2))
    for lean, style in ((0.04, "-o"), (0.0, "--s")):
        geometry = DyadGeometry(lean_fraction_of_height=lean)
        xs = [plan_transfer(a, a, float(m), geometry).position_task_m[0] for m in masses]
        ax1.plot(masses, np.array(xs) * 100, style, ms=3, label=f"lean {lean:g}·H")
    for m, name in ((0.065, "empty cup"), (0.335, "full cup")):
        ax1.axvline(m, color="0.6", lw=0.8)
        ax1.text(m, ax1.get_ylim()[1], name, fontsize=7, rotation=90, va="top", ha="right")
    ax1.set_xlabel("object mass (kg)")
    ax1.set_ylabel("transfer x (cm), + toward the receiver")
    ax1.set_title("Heavier objects are handed over closer to the giver", fontsize=9)
    ax1.legend(fontsize=8)
    cases = [("both standing", a, a), ("giver sitting", sit, a), ("receiver sitting", a, sit)]
    width = 0.35
    for k, (lean, colour) in enumerate(((0.04, "tab:green"), (0.0, "tab:gray"))):
        geometry = DyadGeometry(lean_fraction_of_height=lean)
        zs = [plan_transfer(g, r, 0.2, geometry).position_task_m[1] * 100 for _, g, r in cases]
        ax2.bar(np.arange(3) + (k - 0.5) * width, zs, width, color=colour, label=f"lean {lean:g}·H")
    ax2.set_xticks(np.arange(3), [c[0] for c in cases])
    ax2.set_ylabel("transfer height above the table (cm)")
    ax2.set_title("Sitting lowers the point (with the default lean)", fontsize=9)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "planner_findings.png", dpi=120)
    plt.close(fig)


def robot(out: Path) -> None:
    receiver = FIGURE3_ACTOR
    geometry = DyadGeometry(giver_is_robot=True)
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.6))
    for ax, posture in zip(axes, ("standing", "sitting"), strict=True):
        plan = plan_transfer(
            ROBOT_AS_HUMAN, replace(receiver, posture=posture), EMPTY_CUP_KG, geometry
        )
        draw_plan(ax, plan, f"Robot giver (190 cm, 100 kg, 200 cm), receiver {posture}, 65 g",
                  show_colorbar=False)
        for c in four_positions(plan, DJTSettings()):
            if c.name == "P1":
                continue
            ax.plot(*c.position_task_m, "x", color="k" if c.feasible else "r", ms=8)
            ax.annotate(c.name, c.position_task_m, textcoords="offset points", xytext=(5, -10),
                        fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "planner_robot.png", dpi=120)
    plt.close(fig)

