"""The figures of docs/performance.md (matplotlib, Agg, PNG), drawn by the CPU benches from
what they measured: per-service CPU before and after the lean stack, against the targets
(`test_bench_cpu.py`), and the idle stack's CPU by kind of thread (`test_bench_activations.py`).

Redraw the first from the last CPU bench's results without running it again::

    python -m tests.bench.cpu_plots out/bench/cpu.json docs/img/cpu_per_service.png
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

#: The colours of the kinds of thread (`activation_census.KINDS`), and of before / now.
KIND_COLOURS = {"Python main thread": "#264653", "other Python threads": "#2a9d8f",
                "Zenoh workers": "#e9c46a", "other native threads": "#8d99ae"}
BEFORE, NOW = "#b0b7c3", "#2a9d8f"


def _order(cores: Mapping[str, float]) -> list[str]:
    """Process names, busiest first (the total left out)."""
    return sorted((n for n in cores if n != "total"), key=lambda n: -cores[n])


def plot_cpu(results: Mapping[str, Any], path: Path, targets: Mapping[str, float]) -> None:
    """Per process, idle and episode CPU before and now (cores), and the stack's totals against
    `targets` ({"idle": cores, "episode": cores}), from `test_bench_cpu.py`'s results."""
    import matplotlib.pyplot as plt

    now, before = results["now"], results.get("before")
    names = sorted(set(_order(now["idle_cores"])) | set(_order(before["idle_cores"]) if before else []),
                   key=lambda n: -max(now["idle_cores"].get(n, 0.0), (before or now)["idle_cores"].get(n, 0.0)))
    wake = results.get("wake_cost_us", {}).get("alone")
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), constrained_layout=True,
                             gridspec_kw={"width_ratios": [3, 3, 2]})
    y = np.arange(len(names))
    for ax, key, title in ((axes[0], "idle_cores", "idle (20 s, after the episode)"),
                           (axes[1], "episode_cores", "one default episode")):
        if before:
            ax.barh(y + 0.2, [before[key].get(n, 0.0) for n in names], 0.4, color=BEFORE, label="before")
        ax.barh(y - 0.2, [now[key].get(n, 0.0) for n in names], 0.4, color=NOW, label="now")
        ax.set_yticks(y, names)
        ax.invert_yaxis()
        ax.set_xlabel("CPU, cores")
        ax.set_title(title)
        ax.legend(loc="lower right")
    totals = [("idle", "idle_cores"), ("episode", "episode_cores")]
    x = np.arange(len(totals))
    if before:
        axes[2].bar(x - 0.2, [before[k]["total"] for _, k in totals], 0.4, color=BEFORE, label="before")
    axes[2].bar(x + 0.2, [now[k]["total"] for _, k in totals], 0.4, color=NOW, label="now")
    for i, (label, _key) in enumerate(totals):
        axes[2].hlines(targets[label], i - 0.45, i + 0.45, colors="#9b2226", linestyles="--",
                       label="target" if i == 0 else None)
    axes[2].set_xticks(x, [label for label, _ in totals])
    axes[2].set_ylabel("whole stack, cores")
    axes[2].set_title("totals against the targets")
    axes[2].legend()
    fig.suptitle("Per-service CPU, before and after the lean stack"
                 + (f" (one wake of a Python thread: {wake:.0f} µs in this run)" if wake else ""))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_census(cores: Mapping[tuple[str, str], float], runs_per_s: Mapping[tuple[str, str], float],
                wake_us: float, path: Path) -> None:
    """Per process, its idle CPU by kind of thread (stacked, cores) and its runs a second by
    kind of thread (`activation_census.Census` figures)."""
    import matplotlib.pyplot as plt

    per_process: dict[str, float] = {}
    for (name, _kind), value in cores.items():
        per_process[name] = per_process.get(name, 0.0) + value
    names = _order(per_process)
    y = np.arange(len(names))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), constrained_layout=True, sharey=True)
    for ax, figures, label in ((axes[0], cores, "CPU, cores"), (axes[1], runs_per_s, "runs a second")):
        left = np.zeros(len(names))
        for kind, colour in KIND_COLOURS.items():
            widths = np.array([figures.get((n, kind), 0.0) for n in names])
            if widths.any():
                ax.barh(y, widths, left=left, color=colour, label=kind)
                left += widths
        ax.set_xlabel(label)
    axes[0].set_yticks(y, names)
    axes[0].invert_yaxis()
    axes[1].legend(loc="lower right")
    fig.suptitle(f"The idle stack by kind of thread (one bare wake of a Python thread: {wake_us:.0f} µs)")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        sys.stderr.write("usage: python -m tests.bench.cpu_plots RESULTS.json OUT.png\n")
        return 2
    try:
        results = json.loads(Path(args[0]).read_text())["results"]
    except (OSError, ValueError, KeyError) as exc:
        sys.stderr.write(f"cpu_plots: cannot read {args[0]}: {exc}\n")
        return 1
    plot_cpu(results, Path(args[1]), {"idle": 0.25, "episode": 0.5})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
