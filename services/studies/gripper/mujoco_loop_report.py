"""Tables, CSV and plot of the closed-loop comparison of both plants (`mujoco_loop`,
`mujoco_loop_stats`): rates in %, forces in N, times in s."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from services.studies.gripper.episodes import RECEIVER_KINDS
from services.studies.gripper.mujoco_loop import PLANTS, LoopResult
from services.studies.gripper.mujoco_loop_stats import Flips, PlantStats

__all__ = ["REGION", "summary_table", "flips_table", "flip_lines", "mcnemar_lines", "doc_region", "write_csv",
           "write_episodes_csv", "write_plot", "PLOT_NAME"]

#: The generated region in docs/contact.md (`<!-- crosscheck-loop-table:begin ... -->`).
REGION = "crosscheck-loop-table"
PLOT_NAME = "contact_crosscheck_closed_loop.png"
_LABEL = {"ours": "ours", "mujoco": "MuJoCo"}


def _pct(v: float) -> str:
    return "–" if math.isnan(v) else f"{100 * v:.1f}"


def _ci(ci: tuple[float, float], scale: float = 100.0, digits: int = 1) -> str:
    lo, hi = ci
    return "" if math.isnan(lo) else f" [{scale * lo:.{digits}f}, {scale * hi:.{digits}f}]"


def _num(v: float, digits: int = 2) -> str:
    return "–" if math.isnan(v) else f"{v:.{digits}f}"


def summary_table(rows: list[PlantStats]) -> str:
    """One row per controller and plant: drops, release success, overshoot, release time."""
    lines = ["| controller | plant | drops % [95 % CI] | release success % [95 % CI] | overshoot median N [95 % CI] "
             "| overshoot p95 N [95 % CI] | release time median s |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        s = r.stats
        lines.append(f"| {s.controller} | {_LABEL[r.plant]} | {_pct(s.drop_rate)}{_ci(s.drop_ci)} "
                     f"| {_pct(s.release_success_rate)}{_ci(s.release_success_ci)} "
                     f"| {_num(s.overshoot_median_n)}{_ci(r.overshoot_median_ci, 1.0, 2)} "
                     f"| {_num(s.overshoot_p95_n)}{_ci(r.overshoot_p95_ci, 1.0, 2)} "
                     f"| {_num(s.release_time_median_s, 3)} |")
    return "\n".join(lines)


def flips_table(rows: list[Flips]) -> str:
    """Per controller: drop-verdict flips (ours-only / MuJoCo-only drops) and handover flips,
    per receiver kind and overall."""
    kinds = [k for k in RECEIVER_KINDS if any(f.kind == k for f in rows)]
    header = "| controller | " + " | ".join(f"{k} (n)" for k in kinds) + " | all (n) |"
    lines = [header, "|---|" + "---|" * (len(kinds) + 1)]
    by = {(f.controller, f.kind): f for f in rows}
    for c in dict.fromkeys(f.controller for f in rows):
        cells = []
        for k in kinds + ["all"]:
            f = by[(c, k)]
            cells.append(f"{len(f.ours_only_drops)} / {len(f.mujoco_only_drops)} / {len(f.handover_flips)} "
                         f"({f.episodes})")
        lines.append(f"| {c} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def flip_lines(rows: list[Flips], limit: int = 20) -> list[str]:
    """The flipping episodes' indices, per controller (at most `limit` per list)."""
    out = []
    for f in rows:
        if f.kind != "all":
            continue
        for label, idx in (("ours-only drops", f.ours_only_drops), ("MuJoCo-only drops", f.mujoco_only_drops),
                           ("handover flips", f.handover_flips)):
            if idx:
                more = f" … ({len(idx)} in all)" if len(idx) > limit else ""
                out.append(f"{f.controller}, {label}: " + ", ".join(map(str, idx[:limit])) + more)
    return out


def _p(p: float) -> str:
    return f"{p:.2g}" if p > 0 else "< 1e-300"


def mcnemar_lines(rows: list[dict]) -> list[str]:
    """McNemar exact tests as lines: the two discordant counts and the p-value."""
    return [f"{r['test']}: {r['controller']} — {r['a']}-only drops {r['only_a_drops']}, {r['b']}-only drops "
            f"{r['only_b_drops']}, p = {_p(r['p_value'])}" for r in rows]


def doc_region(result: LoopResult, rows: list[PlantStats], flip_rows: list[Flips], tests: list[dict],
               command: str) -> str:
    """The docs' generated region: the run, the summary table, flips, McNemar, flipping episodes."""
    flips_list = flip_lines(flip_rows)
    return "\n".join([
        f"{result.episodes} episodes per controller, population `{result.population}`, seed {result.seed}, "
        f"μ_k = μ_s on both plants (`{command}`); MuJoCo {result.episodes_per_s('mujoco'):.1f} episodes/s, "
        f"ours {result.episodes_per_s('ours'):.1f} episodes/s per worker.", "",
        summary_table(rows), "",
        "Verdict flips between the plants, per receiver kind: ours-only drops / MuJoCo-only drops / handover "
        "flips (episodes):", "", flips_table(flip_rows), "",
        "McNemar exact tests of paired drops:", "", *[f"- {line}" for line in mcnemar_lines(tests)], "",
        "Flipping episodes (index in the run; replay with `--replay INDEX`):" + (" none." if not flips_list else ""),
        *[f"- {line}" for line in flips_list]])


def write_csv(rows: list[PlantStats], path: Path) -> Path:
    """One row per controller and plant (the benchmark's columns plus the plant and the
    overshoot intervals)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    flat = []
    for r in rows:
        d = {"plant": r.plant, **r.stats.row()}
        d.update(overshoot_median_ci_low_n=r.overshoot_median_ci[0],
                 overshoot_median_ci_high_n=r.overshoot_median_ci[1],
                 overshoot_p95_ci_low_n=r.overshoot_p95_ci[0], overshoot_p95_ci_high_n=r.overshoot_p95_ci[1])
        flat.append(d)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(flat[0]))
        w.writeheader()
        w.writerows(flat)
    return path


def write_episodes_csv(result: LoopResult, path: Path) -> Path:
    """One row per episode and controller: the draws and both plants' verdicts."""
    path.parent.mkdir(parents=True, exist_ok=True)
    d = result.draws
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["index", "kind", "mass_kg", "mu", "pull_angle_deg", "controller"]
                   + [f"{p}_{q}" for p in PLANTS for q in ("dropped", "handed_over", "overshoot_n", "release_time_s")])
        for c, per in result.outcomes.items():
            for i in range(result.episodes):
                w.writerow([int(d["index"][i]), RECEIVER_KINDS[int(d["kind"][i])], f"{d['mass_kg'][i]:.4f}",
                            f"{d['mu'][i]:.4f}", f"{np.degrees(d['pull_angle_rad'][i]):.2f}", c]
                           + [v for p in PLANTS for v in (bool(per[p].dropped[i]), bool(per[p].handed_over[i]),
                                                         f"{per[p].force_overshoot_n[i]:.4f}",
                                                         f"{per[p].release_time_s[i]:.4f}")])
    return path


def write_plot(result: LoopResult, rows: list[PlantStats], path: Path) -> Path:
    """Drop rate and release success per controller on both plants, with 95 % Wilson intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(dict.fromkeys(r.stats.controller for r in rows))
    x = np.arange(len(names))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, (attr, ci, title) in zip(axes, (("drop_rate", "drop_ci", "drop rate (all episodes)"),
                                            ("release_success_rate", "release_success_ci",
                                             "release success (taking episodes)"))):
        for j, (plant, color) in enumerate((("ours", "#6a8fc8"), ("mujoco", "#d08c4a"))):
            stats = [next(r.stats for r in rows if r.plant == plant and r.stats.controller == n) for n in names]
            val = np.array([100 * getattr(s, attr) for s in stats])
            lo = np.array([100 * getattr(s, ci)[0] for s in stats])
            hi = np.array([100 * getattr(s, ci)[1] for s in stats])
            pos = x + (j - 0.5) * 0.38
            ax.bar(pos, val, width=0.38, color=color, label=_LABEL[plant])
            ax.errorbar(pos, val, yerr=[val - lo, hi - val], fmt="none", ecolor="k", capsize=3)
        ax.set_xticks(x, names, rotation=30, ha="right")
        ax.set_ylabel("%")
        ax.set_title(f"{title}, 95 % Wilson CI")
        ax.legend()
    fig.suptitle(f"Closed loop on both plants (μ_k = μ_s): {result.episodes} episodes per controller, "
                 f"{result.population}, seed {result.seed}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
