"""Reports of `handover-study sweep` (`services.studies.gripper.sweep`): the CSV (one row per
grid point and reference), the Markdown table, the plot (a line per figure for one parameter, a
heat map per figure for two) and the generated region of a docs page.

Rates are written in %, forces in N, times in s; a missing figure is "–".
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from services.gripper.errors import GripperError
from services.studies.gripper.sweep import PointStats, SweepResult

__all__ = ["REGION", "check_region", "markdown_table", "rewrite_region", "write_csv", "write_plot"]

#: The generated region of a docs page (`<!-- gripper-sweep:begin ... -->` … `<!-- gripper-sweep:end -->`).
REGION = "gripper-sweep"


def _f(v: float, digits: int = 2) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _pct(rate: float, ci: tuple[float, float]) -> str:
    if not math.isfinite(rate):
        return "–"
    return f"{100 * rate:.1f} [{_f(100 * ci[0], 1)}, {_f(100 * ci[1], 1)}]"


def row(p: PointStats, kind: str) -> dict:
    """One CSV row (rates as fractions, forces N, times s)."""
    d: dict = {"kind": kind, "label": p.label, **{f"param_{k}": v for k, v in p.params.items()},
               "episodes": p.episodes, "drops": p.drops, "drop_rate": p.drop_rate, "drop_ci_low": p.drop_ci[0],
               "drop_ci_high": p.drop_ci[1], "failures": p.failures, "failure_rate": p.failure_rate,
               "failure_ci_low": p.failure_ci[0], "failure_ci_high": p.failure_ci[1],
               "taking_episodes": p.taking_episodes, "handed_over": p.handed_over,
               "release_success_rate": p.release_success_rate, "release_success_ci_low": p.release_success_ci[0],
               "release_success_ci_high": p.release_success_ci[1], "overshoot_median_n": p.overshoot_median_n,
               "overshoot_p95_n": p.overshoot_p95_n, "overshoot_p95_ci_low_n": p.overshoot_p95_ci_n[0],
               "overshoot_p95_ci_high_n": p.overshoot_p95_ci_n[1], "release_time_median_s": p.release_time_median_s}
    d.update({f"drop_rate_{k}": v for k, v in p.drop_rate_by_behaviour.items()})
    return d


def write_csv(result: SweepResult, path: Path) -> Path:
    """Every grid point, then every reference (`kind` point / reference)."""
    rows = [row(p, "point") for p in result.points] + [row(p, "reference") for p in result.references]
    fields = list(dict.fromkeys(k for r in rows for k in r))
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    return path


def markdown_table(result: SweepResult) -> str:
    """One line per grid point, then the references (in italics); in bold the points with fewer
    drops than the controller's own parameters AND a p95 overshoot no higher than HI's."""
    own = result.references[0]
    hi = next((r for r in result.references if r.label == "HI"), None)
    head = ("| " + " | ".join(result.names) + " | drops % [95% CI] | failures % [95% CI] "
            "| release success % (taking) [95% CI] | overshoot median / p95 N [p95 95% CI] | release time median s |")
    lines = [head, "|" + "---|" * (len(result.names) + 5)]

    def cells(p: PointStats) -> str:
        return (f"{_pct(p.drop_rate, p.drop_ci)} | {_pct(p.failure_rate, p.failure_ci)} "
                f"| {_pct(p.release_success_rate, p.release_success_ci)} | {_f(p.overshoot_median_n)} / "
                f"{_f(p.overshoot_p95_n)} [{_f(p.overshoot_p95_ci_n[0])}, {_f(p.overshoot_p95_ci_n[1])}] "
                f"| {_f(p.release_time_median_s, 3)} |")

    for p in result.points:
        better = p.drop_ci[1] < own.drop_rate and (hi is None or p.overshoot_p95_n <= hi.overshoot_p95_n)
        values = " | ".join(f"{'**' if better else ''}{p.params[n]:.4g}{'**' if better else ''}" for n in result.names)
        lines.append(f"| {values} | {cells(p)}")
    for r in result.references:
        lines.append("| " + " | ".join([f"*{r.label}*"] + [""] * (len(result.names) - 1)) + f" | {cells(r)}")
    return "\n".join(lines)


def _values(result: SweepResult, i: int) -> np.ndarray:
    return np.array(list(dict.fromkeys(p.params[result.names[i]] for p in result.points)))


def write_plot(result: SweepResult, path: Path, log: tuple[bool, ...]) -> Path:
    """Drops and p95 overshoot against the parameter (95 % intervals shaded, the references as
    lines), or for two parameters a heat map of each with the controller's own point marked and
    the points above HI's p95 overshoot hatched. `log`: per axis, a log scale."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    hi = next((r for r in result.references if r.label == "HI"), None)
    title = (f"{result.controller}: {result.episodes} episodes per point (same episodes), population "
             f"{result.population}, seed {result.seed}")
    if len(result.names) == 1:
        fig = _line_plot(plt, result, log[0], hi)
    else:
        fig = _heat_plot(plt, result, log, hi)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _line_plot(plt, result: SweepResult, log: bool, hi: PointStats | None):
    x = _values(result, 0)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    series = (("drops %", lambda p: 100 * p.drop_rate, lambda p: [100 * c for c in p.drop_ci]),
              ("p95 overshoot N (taking)", lambda p: p.overshoot_p95_n, lambda p: list(p.overshoot_p95_ci_n)))
    for ax, (label, value, interval) in zip(axes, series):
        y = np.array([value(p) for p in result.points])
        ci = np.array([interval(p) for p in result.points], dtype=float)
        ax.plot(x, y, marker="o", color="#3060a0", label=result.controller)
        ax.fill_between(x, ci[:, 0], np.where(np.isfinite(ci[:, 1]), ci[:, 1], y), color="#3060a0", alpha=0.2,
                        label="95 % interval")
        for ref, style in zip(result.references, ("-", "--", ":", "-.")):
            ax.axhline(value(ref), color="k" if ref is hi else "#c05020", ls=style, lw=1, label=ref.label)
        ax.axvline(result.own_values[result.names[0]], color="#c05020", lw=0.8, alpha=0.6)
        ax.set_xscale("log" if log else "linear")
        ax.set_xlabel(result.names[0])
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    return fig


def _heat_plot(plt, result: SweepResult, log: tuple[bool, ...], hi: PointStats | None):
    from matplotlib import patheffects
    from matplotlib.patches import Rectangle

    xs, ys = _values(result, 1), _values(result, 0)  # first axis: rows (y), second: columns (x)
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    for ax, (label, value, cmap) in zip(axes, (("drops %", lambda p: 100 * p.drop_rate, "viridis"),
                                               ("p95 overshoot N", lambda p: p.overshoot_p95_n, "magma"))):
        z = np.array([value(p) for p in result.points]).reshape(len(ys), len(xs))
        mesh = ax.pcolormesh(np.arange(len(xs) + 1), np.arange(len(ys) + 1), z, cmap=cmap, shading="flat")
        fig.colorbar(mesh, ax=ax, label=label)
        above = np.array([hi is not None and p.overshoot_p95_n > hi.overshoot_p95_n for p in result.points])
        for (i, j), v in np.ndenumerate(z):
            ax.text(j + 0.5, i + 0.5, f"{v:.1f}", ha="center", va="center", fontsize=7, color="w",
                    path_effects=[patheffects.withStroke(linewidth=2, foreground="k")])
            if above.reshape(z.shape)[i, j]:
                ax.add_patch(Rectangle((j, i), 1, 1, fill=False, hatch="//", edgecolor="#dddddd", lw=0))
        ox, oy = (_grid_position(xs, result.own_values[result.names[1]], log[1]),
                  _grid_position(ys, result.own_values[result.names[0]], log[0]))
        ax.plot(ox, oy, marker="*", ms=16, color="#ff4040", mec="k")
        ax.set_xticks(np.arange(len(xs)) + 0.5, [f"{v:.3g}" for v in xs], rotation=45)
        ax.set_yticks(np.arange(len(ys)) + 0.5, [f"{v:.3g}" for v in ys])
        ax.set_xlabel(result.names[1])
        ax.set_ylabel(result.names[0])
        ax.set_title(f"{label}; ★ {result.controller}'s own values"
                     + ("; hatched: p95 above HI's" if hi is not None else ""), fontsize=9)
    return fig


def _grid_position(values: np.ndarray, v: float, log: bool) -> float:
    """Where value v falls on a heat map's cell axis (cell i spans [i, i+1], centre at i+0.5)."""
    f = np.log if log and v > 0 and np.all(values > 0) else (lambda a: a)
    return float(np.interp(f(v), f(values), np.arange(len(values)) + 0.5, left=0.0, right=len(values)))


def check_region(doc: Path) -> None:
    """`GripperError` unless `doc` is readable and has the sweep's generated region."""
    try:
        text = doc.read_text()
    except OSError as exc:
        raise GripperError(f"--doc {doc}: cannot read it ({exc.strerror})") from None
    _bounds(doc, text)


def _bounds(doc: Path, text: str) -> tuple[int, int]:
    begin, end = text.find(f"<!-- {REGION}:begin"), text.find(f"<!-- {REGION}:end -->")
    if begin < 0 or end < begin:
        raise GripperError(f"--doc {doc}: no <!-- {REGION}:begin --> ... <!-- {REGION}:end --> region to rewrite")
    return begin, end


def rewrite_region(doc: Path, body: str, source: str) -> Path:
    """Replace the sweep's generated region of `doc` by `body` (markers kept; `source`, the
    command that made it, goes in the begin marker)."""
    text = doc.read_text()
    begin, end = _bounds(doc, text)
    doc.write_text(text[:begin] + f"<!-- {REGION}:begin (generated by {source}) -->\n" + body.strip() + "\n"
                   + text[end:])
    return doc
