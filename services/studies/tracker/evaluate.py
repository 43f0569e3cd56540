"""Evaluation: hand-position error against simulator truth, with and without corrections.

Runs seeded episodes (`services.studies.tracker.episodes`) and feeds the same frames to one
pipeline per variant: no correction, lag correction only (with and without removing the
robot's points), proximity filter only, and both. Errors are |hand − true hand| at each
skeleton frame (the truth at the frame's time), split by phase:

- ``reaching``: the true hand moves faster than 0.25 m/s and is ≥ 15 cm from the robot's hand
  (where the skeleton's lag hurts, and where Mincelli et al. say the lag correction helps);
- ``final approach``: the true hand is within 15 cm of the robot's hand (where the robot
  merges into the person's cloud and the proximity filter is meant to help);
- ``other``: everything else (hand at rest or slow, far from the robot).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from robot_sim.kinect import ArmGeometry
from services.studies.tracker.episodes import run_episode
from services.tracker.config import TrackerConfig
from services.tracker.core import TrackerPipeline, skeleton_frame_from_message
from services.tracker.pointcloud import depth_frame_from_message

log = logging.getLogger(__name__)

VARIANTS: dict[str, dict[str, bool]] = {
    "none": {"lag_correction": False, "proximity_filter": False},
    "lag (a)": {"lag_correction": True, "proximity_filter": False},
    "lag (a), robot points kept": {"lag_correction": True, "proximity_filter": False, "remove_robot_points": False},
    "proximity (b)": {"lag_correction": False, "proximity_filter": True},
    "both (a)+(b)": {"lag_correction": True, "proximity_filter": True},
}
PHASES = ("reaching", "final approach", "other", "all")
REACH_SPEED_M_S = 0.25
CLOSE_M = 0.15


@dataclass
class EpisodeTrace:
    """Per-frame series of one episode (for figures): times (N,), truth/raw/variant hands (N, 3)."""

    t_s: np.ndarray
    truth_m: np.ndarray
    tool_m: np.ndarray
    hands_m: dict[str, np.ndarray]
    raw_m: np.ndarray
    held: np.ndarray


def evaluate_episode(seed: int, base: TrackerConfig, arm: ArmGeometry,
                     variants: dict[str, dict] | None = None) -> tuple[dict[str, dict[str, list[float]]], EpisodeTrace]:
    """Errors (m) per variant (default `VARIANTS`; each must differ from ``none``'s flags only
    where it says) and phase for one episode, and its trace."""
    variants = {"none": VARIANTS["none"], **(variants or VARIANTS)}
    pipes = {name: TrackerPipeline(msgspec.structs.replace(base, **flags), arm) for name, flags in variants.items()}
    errors = {name: {p: [] for p in PHASES} for name in variants}
    ts, truth, tools, raw, held = [], [], [], [], []
    hands: dict[str, list[np.ndarray]] = {name: [] for name in variants}
    prev_truth = None
    for frame in run_episode(seed, arm):
        t = frame.t_s
        q = np.asarray(frame.joint_state.position_rad)
        depth = depth_frame_from_message(frame.depth, t)
        skel = skeleton_frame_from_message(frame.skeleton, t)
        true_hand = np.asarray(frame.truth.receiver_hand_position_m)
        tool = np.asarray(frame.truth.tool_position_m)
        speed = 0.0 if prev_truth is None else float(np.linalg.norm(true_hand - prev_truth) * 30.0)
        prev_truth = true_hand
        close = np.linalg.norm(true_hand - tool) < CLOSE_M
        phase = "final approach" if close else ("reaching" if speed > REACH_SPEED_M_S else "other")
        outs = {}
        for name, pipe in pipes.items():
            pipe.on_joint_state(q, t)
            pipe.on_depth(depth)
            outs[name] = pipe.on_skeleton(skel)
        if not outs["none"].tracked:
            continue
        ts.append(t)
        truth.append(true_hand)
        tools.append(tool)
        raw.append(outs["none"].hand_raw_m)
        held.append("proximity" in outs.get("both (a)+(b)", outs["none"]).correction)
        for name, est in outs.items():
            err = float(np.linalg.norm(est.hand_m - true_hand))
            errors[name][phase].append(err)
            errors[name]["all"].append(err)
            hands[name].append(est.hand_m)
    trace = EpisodeTrace(
        np.array(ts), np.array(truth), np.array(tools), {k: np.array(v) for k, v in hands.items()}, np.array(raw),
        np.array(held)
    )
    return errors, trace


def summarise(errors: dict[str, dict[str, list[float]]]) -> dict[str, dict[str, dict[str, float]]]:
    """Mean, median and 90th percentile (mm) and frame counts per variant and phase."""
    out: dict[str, dict[str, dict[str, float]]] = {}
    for name, phases in errors.items():
        out[name] = {}
        for phase, values in phases.items():
            v = np.asarray(values) * 1000.0
            out[name][phase] = (
                {"frames": int(v.size), "mean_mm": float(v.mean()), "median_mm": float(np.median(v)),
                 "p90_mm": float(np.percentile(v, 90))}
                if v.size
                else {"frames": 0, "mean_mm": float("nan"), "median_mm": float("nan"), "p90_mm": float("nan")}
            )
    return out


def markdown_table(summary: dict[str, dict[str, dict[str, float]]]) -> str:
    """The evaluation table (median / p90 error in mm per phase)."""
    head = "| variant | " + " | ".join(f"{p} median / p90 (mm)" for p in PHASES) + " |"
    sep = "|---|" + "---|" * len(PHASES)
    rows = [head, sep]
    for name, phases in summary.items():
        cells = [f"{phases[p]['median_mm']:.0f} / {phases[p]['p90_mm']:.0f}" for p in PHASES]
        rows.append(f"| {name} | " + " | ".join(cells) + " |")
    counts = ", ".join(f"{p}: {summary['none'][p]['frames']}" for p in PHASES)
    rows.append("")
    rows.append(f"Frames per phase: {counts}.")
    return "\n".join(rows)


def run_evaluation(episodes: int, first_seed: int, base: TrackerConfig | None = None, progress: bool = False):
    """Evaluate `episodes` seeded episodes starting at `first_seed`.

    Returns:
        (summary dict, trace of the first episode).
    """
    base = base or TrackerConfig()
    arm = ArmGeometry()
    total = {name: {p: [] for p in PHASES} for name in VARIANTS}
    first_trace = None
    seeds = range(first_seed, first_seed + episodes)
    if progress:
        from tqdm import tqdm

        seeds = tqdm(seeds, desc="episodes", unit="ep")
    for seed in seeds:
        errs, trace = evaluate_episode(seed, base, arm)
        if first_trace is None:
            first_trace = trace
        for name in VARIANTS:
            for p in PHASES:
                total[name][p].extend(errs[name][p])
    return summarise(total), first_trace


def plot_trace(trace: EpisodeTrace, path: Path) -> None:
    """Raw vs corrected hand trajectory of one episode (x, z and error over time)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    t = trace.t_s
    both = trace.hands_m["both (a)+(b)"]
    for ax, i, label in ((axes[0], 0, "hand x (m, base)"), (axes[1], 2, "hand z (m, base)")):
        ax.plot(t, trace.truth_m[:, i], "k-", lw=2, label="truth")
        ax.plot(t, trace.raw_m[:, i], color="tab:red", lw=1, label="raw skeleton")
        ax.plot(t, both[:, i], color="tab:blue", lw=1.5, label="corrected (a)+(b)")
        ax.plot(t, trace.tool_m[:, i], color="tab:gray", ls="--", lw=1, label="robot tool")
        ax.set_ylabel(label)
    axes[0].legend(loc="best", fontsize=8)
    for name, colour in (("none", "tab:red"), ("lag (a)", "tab:orange"), ("proximity (b)", "tab:green"),
                         ("both (a)+(b)", "tab:blue")):
        err = np.linalg.norm(trace.hands_m[name] - trace.truth_m, axis=1) * 1000.0
        axes[2].plot(t, err, color=colour, lw=1.2, label=name)
    held = trace.held
    if held.any():
        axes[2].fill_between(t, 0, 1, where=held, transform=axes[2].get_xaxis_transform(), color="tab:blue", alpha=0.1,
                             label="proximity hold")
    axes[2].set_ylabel("hand error (mm)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(loc="upper left", fontsize=8)
    fig.suptitle("Simulated Kinect: raw vs corrected receiver hand (episode seed shown in docs)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_results(summary: dict, path: Path, episodes: int, first_seed: int) -> None:
    """Write the summary as JSON."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"episodes": episodes, "first_seed": first_seed, "summary": summary}, indent=2))
