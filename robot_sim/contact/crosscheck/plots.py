"""The cross-check's figures (matplotlib, Agg backend; no display needed).

Both plants on the same axes: ours solid, MuJoCo dashed. Gripper frame (x toward the
receiver, y DOWN); positions in mm, forces in N, time in s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from robot_sim.contact.crosscheck.compare import CaseResult  # noqa: E402

__all__ = ["plot_onset", "plot_traces", "FIGURES"]

#: File names of the figures under the output folder.
FIGURES = {"onset": "contact_crosscheck_onset.png", "slide": "contact_crosscheck_slide.png",
           "receiver": "contact_crosscheck_receivers.png", "difference": "contact_crosscheck_mu_k.png"}


def _value(res: CaseResult, key: str, plant: str) -> float:
    for r in res.rows:
        if r.quantity == key:
            return float(r.ours if plant == "ours" else r.mujoco)
    return math.nan


def plot_onset(results: Sequence[CaseResult], path: str | Path) -> Path:
    """Slip-onset pull: MuJoCo against ours (with Coulomb's μ F_G onset for reference), and
    each plant's difference to Coulomb's value, per case."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ours = np.array([_value(r, "onset_pull_n", "ours") for r in results])
    theirs = np.array([_value(r, "onset_pull_n", "mujoco") for r in results])
    coulomb = np.array([r.case.scenario.onset_pull_n(r.case.scenario.grip[0][1]) for r in results])
    support = np.array([r.case.scenario.support for r in results])
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(11, 4.6))
    top = 1.05 * float(np.nanmax(np.concatenate([ours, theirs])))
    a0.plot([0, top], [0, top], color="0.6", lw=0.8, label="equal")
    for sup, marker, label in ((False, "o", "weight on the pads"), (True, "s", "weight carried by the hand")):
        sel = support == sup
        a0.scatter(ours[sel], theirs[sel], marker=marker, s=22, facecolors="none", edgecolors="tab:blue", label=label)
    a0.set_xlabel("ours: pull at slip onset (N)")
    a0.set_ylabel("MuJoCo: pull at slip onset (N)")
    a0.set_title(f"{len(results)} cases: M, μ, φ, support", fontsize=9)
    a0.legend(fontsize=7, loc="upper left")
    a0.grid(True, alpha=0.3)
    idx = np.arange(len(results))
    a1.plot(idx, ours - coulomb, "o", ms=4, mfc="none", color="tab:blue", label="ours − Coulomb")
    a1.plot(idx, theirs - coulomb, "x", ms=4, color="tab:red", label="MuJoCo − Coulomb")
    a1.plot(idx, theirs - ours, ".", ms=4, color="k", label="MuJoCo − ours")
    a1.axhline(0.0, color="0.6", lw=0.8)
    a1.set_xlabel("case (M, then μ, then φ, then support)")
    a1.set_ylabel("difference (N)")
    a1.set_title("against Coulomb's |F_p u + (1 − s) W| = μ F_G (detection at 1 mm/s adds the same delay)",
                 fontsize=8)
    a1.legend(fontsize=7)
    a1.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


#: Distance panels show up to this displacement (mm): the pads' extent and a little more.
_DISTANCE_TOP_MM = 55.0
#: Position panels show x up to this (mm): a receiver's 20 cm pull; a falling object leaves the plot.
_POSITION_TOP_MM = 230.0


def _trace_panel(ax, res: CaseResult, what: str) -> None:
    top = 0.0
    for run, style in ((res.ours, "-"), (res.mujoco, "--")):
        if not len(run.time_s):
            continue
        t = run.time_s
        if what == "distance":
            d = 1e3 * np.hypot(run.x_m, run.y_m)
            top = max(top, float(d.max()))
            ax.plot(t, d, style, color="tab:blue" if style == "-" else "tab:red",
                    lw=1.3, label=f"{run.plant}: |displacement|")
        else:
            top = max(top, 1e3 * float(np.max(np.abs(run.x_m))))
            ax.plot(t, np.clip(1e3 * run.y_m, -20, 120), style, color="tab:blue" if style == "-" else "tab:red",
                    lw=1.3, label=f"{run.plant}: y (down)")
            ax.plot(t, 1e3 * run.x_m, style, color="tab:green" if style == "-" else "tab:olive", lw=1.0,
                    label=f"{run.plant}: x")
    if what == "distance":
        ax.set_ylim(-0.02 * min(top, _DISTANCE_TOP_MM), min(_DISTANCE_TOP_MM, max(1.1 * top, 0.05)))
    elif top > _POSITION_TOP_MM:
        ax.set_ylim(top=_POSITION_TOP_MM)
    grip = res.mujoco  # the actuator's force; our plant reports 0 once the object has left
    twin = ax.twinx()
    twin.plot(grip.time_s, grip.grip_force_n, color="0.55", lw=0.8, label="grip force")
    twin.set_ylim(0, max(12.0, 1.2 * float(np.max(grip.grip_force_n, initial=0.0))))
    twin.tick_params(labelsize=6)
    ax.set_title(res.case.scenario.name, fontsize=8)
    ax.tick_params(labelsize=6)
    ax.grid(True, alpha=0.3)


def plot_traces(results: Sequence[CaseResult], path: str | Path, what: str = "distance", columns: int = 4) -> Path:
    """Small multiples of the cases' time series, both plants: `what` = "distance" (the
    object's displacement from its start, mm) or "position" (x and y, mm; y clipped to
    −20…120 mm); the grip force in grey on the right axis (N)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = max(1, math.ceil(len(results) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(3.3 * columns, 2.5 * rows + 0.6), squeeze=False)
    for ax, res in zip(axes.flat, results):
        _trace_panel(ax, res, what)
    for ax in list(axes.flat)[len(results):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    height_in = fig.get_figheight()
    fig.legend(handles, labels, loc="upper center", ncol=4, fontsize=8, frameon=False)
    unit = f"|displacement| (mm, to {_DISTANCE_TOP_MM:g})" if what == "distance" else "position (mm; x, y down)"
    fig.supylabel(f"object {unit}; grey: grip force (N, right)", fontsize=8)
    fig.supxlabel("time (s)", fontsize=8)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.3 / height_in))
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
