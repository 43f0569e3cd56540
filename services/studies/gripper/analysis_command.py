"""Command line for the fail-safe analysis (thesis §3.4.3–3.4.4) and its figures.

Examples:
    handover-study failsafe fst --phi-deg 20 --preset FS1
    handover-study failsafe fbt --phi-deg 0 --preset FS-sim-g1 --no-integrator
    handover-study failsafe conditions --preset FS-sim-g5
    handover-study figures gripper --out docs/img          # Figures 18-19 (make_figures)
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from services.gripper.controllers.fail_safe import FS_PRESETS, FailSafeParams
from services.gripper.errors import GripperError
from services.studies.gripper import analysis


def _add_params(p: argparse.ArgumentParser) -> None:
    p.add_argument("--preset", default="FS-sim-g5", choices=sorted(FS_PRESETS), help="fail-safe parameter set")
    for name in ("alpha", "beta", "gamma", "f_margin_n", "k_i"):
        p.add_argument(f"--{name.replace('_', '-')}", type=float, dest=name, help=f"override {name}")
    p.add_argument("--mass-kg", type=float, default=0.2, help="object mass M, kg (default 0.2, Table IV)")
    p.add_argument("--mu-static", type=float, default=0.6, help="μ_s of the whole grip (default 0.6)")
    p.add_argument("--mu-kinetic", type=float, default=0.5, help="μ_k of the whole grip (default 0.5)")


def _params(args) -> tuple[FailSafeParams, analysis.ThesisPlant]:
    overrides = {k: getattr(args, k) for k in ("alpha", "beta", "gamma", "f_margin_n", "k_i")
                 if getattr(args, k) is not None}
    fs = replace(FS_PRESETS[args.preset], **overrides)
    plant = analysis.ThesisPlant(mass_kg=args.mass_kg, mu_static=args.mu_static, mu_kinetic=args.mu_kinetic)
    return fs, plant


def _describe(fs: FailSafeParams, plant: analysis.ThesisPlant) -> str:
    return (
        f"α={fs.alpha:g} β={fs.beta:g} γ={fs.gamma:g} F_margin={fs.f_margin_n:g} N k_i={fs.k_i:g}; "
        f"M={plant.mass_kg:g} kg (W={plant.weight_n:.3f} N) μs={plant.mu_static:g} μk={plant.mu_kinetic:g}"
    )


def _phis(args) -> np.ndarray:
    return np.radians(np.asarray(args.phi_deg, dtype=float))


def cmd_fst(args) -> int:
    fs, plant = _params(args)
    print(_describe(fs, plant))
    for phi in _phis(args):
        value = analysis.start_force_threshold_n(phi, fs, plant)
        printed = analysis.start_force_threshold_n(phi, fs, plant, printed_equation=True)
        print(f"φ = {math.degrees(phi):6.1f}°  F_ST = {value:8.4f} N   "
              f"(printed eq 3.12 without the square: {printed:.4f} N)")
    return 0


def cmd_fbt(args) -> int:
    fs, plant = _params(args)
    print(_describe(fs, plant))
    for phi in _phis(args):
        value = analysis.stable_force_threshold_n(phi, fs, plant, with_integrator=not args.no_integrator)
        which = "eq 3.16, no integrator" if args.no_integrator else "eq 3.20, with integrator"
        print(f"φ = {math.degrees(phi):6.1f}°  F_BT = {value:8.4f} N   ({which})")
    return 0


def cmd_conditions(args) -> int:
    fs, plant = _params(args)
    print(_describe(fs, plant))
    amin = analysis.rest_condition_alpha_min(fs, plant)
    ok = "holds" if analysis.rest_condition_holds(fs, plant) else "FAILS: the object slips at rest"
    print(f"rest condition (3.9): α ≥ {amin:.4f}  -> {ok}")
    print(f"tolerated downward acceleration (3.11): F_margin/β = {analysis.tolerated_accel_m_s2(fs):.4f} m/s²")
    print(f"φ_max (F_ST → ∞): {math.degrees(analysis.phi_max_rad(fs, plant)):.2f}°")
    for cap in args.max_pull_n:
        print(f"steepest φ with F_ST ≤ {cap:g} N: {math.degrees(analysis.phi_max_for_pull_rad(cap, fs, plant)):.2f}°")
    return 0


def make_figures(out_dir: Path, plant: analysis.ThesisPlant = analysis.TABLE_IV_PLANT) -> list[Path]:
    """Figures 18 and 19 (PNG): F_ST(φ) for γ = 1, 3, 5; F_ST and F_BT without/with integrator."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    base = FS_PRESETS["FS-sim-g1"]  # Table IV: α=10 β=3 F_margin=12 k_i=0.13
    phi_deg = np.linspace(-60.0, 40.0, 401)
    phi = np.radians(phi_deg)
    written = []

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for gamma, colour in ((1.0, "tab:blue"), (3.0, "tab:orange"), (5.0, "tab:green")):
        fs = replace(base, gamma=gamma)
        fst = analysis.start_force_threshold_n(phi, fs, plant)
        printed = analysis.start_force_threshold_n(phi, fs, plant, printed_equation=True)
        ax.plot(phi_deg, fst, color=colour, lw=1.8, label=f"γ = {gamma:g}")
        ax.plot(phi_deg, printed, color=colour, lw=0.9, ls="--")
        ax.axvline(math.degrees(analysis.phi_max_rad(fs, plant)), color=colour, lw=0.8, ls=":")
    ax.plot([], [], "k--", lw=0.9, label="printed eq 3.12 (square dropped)")
    ax.plot([], [], "k:", lw=0.8, label="φ_max (F_ST → ∞)")
    ax.set_ylim(0, 10)
    ax.set_xlabel("pull angle φ (deg, > 0 pulls down)")
    ax.set_ylabel("start force threshold F_ST (N)")
    ax.set_title("Thesis Fig. 18: F_ST(φ), Table IV set (α=10, β=3, F_margin=12 N), M=0.2 kg", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    path = out_dir / "gripper_fig18_fst.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    written.append(path)

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.0), sharey=True)
    fst = analysis.start_force_threshold_n(phi, base, plant)
    for ax, integrator, label in ((axes[0], False, "(a) eq 3.16, no integrator"),
                                  (axes[1], True, "(b) eq 3.20, with integrator k_i = 0.13")):
        fbt = analysis.stable_force_threshold_n(phi, base, plant, with_integrator=integrator)
        ax.plot(phi_deg, fst, "b-", lw=1.6, label="F_ST")
        ax.plot(phi_deg, np.where(np.isfinite(fbt), fbt, np.nan), "r-", lw=1.6, label="F_BT")
        unstable = ~np.isfinite(fbt)
        if np.any(unstable):
            ax.fill_between(phi_deg, 0, 20, where=unstable, color="r", alpha=0.08,
                            label="F_BT = ∞ (|a| > 1 at any pull)")
        ax.set_ylim(0, 20)
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("pull angle φ (deg)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    axes[0].set_ylabel("force (N)")
    fig.suptitle("Thesis Fig. 19: F_ST and F_BT, Table IV set as printed (γ = 1), M = 0.2 kg", fontsize=10)
    fig.tight_layout()
    path = out_dir / "gripper_fig19_fbt.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    written.append(path)
    return written


DESCRIPTION = ("Fail-safe law analysis (thesis §3.4.3-3.4.4): F_ST, F_BT, rest condition, tolerated "
               "acceleration, φ_max.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The analysis's sub-commands (fst, fbt, conditions) and their flags."""
    sub = parser.add_subparsers(dest="analysis", required=True, metavar="{fst,fbt,conditions}")
    p = sub.add_parser("fst", help="start force threshold F_ST(φ), eq 3.12 with the square restored")
    p.add_argument("--phi-deg", type=float, nargs="+", default=[0.0], help="pull angle(s), degrees (> 0 pulls down)")
    _add_params(p)
    p.set_defaults(analysis_func=cmd_fst)
    p = sub.add_parser("fbt", help="stable force threshold F_BT(φ), |a| = 1 on eq 3.20 (or 3.16)")
    p.add_argument("--phi-deg", type=float, nargs="+", default=[0.0], help="pull angle(s), degrees")
    p.add_argument("--no-integrator", action="store_true", help="use eq 3.16 (no integrator)")
    _add_params(p)
    p.set_defaults(analysis_func=cmd_fbt)
    p = sub.add_parser("conditions", help="rest condition (3.9), tolerated acceleration (3.11), φ_max")
    p.add_argument("--max-pull-n", type=float, nargs="*", default=[5.0, 10.0],
                   help="pull caps for a practical φ_max, N")
    _add_params(p)
    p.set_defaults(analysis_func=cmd_conditions)


def run(args: argparse.Namespace) -> int:
    """Run the chosen analysis; exit 1 on a failure."""
    try:
        return args.analysis_func(args)
    except (GripperError, OSError, ValueError) as exc:
        print(f"handover-study failsafe: error: {exc}", file=sys.stderr)
        return 1
