"""Reproduce thesis Figures 20–23 (§3.5) from the thesis model mode, with a comparison table.

Each figure is a batch of `robot_sim.thesis_model` scenarios run with a fail-safe preset:
"FS-sim-g5" (the §3.5 text, γ = 5) by default, "FS-sim-g1" (Table IV as printed, γ = 1) for
comparison. Outputs:
- PNG plots (matplotlib, Agg) with the system mode as background colour: red grasp,
  yellow slip, green release, as in the thesis;
- Rerun recordings (.rrd) of every signal, one per figure, written with `rr.save`-style
  file sinks (no viewer);
- a Markdown table comparing what the thesis states with what we compute
  (`services.studies.gripper.claims`, fed with each episode's `EpisodeMetrics`).

Usage:
    handover-study reproduce --img-dir docs/img --rrd-dir out/reproduction
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from handover_model.grip import Mode
from robot_sim.thesis_model import ThesisRun, ThesisScenario, simulate
from services.gripper.controllers.fail_safe import FS_PRESETS
from services.gripper.controllers.registry import make_controller
from services.gripper.errors import GripperError
from services.studies.gripper.claims import Claim, EpisodeMetrics, FigureMetrics, analysis_claims, simulation_claims

log = logging.getLogger(__name__)

MODE_COLOURS = {int(Mode.GRASP): "#e06060", int(Mode.SLIP): "#f0d050", int(Mode.RELEASE): "#60c060"}
MODE_NAMES = {int(Mode.GRASP): "grasp", int(Mode.SLIP): "slip", int(Mode.RELEASE): "release"}
PRESET_TAGS = {"FS-sim-g5": "g5", "FS-sim-g1": "g1"}
HIGH_FRICTION = (0.9, 0.8)
LOW_FRICTION = (0.3, 0.2)
NOISE_SNR_DB = 3.0


@dataclass(frozen=True)
class Panel:
    """One sub-plot: which episode of the figure's batch and which signal group."""

    letter: str
    episode: str
    kind: str  # "forces" (F_p and F_G) or "accel" (a_y)


@dataclass(frozen=True)
class FigureSpec:
    number: int
    title: str
    episodes: dict[str, ThesisScenario]
    panels: tuple[Panel, ...]


def figure_specs(base: ThesisScenario | None = None) -> list[FigureSpec]:
    """The four §3.5 figures as scenario batches and panel layouts."""
    b = base or ThesisScenario()
    take = replace(b, action="taking")
    drop = replace(b, action="dropping")
    deg20 = math.radians(20.0)
    return [
        FigureSpec(
            20, "φ = 0°: taking and dropping",
            {"taking": take, "dropping": drop},
            (Panel("a", "taking", "forces"), Panel("b", "dropping", "forces"),
             Panel("c", "taking", "accel"), Panel("d", "dropping", "accel")),
        ),
        FigureSpec(
            21, "taking at φ = +20° and φ = −20°",
            {"taking_phi_p20": replace(take, phi_rad=deg20), "taking_phi_m20": replace(take, phi_rad=-deg20)},
            (Panel("a", "taking_phi_p20", "forces"), Panel("b", "taking_phi_m20", "forces"),
             Panel("c", "taking_phi_p20", "accel"), Panel("d", "taking_phi_m20", "accel")),
        ),
        FigureSpec(
            22, "friction: high (μs=0.9, μk=0.8) and low (μs=0.3, μk=0.2)",
            {
                "taking_high_mu": replace(take, mu_static=HIGH_FRICTION[0], mu_kinetic=HIGH_FRICTION[1]),
                "dropping_high_mu": replace(drop, mu_static=HIGH_FRICTION[0], mu_kinetic=HIGH_FRICTION[1]),
                "taking_low_mu": replace(take, mu_static=LOW_FRICTION[0], mu_kinetic=LOW_FRICTION[1]),
                "dropping_low_mu": replace(drop, mu_static=LOW_FRICTION[0], mu_kinetic=LOW_FRICTION[1]),
            },
            (Panel("a", "taking_high_mu", "accel"), Panel("b", "dropping_high_mu", "accel"),
             Panel("c", "taking_low_mu", "accel"), Panel("d", "dropping_low_mu", "accel")),
        ),
        FigureSpec(
            23, f"dropping with white noise (SNR {NOISE_SNR_DB:g} dB) on F_G and on a_y",
            {
                "dropping_grip_noise": replace(drop, grip_noise_snr_db=NOISE_SNR_DB, seed=23),
                "dropping_accel_noise": replace(drop, accel_noise_snr_db=NOISE_SNR_DB, seed=24),
                "dropping_grip_noise_variance": replace(
                    drop, grip_noise_snr_db=NOISE_SNR_DB, noise_reference="variance", seed=23
                ),
            },
            (Panel("a", "dropping_grip_noise", "forces"), Panel("b", "dropping_accel_noise", "forces"),
             Panel("c", "dropping_grip_noise", "accel"), Panel("d", "dropping_accel_noise", "accel")),
        ),
    ]


def run_figure(spec: FigureSpec, preset: str) -> ThesisRun:
    """Simulate all episodes of one figure with a fail-safe preset (one vectorised batch)."""
    controller = make_controller(preset, period_s=next(iter(spec.episodes.values())).period_s)
    return simulate(list(spec.episodes.values()), controller)


# --------------------------------------------------------------------------- metrics


def episode_metrics(run: ThesisRun, episode: int) -> EpisodeMetrics:
    """What the thesis's statements are about, measured on episode `episode` of `run`."""
    t = run.time_s
    mode = run.mode[:, episode]
    ay = run.accel_y_m_s2[:, episode]
    rel = np.flatnonzero(mode == int(Mode.RELEASE))
    slip = np.flatnonzero(mode == int(Mode.SLIP))
    first_rel = int(rel[0]) if rel.size else None
    return EpisodeMetrics(
        release_time_s=float(t[first_rel]) if first_rel is not None else math.nan,
        final_mode=MODE_NAMES[int(mode[-1])],
        released_at_end=bool(mode[-1] == int(Mode.RELEASE)),
        pull_at_release_n=float(run.pull_n[first_rel, episode]) if first_rel is not None else math.nan,
        max_accel_y_m_s2=float(ay.max()),
        max_accel_y_slipping_m_s2=float(ay[slip].max()) if slip.size else 0.0,
        min_accel_y_after_release_m_s2=float(ay[first_rel:].min()) if first_rel is not None else math.nan,
        accel_before_release=bool(np.any(ay[: first_rel if first_rel is not None else len(t)] > 0.0)),
        mode_switches=int(np.count_nonzero(np.diff(mode))),
        first_slip_time_s=float(t[slip[0]]) if slip.size else math.nan,
        slide_m=float(run.slide_m[-1, episode]),
        final_grip_n=float(run.grip_force_n[-1, episode]),
        initial_grip_n=float(run.grip_force_n[0, episode]),
    )


def figure_metrics(spec: FigureSpec, run: ThesisRun) -> dict[str, EpisodeMetrics]:
    """Metrics of every episode of one figure's run, by episode name."""
    return {name: episode_metrics(run, j) for j, name in enumerate(spec.episodes)}


# --------------------------------------------------------------------------- plots


def _mode_background(ax, time_s: np.ndarray, mode: np.ndarray) -> None:
    dt = time_s[1] - time_s[0] if time_s.size > 1 else 0.01
    edges = np.flatnonzero(np.diff(mode)) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [mode.size]])
    for s, e in zip(starts, ends):
        ax.axvspan(time_s[s], time_s[e - 1] + dt, color=MODE_COLOURS[int(mode[s])], alpha=0.35, lw=0)


def plot_figure(spec: FigureSpec, run: ThesisRun, preset: str, path: Path) -> Path:
    """Draw one figure (2×2 panels) as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    names = list(spec.episodes)
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), sharex=True)
    for ax, panel in zip(axes.ravel(), spec.panels):
        j = names.index(panel.episode)
        t = run.time_s
        _mode_background(ax, t, run.mode[:, j])
        if panel.kind == "forces":
            ax.plot(t, run.pull_n[:, j], "b-", lw=1.5, label="$F_p$ (pull)")
            ax.plot(t, run.grip_force_n[:, j], "k-", lw=1.2, label="$F_G$ (grip)")
            ax.set_ylabel("force (N)")
        else:
            measured = run.accel_y_measured_m_s2[:, j]
            if not np.allclose(measured, run.accel_y_m_s2[:, j]):
                ax.plot(t, measured, color="0.55", lw=0.7, label="$a_y$ measured")
            ax.plot(t, run.accel_y_m_s2[:, j], "k-", lw=1.2, label="$a_y$ (true)")
            ax.axhline(4.0, color="k", ls=":", lw=0.8)
            ax.set_ylabel("$a_y$ (m/s², down +)")
        ax.set_title(f"({panel.letter}) {panel.episode.replace('_', ' ')}", fontsize=10)
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    handles = [Patch(color=MODE_COLOURS[m], alpha=0.35, label=MODE_NAMES[m]) for m in MODE_COLOURS]
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=9, frameon=False)
    gamma = FS_PRESETS[preset].gamma
    fig.suptitle(f"Thesis Fig. {spec.number} reproduced: {spec.title}  [{preset}, γ={gamma:g}]", fontsize=11)
    fig.tight_layout(rect=(0, 0.04, 1, 0.96))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def record_figure(spec: FigureSpec, run: ThesisRun, preset: str, path: Path) -> Path:
    """Write every signal of one figure to a Rerun recording (.rrd), no viewer."""
    import rerun as rr

    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream("handover_gripper_reproduction", recording_id=f"fig{spec.number}_{preset}")
    rec.save(str(path))
    times = [rr.TimeColumn("time", duration=run.time_s)]
    signals = {
        "pull_n": run.pull_n, "grip_force_n": run.grip_force_n, "grip_command_n": run.grip_command_n,
        "force_x_n": run.force_x_n, "force_y_n": run.force_y_n, "accel_y_m_s2": run.accel_y_m_s2,
        "accel_y_measured_m_s2": run.accel_y_measured_m_s2, "mode": run.mode.astype(float),
        "slide_m": run.slide_m,
    }
    for j, name in enumerate(spec.episodes):
        base = f"fig{spec.number}/{name}"
        for signal, values in signals.items():
            rr.send_columns(f"{base}/{signal}", indexes=times, columns=rr.Scalars.columns(scalars=values[:, j]),
                            recording=rec)
        mode_text = [MODE_NAMES[int(m)] for m in run.mode[:, j]]
        rr.send_columns(f"{base}/mode_name", indexes=times, columns=rr.TextLog.columns(text=mode_text), recording=rec)
    rec.flush()
    rec.disconnect()
    return path


# --------------------------------------------------------------------------- CLI


def reproduce(presets: list[str], img_dir: Path | None, rrd_dir: Path | None) -> tuple[list[Claim], list[Path]]:
    """Run all figures for each preset; write PNGs and recordings; return claims and files."""
    written: list[Path] = []
    claims = analysis_claims()
    for preset in presets:
        if preset not in FS_PRESETS:
            raise GripperError(f"unknown fail-safe preset {preset!r}; choose from {', '.join(FS_PRESETS)}")
        tag = PRESET_TAGS.get(preset, preset)
        metrics: FigureMetrics = {}
        for spec in figure_specs():
            run = run_figure(spec, preset)
            metrics[spec.number] = figure_metrics(spec, run)
            if img_dir is not None:
                written.append(plot_figure(spec, run, preset, img_dir / f"gripper_fig{spec.number}_{tag}.png"))
            if rrd_dir is not None:
                written.append(record_figure(spec, run, preset, rrd_dir / f"gripper_fig{spec.number}_{tag}.rrd"))
        claims.extend(simulation_claims(metrics, preset))
    return claims, written

