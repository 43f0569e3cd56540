"""The report's plots (matplotlib, Agg backend, PNG): outcome by behaviour, posture and
height band; the distributions of the handover times."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from services.studies.evaluation.summary import group_order, height_band

#: Outcome colours, one per outcome the records can hold.
_COLOURS = {"released": "#2a9d8f", "timeout": "#e9c46a", "aborted": "#f4a261", "failed": "#e76f51",
            "protective_stop": "#9b2226", "dropped": "#6d597a", "no_summary": "#8d99ae", "stack_error": "#2b2d42"}


def _outcome_bars(ax: Any, records: Sequence[dict[str, Any]], key: Callable[[dict[str, Any]], str], title: str) -> None:
    groups = sorted({key(r) for r in records}, key=group_order)
    counts = {g: Counter(str(r.get("outcome")) for r in records if key(r) == g) for g in groups}
    bottom = np.zeros(len(groups))
    for outcome in [o for o in _COLOURS if any(c[o] for c in counts.values())]:
        heights = np.array([counts[g][outcome] for g in groups], dtype=float)
        ax.bar(groups, heights, bottom=bottom, color=_COLOURS[outcome], label=outcome)
        bottom += heights
    ax.set_title(title)
    ax.set_ylabel("episodes")
    ax.tick_params(axis="x", labelrotation=20)


def _outcomes(records: Sequence[dict[str, Any]], path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    _outcome_bars(axes[0], records, lambda r: str(r.get("behaviour")), "by behaviour")
    _outcome_bars(axes[1], records, lambda r: str(r.get("posture")), "by posture")
    _outcome_bars(axes[2], records, lambda r: height_band(float(r["height_m"])), "by height")
    seen: dict[str, Any] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(label, handle)
    fig.legend(list(seen.values()), list(seen.keys()), loc="outside right upper")
    fig.suptitle(f"Episode outcomes ({len(records)} episodes)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _times(records: Sequence[dict[str, Any]], path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, field, label in ((axes[0], "time_to_handover_s", "episode start → release, s"),
                             (axes[1], "reach_to_release_s", "reach start → release, s")):
        values = [r[field] for r in records if r.get("success") and r.get(field) is not None]
        if values:
            ax.hist(values, bins=min(30, max(5, len(values) // 5)), color="#2a9d8f")
            ax.axvline(float(np.median(values)), color="k", linestyle="--", label="median")
            ax.legend()
        ax.set_xlabel(label)
        ax.set_ylabel("successful episodes")
    fig.suptitle("Time to handover")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_plots(records: Sequence[dict[str, Any]], folder: Path) -> list[str]:
    """Draw the plots into `folder`; their file names (none without records)."""
    if not records:
        return []
    import matplotlib

    matplotlib.use("Agg")
    paths = [folder / "outcomes.png", folder / "times.png"]
    _outcomes(records, paths[0])
    _times(records, paths[1])
    return [str(p) for p in paths]
