"""Reports of the release-controller benchmark (`services.studies.gripper.benchmark`): the
headline, per-sub-population and drop-attribution Markdown tables, the per-controller and
per-sub-population CSVs and the PNG plots.

Rates are written in %, forces in N, times in s; a missing figure (no episode to judge) is "–".
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from services.studies.gripper.benchmark import BenchResult, ControllerStats, SubpopulationStats


def _f(v: float, digits: int = 2) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def markdown_table(rows: list[ControllerStats]) -> str:
    """The headline table (rates in %)."""
    head = ("| controller | drop rate % [95% CI] | release success % (taking) [95% CI] | overshoot median / p95 N "
            "| release time median s | mode switches / ep | drops: taking / dropping / hesitating / bumping % |")
    lines = [head, "|" + "---|" * 7]
    for s in rows:
        b = s.drop_rate_by_behaviour
        lines.append(
            f"| {s.controller} | {100 * s.drop_rate:.1f} [{100 * s.drop_ci[0]:.1f}, {100 * s.drop_ci[1]:.1f}] "
            f"| {100 * s.release_success_rate:.1f} [{100 * s.release_success_ci[0]:.1f}, "
            f"{100 * s.release_success_ci[1]:.1f}] | {_f(s.overshoot_median_n)} / {_f(s.overshoot_p95_n)} "
            f"| {_f(s.release_time_median_s, 3)} | {_f(s.mode_switches_mean)} "
            f"| {' / '.join(_f(100 * b[k], 1) for k in ('taking', 'dropping', 'hesitating', 'bumping'))} |")
    return "\n".join(lines)


def _pct_ci(rate: float, ci: tuple[float, float]) -> str:
    if rate is None or math.isnan(rate):
        return "–"
    return f"{100 * rate:.1f} [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"


def subpopulation_table(rows: list[SubpopulationStats]) -> str:
    """One row per sub-population per controller, then the overall rows (rates in %;
    handovers, objects held to the end of the episode (neither released nor dropped),
    release success, overshoot and release time over the taking receivers only, "–" where a
    sub-population has none)."""
    lines = ["| receiver | gripper | controller | episodes | drops | drop rate % [95% CI] "
             "| handed over / held to the end / taking "
             "| release success % [95% CI] | overshoot median / p95 N | release time median s |",
             "|" + "---|" * 10]
    for r in rows:
        s = r.stats
        taking = s.taking_episodes > 0
        handed = f"{s.handed_over} / {s.held_to_end} / {s.taking_episodes}" if taking else "–"
        over = f"{_f(s.overshoot_median_n)} / {_f(s.overshoot_p95_n)}" if taking else "–"
        lines.append(f"| {r.receiver} | {r.gripper} | {s.controller} | {s.episodes} | {s.drops} "
                     f"| {_pct_ci(s.drop_rate, s.drop_ci)} | {handed} "
                     f"| {_pct_ci(s.release_success_rate, s.release_success_ci)} | {over} "
                     f"| {_f(s.release_time_median_s, 3)} |")
    return "\n".join(lines)


def gripper_table(rows: list[SubpopulationStats]) -> str:
    """Per gripper, per controller: drop rate, release success and overshoot over the taking
    receivers; the gripper's best controller (fewest drops; then more handovers) in bold."""
    lines = ["| gripper | controller | episodes | drop rate % [95% CI] | release success % (taking) [95% CI] "
             "| overshoot median / p95 N |", "|" + "---|" * 6]
    for gripper in dict.fromkeys(r.gripper for r in rows):
        group = [r.stats for r in rows if r.gripper == gripper]
        best = min(group, key=lambda s: (s.drop_rate, -s.release_success_rate)).controller
        for s in group:
            name = f"**{s.controller}**" if s.controller == best else s.controller
            lines.append(f"| {gripper} | {name} | {s.episodes} | {_pct_ci(s.drop_rate, s.drop_ci)} "
                         f"| {_pct_ci(s.release_success_rate, s.release_success_ci)} "
                         f"| {_f(s.overshoot_median_n)} / {_f(s.overshoot_p95_n)} |")
    return "\n".join(lines)


def paired_lines(tests: list[dict]) -> str:
    """One Markdown bullet per paired drop test (`benchmark.per_gripper_paired_tests`)."""
    out = []
    for t in tests:
        p = f"= {t['p_value']:.2g}" if t["p_value"] > 0 else "< 1e-300"
        out.append(f"- {t['gripper']}: {t['a']} vs {t['b']}: {t['a']}-only drops {t['only_a_drops']}, "
                   f"{t['b']}-only {t['only_b_drops']}, McNemar exact p {p}")
    return "\n".join(out)


def write_subpopulation_csv(rows: list[SubpopulationStats], path: Path) -> Path:
    """The per-sub-population figures as CSV (receiver, gripper, then `ControllerStats.row`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    dicts = [{"receiver": r.receiver, "gripper": r.gripper, **r.stats.row()} for r in rows]
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(dicts[0]))
        writer.writeheader()
        writer.writerows(dicts)
    return path


def attribution_table(rows: list[dict]) -> str:
    """Markdown table of `benchmark.drop_attribution` (rates in % of all episodes)."""
    lines = ["| controller | drops % | unavoidable % | actuator-limited % | receiver let go % "
             "| controller drops % [95% CI] | controller drops: taking / dropping / hesitating / bumping % |",
             "|" + "---|" * 7]
    for r in rows:
        lo, hi = r["controller_drop_ci"]
        lines.append(
            f"| {r['controller']} | {100 * r['drop_rate']:.1f} | {100 * r['unavoidable_rate']:.1f} "
            f"| {100 * r['actuator_limited_rate']:.1f} | {100 * r['receiver_let_go_rate']:.1f} "
            f"| {100 * r['controller_drop_rate']:.1f} [{100 * lo:.1f}, {100 * hi:.1f}] | "
            + " / ".join(_f(100 * r[f'controller_drop_rate_{k}'], 1)
                         for k in ('taking', 'dropping', 'hesitating', 'bumping')) + " |")
    return "\n".join(lines)


def write_csv(rows: list[ControllerStats], path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    dicts = [r.row() for r in rows]
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(dicts[0]))
        writer.writeheader()
        writer.writerows(dicts)
    return path


def _binned_drop(result: BenchResult, name: str, values: np.ndarray, edges: np.ndarray):
    idx = np.clip(np.digitize(values, edges) - 1, 0, len(edges) - 2)
    d = result.outcomes[name].dropped
    rate = np.array([d[idx == i].mean() if np.any(idx == i) else np.nan for i in range(len(edges) - 1)])
    return 0.5 * (edges[:-1] + edges[1:]), rate


def write_plots(result: BenchResult, rows: list[ControllerStats], out_dir: Path,
                prefix: str = "gripper_bench") -> list[Path]:
    """Drop rate with CIs per controller; drop rate vs mass, friction and pull angle;
    overshoot distributions (taking episodes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    names = [r.controller for r in rows]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    x = np.arange(len(rows))
    for k, (attr, ci, title) in enumerate((("drop_rate", "drop_ci", "drop rate (all episodes)"),
                                            ("release_success_rate", "release_success_ci",
                                             "release success (taking episodes)"))):
        val = np.array([100 * getattr(r, attr) for r in rows])
        lo = np.array([100 * getattr(r, ci)[0] for r in rows])
        hi = np.array([100 * getattr(r, ci)[1] for r in rows])
        ax[k].bar(x, val, color="#6a8fc8")
        ax[k].errorbar(x, val, yerr=[val - lo, hi - val], fmt="none", ecolor="k", capsize=4)
        ax[k].set_xticks(x, names, rotation=30, ha="right")
        ax[k].set_ylabel("%")
        ax[k].set_title(f"{title}, 95 % Wilson CI")
    fig.suptitle(f"{rows[0].episodes} episodes per controller, seed {result.seed}")
    fig.tight_layout()
    p = out_dir / f"{prefix}_rates.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)

    fig, ax = plt.subplots(1, 3, figsize=(14, 4), sharey=True)
    for name in names:
        for k, (vals, edges, label) in enumerate((
                (result.mass_kg, np.linspace(0.05, 0.6, 12), "object mass, kg"),
                (result.mu_static, np.linspace(0.2, 0.9, 8), "μ_s"),
                (np.degrees(result.pull_angle_rad), np.linspace(-45, 45, 10), "pull angle φ, ° (> 0 down)"))):
            c, r = _binned_drop(result, name, vals, edges)
            ax[k].plot(c, 100 * r, marker="o", label=name)
            ax[k].set_xlabel(label)
    ax[0].set_ylabel("drop rate, %")
    ax[2].legend(fontsize=8)
    fig.suptitle("where the controllers drop objects (all behaviours)")
    fig.tight_layout()
    p = out_dir / f"{prefix}_drop_vs_params.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)

    fig, ax = plt.subplots(figsize=(8, 4))
    take = result.behaviour == 0
    data = [result.outcomes[n].force_overshoot_n[take] for n in names]
    ax.boxplot(data, whis=(5, 95), showfliers=False)
    ax.set_xticks(np.arange(1, len(names) + 1), names, rotation=30, ha="right")
    ax.set_ylabel("force overshoot, N")
    ax.set_title("receiver force before release (taking episodes; whiskers p5–p95)")
    fig.tight_layout()
    p = out_dir / f"{prefix}_overshoot.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)
    return paths


def write_subpopulation_plot(rows: list[SubpopulationStats], out_dir: Path,
                             prefix: str = "gripper_bench") -> Path:
    """Drop rate (every receiver kind) and release success (taking kinds) per sub-population
    and controller with 95 % Wilson intervals: one column of panels per gripper class."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in rows if r.gripper != "all"]
    grippers = list(dict.fromkeys(r.gripper for r in rows))
    receivers = list(dict.fromkeys(r.receiver for r in rows))
    names = list(dict.fromkeys(r.stats.controller for r in rows))
    taking = [k for k in receivers if any(r.receiver == k and r.stats.taking_episodes for r in rows)]
    cell = {(r.receiver, r.gripper, r.stats.controller): r.stats for r in rows}
    fig, axes = plt.subplots(2, len(grippers), figsize=(4.2 * len(grippers), 7.5), sharey="row", squeeze=False)
    width = 0.8 / len(names)
    for col, g in enumerate(grippers):
        for row, (kinds, attr, ci, title) in enumerate((
                (receivers, "drop_rate", "drop_ci", "drop rate, %"),
                (taking, "release_success_rate", "release_success_ci", "release success (taking), %"))):
            ax = axes[row][col]
            for j, name in enumerate(names):
                stats = [cell.get((k, g, name)) for k in kinds]
                val = np.array([100 * getattr(s, attr) if s else np.nan for s in stats])
                lo = np.array([100 * getattr(s, ci)[0] if s else np.nan for s in stats])
                hi = np.array([100 * getattr(s, ci)[1] if s else np.nan for s in stats])
                x = np.arange(len(kinds)) + (j - (len(names) - 1) / 2) * width
                ax.bar(x, val, width, label=name)
                ax.errorbar(x, val, yerr=[val - lo, hi - val], fmt="none", ecolor="k", capsize=2, lw=0.8)
            ax.set_xticks(np.arange(len(kinds)), kinds, rotation=35, ha="right", fontsize=8)
            ax.set_title(g if row == 0 else "", fontsize=10)
            if col == 0:
                ax.set_ylabel(title)
    axes[0][0].legend(fontsize=8)
    fig.suptitle("per sub-population (receiver kind × gripper class), 95 % Wilson CI")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{prefix}_subpopulations.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
