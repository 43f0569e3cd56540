"""Plot of an offline motion preview (matplotlib; imported only for `handover-motion plan --plot`)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from handover_model import robots  # noqa: E402


def plot_record(record, path: str | Path, title: str = "") -> None:
    """Joint positions and tool speed of a `PreviewRecord` to a PNG."""
    fig, (ax_q, ax_v) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for j, name in enumerate(robots.active().joints):
        ax_q.plot(record.time_s, record.q_rad[:, j], label=name)
    ax_q.set_ylabel("joint position (rad)")
    ax_q.legend(ncol=4, fontsize=8)
    ax_q.grid(alpha=0.3)
    ax_v.plot(record.time_s, record.tool_speed_m_s, color="k")
    ax_v.set_ylabel("tool speed (m/s)")
    ax_v.set_xlabel("time (s)")
    ax_v.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
