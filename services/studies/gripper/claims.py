"""The thesis's statements (§3.4–3.6) checked against what we compute: the comparison table of
`handover-study reproduce`.

`analysis_claims` checks the closed-form statements with `services.studies.gripper.analysis`;
`simulation_claims` checks the statements about Figures 20–23 on the metrics of one preset's
runs (measured by `services.studies.gripper.reproduce`); `claims_table` writes them as a
Markdown table. Times in s, forces in N, accelerations in m/s².
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from services.gripper.controllers.fail_safe import FS_PRESETS
from services.studies.gripper import analysis


@dataclass(frozen=True)
class Claim:
    """One row of the table: what the thesis states, what we get, and whether they agree."""

    source: str
    thesis: str
    ours: str
    agree: str  # "yes", "no", "partly"
    note: str = ""


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


#: Metrics of one preset's runs: figure number → episode name → metrics.
FigureMetrics = dict[int, dict[str, EpisodeMetrics]]


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


def _held(x: EpisodeMetrics) -> bool:
    """Never released and in the grasp mode at the end."""
    return math.isnan(x.release_time_s) and x.final_mode == "grasp"


def _dropping_held_claim(drop: EpisodeMetrics, preset: str) -> Claim:
    """Fig. 20b,d: the dropping episode slips but is held."""
    return Claim(
        "Fig. 20b,d", "dropping: a_y < 4 m/s² while pulled; grasp re-established after the pull",
        f"max a_y = {_fmt(drop.max_accel_y_m_s2, 'm/s²')}, slip from {_fmt(drop.first_slip_time_s, 's')}, "
        f"final mode {drop.final_mode}, F_G back to {_fmt(drop.final_grip_n, 'N')} "
        f"(start {_fmt(drop.initial_grip_n, 'N')}); "
        f"{drop.mode_switches} mode switches",
        "yes" if (drop.max_accel_y_m_s2 < 4.0 and _held(drop) and not math.isnan(drop.first_slip_time_s))
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
    )


def _figure20_claims(episodes: dict[str, EpisodeMetrics], preset: str) -> list[Claim]:
    """Fig. 20 (φ = 0°): taking released at once, dropping held, a_y before the release."""
    take, drop = episodes["taking"], episodes["dropping"]
    return [
        Claim(
            "Fig. 20a", "taking: F_G drops to zero once pulled; released immediately",
            f"released at t = {_fmt(take.release_time_s, 's')} (pull started at 1 s), "
            f"F_p then {_fmt(take.pull_at_release_n, 'N')}",
            "yes" if take.released_at_end else "no",
        ),
        _dropping_held_claim(drop, preset),
        Claim(
            "Fig. 20c", "taking: the object briefly accelerates downward before release",
            f"a_y > 0 before release: {take.accel_before_release} (max {_fmt(take.max_accel_y_m_s2, 'm/s²')})",
            "yes" if take.accel_before_release else "no",
        ),
    ]


def _figure21_claims(episodes: dict[str, EpisodeMetrics]) -> list[Claim]:
    """Fig. 21: taking at ±20°."""
    p20, m20 = episodes["taking_phi_p20"], episodes["taking_phi_m20"]
    return [Claim(
        "Fig. 21", "taking at ±20°: released immediately; at −20° a_y < 0 after release",
        f"+20°: released at {_fmt(p20.release_time_s, 's')}; −20°: released at {_fmt(m20.release_time_s, 's')}, "
        f"min a_y after release {_fmt(m20.min_accel_y_after_release_m_s2, 'm/s²')}",
        "yes" if (p20.released_at_end and m20.released_at_end and m20.min_accel_y_after_release_m_s2 < 0) else "no",
    )]


def _figure22_claims(episodes: dict[str, EpisodeMetrics]) -> list[Claim]:
    """Fig. 22: high and low friction."""
    th, dh, tl, dl = (episodes[n] for n in ("taking_high_mu", "dropping_high_mu", "taking_low_mu", "dropping_low_mu"))
    ok = (th.released_at_end and tl.released_at_end and _held(dh) and _held(dl)
          and dl.max_accel_y_slipping_m_s2 > dh.max_accel_y_slipping_m_s2)
    return [Claim(
        "Fig. 22", "taking released and dropping held for high and low friction; higher slip a_y with low friction",
        f"taking released: {th.released_at_end}/{tl.released_at_end}; dropping held: {_held(dh)}/{_held(dl)}; "
        f"max slip a_y high/low μ = {dh.max_accel_y_slipping_m_s2:.2f}/{dl.max_accel_y_slipping_m_s2:.2f} m/s²",
        "yes" if ok else "no",
    )]


def _figure23_claims(episodes: dict[str, EpisodeMetrics]) -> list[Claim]:
    """Fig. 23: dropping with noise on F_G (two readings of the SNR) and on a_y."""
    gn, an = episodes["dropping_grip_noise"], episodes["dropping_accel_noise"]
    gv = episodes["dropping_grip_noise_variance"]
    return [
        Claim(
            "Fig. 23a,c", "F_G noise (SNR 3 dB): a_y < 6 m/s², grasp re-established after the pull",
            f"max a_y = {_fmt(gn.max_accel_y_m_s2, 'm/s²')}, first release at {_fmt(gn.release_time_s, 's')}, "
            f"final mode {gn.final_mode}",
            "yes" if (gn.max_accel_y_m_s2 < 6.0 and gn.final_mode == "grasp") else "no",
            "SNR taken against the mean power of F_G (Matlab awgn 'measured'): σ ≈ 0.7·F_G, so the noisy grip "
            "crosses zero and the object is in free fall for single steps; against the variance of F_G the noise is "
            "far smaller",
        ),
        Claim(
            "Fig. 23a,c (SNR vs variance)", "as above, SNR taken against the variance of F_G instead",
            f"max a_y = {_fmt(gv.max_accel_y_m_s2, 'm/s²')}, first release at {_fmt(gv.release_time_s, 's')}, "
            f"final mode {gv.final_mode}",
            "yes" if (gv.max_accel_y_m_s2 < 6.0 and gv.final_mode == "grasp") else "no",
            "not plotted; the milder reading of 'SNR'",
        ),
        Claim(
            "Fig. 23b,d", "a_y noise (SNR 3 dB): the fall is prevented, grasp re-established",
            f"released: {not math.isnan(an.release_time_s)}, final mode {an.final_mode}, "
            f"max a_y {_fmt(an.max_accel_y_m_s2, 'm/s²')}",
            "yes" if (math.isnan(an.release_time_s) and an.final_mode == "grasp") else "no",
        ),
    ]


def simulation_claims(metrics: FigureMetrics, preset: str) -> list[Claim]:
    """Claims of §3.5 about Figures 20–23, checked on the metrics of runs made with `preset`."""
    claims = [
        *_figure20_claims(metrics[20], preset),
        *_figure21_claims(metrics[21]),
        *_figure22_claims(metrics[22]),
        *_figure23_claims(metrics[23]),
    ]
    return [replace(c, source=f"{c.source} [{preset}]") for c in claims]


def claims_table(claims: list[Claim]) -> str:
    """Markdown table of claims."""
    lines = ["| where | thesis states | we get | agree | note |", "|---|---|---|---|---|"]
    for c in claims:
        cells = (c.source, c.thesis, c.ours, c.agree, c.note)
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return "\n".join(lines) + "\n"
