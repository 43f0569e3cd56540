"""Figures of single episodes (matplotlib, Agg backend; no display needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from handover_model.grip import Mode  # noqa: E402
from robot_sim.contact.outcome import EpisodeOutcome, EpisodeTrace  # noqa: E402

__all__ = ["plot_episode"]

#: Background colours of the thesis's Figs. 20–23: grasp red, slip yellow, release green.
MODE_COLOURS = {Mode.GRASP: "#f4c7c3", Mode.SLIP: "#fce8b2", Mode.RELEASE: "#b7e1cd"}


def _mode_background(ax, t: np.ndarray, mode: np.ndarray) -> None:
    edges = np.flatnonzero(np.diff(mode)) + 1
    starts = np.concatenate(([0], edges))
    ends = np.concatenate((edges, [len(t) - 1]))
    for s, e in zip(starts, ends):
        ax.axvspan(t[s], t[e], color=MODE_COLOURS[Mode(int(mode[s]))], lw=0, zorder=0)


def plot_episode(trace: EpisodeTrace, outcome: EpisodeOutcome, path: str | Path, title: str = "") -> Path:
    """Three panels over time with the mode as background: forces, positions, accelerations.
    Returns the written PNG's path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    t = trace.time_s
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    for ax in axes:
        _mode_background(ax, t, trace.mode)
        ax.grid(True, alpha=0.3)
    a0, a1, a2 = axes
    a0.plot(t, trace.grip_force_n, color="k", lw=1.6, label="grip force F_G (true)")
    if trace.grip_command_n is not None:
        a0.plot(t, trace.grip_command_n, color="k", lw=0.8, ls="--", label="grip command")
    a0.plot(t, np.hypot(trace.pull_force_x_n, trace.pull_force_y_n), color="tab:blue", lw=1.4,
            label="|receiver force| (true)")
    if trace.sensed_force_x_n is not None:
        a0.plot(t, trace.sensed_force_x_n, color="tab:orange", lw=0.8, label="F_sx (wrist sensor)")
        a0.plot(t, trace.sensed_force_y_n, color="tab:green", lw=0.8, label="F_sy (wrist sensor)")
    a0.set_ylabel("force (N)")
    a0.legend(loc="upper right", fontsize=7)
    a1.plot(t, 100 * trace.object_position_x_m, color="tab:blue", label="object x (to receiver)")
    a1.plot(t, 100 * trace.object_position_y_m, color="tab:red", label="object y (down)")
    if trace.hand_position_x_m is not None:
        a1.plot(t, 100 * trace.hand_position_x_m, color="tab:blue", ls=":", label="hand x")
        a1.plot(t, 100 * trace.hand_position_y_m, color="tab:red", ls=":", label="hand y")
    a1.set_ylabel("position (cm)")
    lo = min(-5.0, 100 * float(np.min(trace.object_position_y_m)))
    a1.set_ylim(lo, max(35.0, 100 * float(np.max(trace.object_position_x_m)) + 2))
    a1.legend(loc="upper left", fontsize=7)
    a2.plot(t, trace.object_accel_y_m_s2, color="tab:red", lw=1.2, label="a_y true (down)")
    if trace.accel_estimate_y_m_s2 is not None:
        a2.plot(t, trace.accel_estimate_y_m_s2, color="tab:purple", lw=0.8, label="a_y optical estimate")
    a2.set_ylim(-15, 15)
    a2.set_ylabel("accel (m/s²)")
    a2.set_xlabel("time (s)")
    a2.legend(loc="upper left", fontsize=7)
    o = outcome
    summary = (f"released={o.released} at {o.release_time_s:.3f} s, dropped={o.dropped}, handed over={o.handed_over}, "
               f"overshoot {o.force_overshoot_n:.2f} N, slip {100 * o.slip_distance_m:.1f} cm, "
               f"switches {o.mode_switch_count}")
    fig.suptitle((title + "\n" if title else "") + summary, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
