"""Reproduce thesis Figures 20–23 (§3.5) from the thesis model mode, with a comparison table.

Each figure is a batch of `robot_sim.thesis_model` scenarios run with a fail-safe preset:
"FS-sim-g5" (the §3.5 text, γ = 5) by default, "FS-sim-g1" (Table IV as printed, γ = 1) for
comparison. Outputs:
- PNG plots (matplotlib, Agg) with the system mode as background colour: red grasp,
  yellow slip, green release, as in the thesis;
- Rerun recordings (.rrd) of every signal, one per figure, written with `rr.save`-style
  file sinks (no viewer);
- a Markdown table comparing what the thesis states with what we compute.

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
from services.studies.gripper import analysis

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


@dataclass(frozen=True)
class EpisodeMetrics:
    """What the thesis's statements are about, for one episode (times s, forces N, m/s²)."""

    release_time_s: float  # first step in release mode (nan: never)
    final_mode: str
    released_at_end: bool
    pull_at_release_n: float  # F_p when the release mode is first entered (force overshoot)
    max_accel_y_m_s2: float
    max_accel_y_slipping_m_s2: float  # largest a_y while in the slip mode
    min_accel_y_after_release_m_s2: float
    accel_before_release: bool  # a_y > 0 at some step before the first release
    mode_switches: int
    first_slip_time_s: float
    slide_m: float  # integrated slide while slipping (diagnostic, not in the thesis)
    final_grip_n: float
    initial_grip_n: float


def episode_metrics(run: ThesisRun, episode: int) -> EpisodeMetrics:
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


# --------------------------------------------------------------------------- comparison table


@dataclass(frozen=True)
class Claim:
    source: str
    thesis: str
    ours: str
    agree: str  # "yes", "no", "partly"
    note: str = ""


def _fmt(x: float, unit: str = "", digits: int = 2) -> str:
    if isinstance(x, float) and math.isnan(x):
        return "never"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return f"{x:.{digits}f}{(' ' + unit) if unit else ''}"


def analysis_claims() -> list[Claim]:
    """Claims of §3.4.3–3.4.4 and §3.6.1.1 checked with `analysis`."""
    sim5, sim1 = FS_PRESETS["FS-sim-g5"], FS_PRESETS["FS-sim-g1"]
    plant = analysis.TABLE_IV_PLANT
    box = analysis.ThesisPlant(mass_kg=0.23)
    fs1, fs2, fs3 = FS_PRESETS["FS1"], FS_PRESETS["FS2"], FS_PRESETS["FS3"]
    sim3 = replace(sim5, gamma=3.0)
    fst = analysis.start_force_threshold_n
    claims = []
    f5 = fst(0.0, sim5, plant)
    claims.append(Claim("§3.5", "γ = 5 gives F_ST(0) < 1 N", f"F_ST(0) = {_fmt(f5, 'N')}", "yes" if f5 < 1 else "no"))
    over = {n: (fst(0.0, p, plant), fst(0.0, p, box)) for n, p in (("FS1", fs1), ("FS2", fs2), ("FS3", fs3))}
    stated = {"FS1": 2.0, "FS2": 4.0, "FS3": 3.0}
    for name, (light, heavy) in over.items():
        close = abs(heavy - stated[name]) <= 0.25 * stated[name]
        claims.append(Claim(
            "§3.6.1.1", f"{name}: force overshoot F_ST(0) ≈ {stated[name]:g} N",
            f"{_fmt(light, 'N')} (M = 0.2 kg), {_fmt(heavy, 'N')} (M = 0.23 kg, the test box)",
            "yes" if close else "no",
            "eq 3.12 with the square restored; the thesis does not say which mass its numbers used"
            + (f"; Fig. 18's γ = 3 curve (F_margin = 12 N, M = 0.2 kg) gives {fst(0.0, sim3, plant):.2f} N"
               if name == "FS1" else ""),
        ))
    order_ok = all(over["FS1"][k] < over["FS3"][k] < over["FS2"][k] for k in (0, 1))
    claims.append(Claim("issue", "overshoot FS1 < FS3 < FS2",
                        "holds for M = 0.2 and 0.23 kg" if order_ok else "does not hold", "yes" if order_ok else "no"))
    pm = math.degrees(analysis.phi_max_rad(sim3, plant))
    f20 = fst(math.radians(20.0), sim3, plant)
    claims.append(Claim(
        "§3.4.3, Fig. 18", "γ = 3: φ_max = 20°",
        f"asymptote φ_max = {pm:.1f}°; F_ST(20°) = {_fmt(f20, 'N')}",
        "partly",
        "F_ST grows without bound only at φ_max ≈ 26°; 20° is where F_ST reaches "
        f"{f20:.1f} N, plausibly where the thesis's plot ends",
    ))
    widen = [math.degrees(analysis.phi_max_rad(replace(sim5, gamma=g), plant)) for g in (1.0, 3.0, 5.0)]
    lower = [fst(0.0, replace(sim5, gamma=g), plant) for g in (1.0, 3.0, 5.0)]
    mono = widen[0] < widen[1] < widen[2] and lower[0] > lower[1] > lower[2]
    claims.append(Claim(
        "§3.4.3", "higher γ: lower F_ST and a wider range of angles",
        f"γ = 1, 3, 5: F_ST(0) = {', '.join(f'{x:.2f}' for x in lower)} N; "
        f"φ_max = {', '.join(f'{x:.1f}' for x in widen)}°",
        "yes" if mono else "no",
    ))
    amin = analysis.rest_condition_alpha_min(sim5, plant)
    claims.append(Claim("§3.5", "α = 10 satisfies the rest condition (3.9)", f"α_min = {amin:.2f}",
                        "yes" if sim5.alpha >= amin else "no"))
    claims.append(Claim("§3.5", "β = 3, F_margin = 12 N tolerate 4 m/s² (3.11)",
                        f"{analysis.tolerated_accel_m_s2(sim5):.2f} m/s²", "yes"))
    phis = np.radians(np.linspace(-40.0, 10.0, 26))
    fbt = analysis.stable_force_threshold_n(phis, sim1, plant, with_integrator=False)
    fst1 = fst(phis, sim1, plant)
    finite = np.isfinite(fst1)
    above = bool(np.all(fbt[finite] > fst1[finite]))
    claims.append(Claim(
        "§3.4.4, Fig. 19a", "without integrator F_BT > F_ST (Table IV set)",
        f"F_BT(0) = {_fmt(float(analysis.stable_force_threshold_n(0.0, sim1, plant, with_integrator=False)), 'N')} vs "
        f"F_ST(0) = {_fmt(float(fst(0.0, sim1, plant)), 'N')}; F_BT > F_ST on −40°…10°: {above}",
        "yes" if above else "no",
        "with γ = 5 the recursion has |a| > 1 for every pull (F_BT = ∞)",
    ))
    phi_deg = np.arange(-60.0, 60.5, 1.0)
    fbt_i = analysis.stable_force_threshold_n(np.radians(phi_deg), sim1, plant, with_integrator=True)
    stable = phi_deg[fbt_i == 0.0]
    plotted = (phi_deg >= -30.0) & (phi_deg <= 30.0)
    claims.append(Claim(
        "§3.4.4, Fig. 19b", "with the integrator the pole is inside the unit circle for all pulls",
        f"F_BT = 0 (|a| ≤ 1 for every pull) for φ from {stable.min():.0f}° to {stable.max():.0f}° (1° grid); "
        f"steeper upward pulls: F_BT = {_fmt(float(fbt_i[0]), 'N')} at −60°",
        "yes" if np.all(fbt_i[plotted] == 0.0) and stable.min() <= -30 else "partly",
        "for steep upward pulls that lift more than the weight (W + F_p sin φ < 0) eq 3.20 gives a > 1: the "
        "grip runs away from its fixed point (to zero, i.e. release, from below it)",
    ))
    return claims


def simulation_claims(results: dict[int, tuple[FigureSpec, ThesisRun]], preset: str) -> list[Claim]:
    """Claims of §3.5 about Figures 20–23, checked on runs made with `preset`."""

    def m(fig: int, name: str) -> EpisodeMetrics:
        spec, run = results[fig]
        return episode_metrics(run, list(spec.episodes).index(name))

    def held(x: EpisodeMetrics) -> bool:
        return math.isnan(x.release_time_s) and x.final_mode == "grasp"

    claims = []
    take, drop = m(20, "taking"), m(20, "dropping")
    claims.append(Claim(
        "Fig. 20a", "taking: F_G drops to zero once pulled; released immediately",
        f"released at t = {_fmt(take.release_time_s, 's')} (pull started at 1 s), "
        f"F_p then {_fmt(take.pull_at_release_n, 'N')}",
        "yes" if take.released_at_end else "no",
    ))
    claims.append(Claim(
        "Fig. 20b,d", "dropping: a_y < 4 m/s² while pulled; grasp re-established after the pull",
        f"max a_y = {_fmt(drop.max_accel_y_m_s2, 'm/s²')}, slip from {_fmt(drop.first_slip_time_s, 's')}, "
        f"final mode {drop.final_mode}, F_G back to {_fmt(drop.final_grip_n, 'N')} "
        f"(start {_fmt(drop.initial_grip_n, 'N')}); "
        f"{drop.mode_switches} mode switches",
        "yes" if (drop.max_accel_y_m_s2 < 4.0 and held(drop) and not math.isnan(drop.first_slip_time_s))
        else ("no" if math.isnan(drop.first_slip_time_s) else "partly"),
        (
            f"the pull (2 N) stays below F_ST(0) = {analysis.start_force_threshold_n(0.0, FS_PRESETS[preset]):.2f} N, "
            "so nothing slips; the thesis's yellow slip band needs γ = 5 (its text), not Table IV's γ = 1"
        )
        if math.isnan(drop.first_slip_time_s)
        else (
            f"the model has no velocity: integrating its slip acceleration the object slides {drop.slide_m:.2f} m "
            "while 'held', far beyond any finger pad"
        ),
    ))
    claims.append(Claim(
        "Fig. 20c", "taking: the object briefly accelerates downward before release",
        f"a_y > 0 before release: {take.accel_before_release} (max {_fmt(take.max_accel_y_m_s2, 'm/s²')})",
        "yes" if take.accel_before_release else "no",
    ))
    p20, m20 = m(21, "taking_phi_p20"), m(21, "taking_phi_m20")
    claims.append(Claim(
        "Fig. 21", "taking at ±20°: released immediately; at −20° a_y < 0 after release",
        f"+20°: released at {_fmt(p20.release_time_s, 's')}; −20°: released at {_fmt(m20.release_time_s, 's')}, "
        f"min a_y after release {_fmt(m20.min_accel_y_after_release_m_s2, 'm/s²')}",
        "yes" if (p20.released_at_end and m20.released_at_end and m20.min_accel_y_after_release_m_s2 < 0) else "no",
    ))
    th, dh, tl, dl = (m(22, n) for n in ("taking_high_mu", "dropping_high_mu", "taking_low_mu", "dropping_low_mu"))
    ok = (th.released_at_end and tl.released_at_end and held(dh) and held(dl)
          and dl.max_accel_y_slipping_m_s2 > dh.max_accel_y_slipping_m_s2)
    claims.append(Claim(
        "Fig. 22", "taking released and dropping held for high and low friction; higher slip a_y with low friction",
        f"taking released: {th.released_at_end}/{tl.released_at_end}; dropping held: {held(dh)}/{held(dl)}; "
        f"max slip a_y high/low μ = {dh.max_accel_y_slipping_m_s2:.2f}/{dl.max_accel_y_slipping_m_s2:.2f} m/s²",
        "yes" if ok else "no",
    ))
    gn, an = m(23, "dropping_grip_noise"), m(23, "dropping_accel_noise")
    claims.append(Claim(
        "Fig. 23a,c", "F_G noise (SNR 3 dB): a_y < 6 m/s², grasp re-established after the pull",
        f"max a_y = {_fmt(gn.max_accel_y_m_s2, 'm/s²')}, first release at {_fmt(gn.release_time_s, 's')}, "
        f"final mode {gn.final_mode}",
        "yes" if (gn.max_accel_y_m_s2 < 6.0 and gn.final_mode == "grasp") else "no",
        "SNR taken against the mean power of F_G (Matlab awgn 'measured'): σ ≈ 0.7·F_G, so the noisy grip "
        "crosses zero and the object is in free fall for single steps; against the variance of F_G the noise is "
        "far smaller",
    ))
    gv = m(23, "dropping_grip_noise_variance")
    claims.append(Claim(
        "Fig. 23a,c (SNR vs variance)", "as above, SNR taken against the variance of F_G instead",
        f"max a_y = {_fmt(gv.max_accel_y_m_s2, 'm/s²')}, first release at {_fmt(gv.release_time_s, 's')}, "
        f"final mode {gv.final_mode}",
        "yes" if (gv.max_accel_y_m_s2 < 6.0 and gv.final_mode == "grasp") else "no",
        "not plotted; the milder reading of 'SNR'",
    ))
    claims.append(Claim(
        "Fig. 23b,d", "a_y noise (SNR 3 dB): the fall is prevented, grasp re-established",
        f"released: {not math.isnan(an.release_time_s)}, final mode {an.final_mode}, "
        f"max a_y {_fmt(an.max_accel_y_m_s2, 'm/s²')}",
        "yes" if (math.isnan(an.release_time_s) and an.final_mode == "grasp") else "no",
    ))
    return [replace(c, source=f"{c.source} [{preset}]") for c in claims]


def claims_table(claims: list[Claim]) -> str:
    """Markdown table of claims."""
    lines = ["| where | thesis states | we get | agree | note |", "|---|---|---|---|---|"]
    for c in claims:
        cells = (c.source, c.thesis, c.ours, c.agree, c.note)
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- CLI


def reproduce(presets: list[str], img_dir: Path | None, rrd_dir: Path | None) -> tuple[list[Claim], list[Path]]:
    """Run all figures for each preset; write PNGs and recordings; return claims and files."""
    written: list[Path] = []
    claims = analysis_claims()
    for preset in presets:
        if preset not in FS_PRESETS:
            raise GripperError(f"unknown fail-safe preset {preset!r}; choose from {', '.join(FS_PRESETS)}")
        tag = PRESET_TAGS.get(preset, preset)
        results = {}
        for spec in figure_specs():
            run = run_figure(spec, preset)
            results[spec.number] = (spec, run)
            if img_dir is not None:
                written.append(plot_figure(spec, run, preset, img_dir / f"gripper_fig{spec.number}_{tag}.png"))
            if rrd_dir is not None:
                written.append(record_figure(spec, run, preset, rrd_dir / f"gripper_fig{spec.number}_{tag}.rrd"))
        claims.extend(simulation_claims(results, preset))
    return claims, written

