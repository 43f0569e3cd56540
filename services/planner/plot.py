"""The planner's cost-map drawing (matplotlib; imported only when a figure is asked for).

`draw_plan` draws one `TransferPlan` in the task plane (x toward the receiver, z above the
table top, m): the E_DJT cost map, the table, both arms at the optimum and the optimum.
"""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes

from handover_model import scene
from services.planner.transfer_plan import TransferPlan
from services.planner.djt.arms import elbow_position


def draw_plan(ax: Axes, plan: TransferPlan, title: str, show_colorbar: bool = True) -> None:
    """Cost map, table, both arms at the optimum and the optimum (yellow dot) on `ax`."""
    cmap = plan.cost_map
    cost = np.where(cmap.feasible, cmap.cost, np.nan)
    mesh = ax.pcolormesh(cmap.x_m, cmap.z_m, cost, shading="nearest", cmap="viridis")
    if show_colorbar:
        ax.figure.colorbar(mesh, ax=ax, label="E_DJT (N² m²)")
    finite = cost[np.isfinite(cost)]
    if finite.size > 10:
        levels = np.quantile(finite, [0.02, 0.1, 0.25, 0.5, 0.75])
        ax.contour(cmap.x_m, cmap.z_m, cost, levels=np.unique(levels), colors="w", linewidths=0.6)
    half = scene.TABLE_DEPTH_M / 2.0
    ax.fill_between([-half, half], -scene.TABLE_HEIGHT_M, 0.0, color="0.75", zorder=0)
    ax.plot([-half, half], [0.0, 0.0], color="0.3", lw=2)
    p = np.array(plan.position_task_m)
    for actor, q, colour in (
        (plan.dyad.giver, plan.optimum.giver_joint_rad, "tab:red"),
        (plan.dyad.receiver, plan.optimum.receiver_joint_rad, "tab:blue"),
    ):
        elbow = elbow_position(actor, q[0])
        xs = [actor.shoulder_x_m, elbow[0], p[0]]
        zs = [actor.shoulder_z_m, elbow[1], p[1]]
        ax.plot(xs, zs, "-o", color=colour, lw=2.5, ms=5)
    ax.plot(p[0], p[1], "o", color="yellow", mec="k", ms=11, zorder=5)
    ax.annotate(
        f"({p[0] * 100:+.1f}, {p[1] * 100:.1f}) cm",
        p,
        textcoords="offset points",
        xytext=(8, 10),
        fontsize=8,
        bbox={"fc": "w", "alpha": 0.8, "lw": 0},
    )
    ax.set_xlim(-0.75, 0.75)
    ax.set_ylim(-0.2, 1.0)
    ax.set_aspect("equal")
    ax.set_xlabel("task x (m), giver → receiver")
    ax.set_ylabel("task z above the table top (m)")
    ax.set_title(title, fontsize=9)
