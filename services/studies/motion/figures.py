"""Figures of the motion service (matplotlib, Agg backend).

`handover-study figures motion [--out DIR]` writes the docs/motion.md figures
(`docs/img/motion_*.png` by default) from real planned motions.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from handover_model import robots  # noqa: E402
from services.motion.plot import plot_record  # noqa: E402


def make_docs_figures(out_dir: Path) -> list[Path]:
    """Transfer with and without the receiver-zone cap, and a stop mid-reach."""
    from bus_schema.messages import MotionGoal, MotionStop
    from handover_model import scene
    from services.motion.config import MotionConfig
    from services.motion.core import MotionController
    from services.motion.ik import ArmIk
    from services.motion.preview import preview

    out_dir.mkdir(parents=True, exist_ok=True)
    config = MotionConfig.from_dict({}, robots.active())
    ik = ArmIk(config)
    home = np.array(robots.active().home_rad)

    def goal(**kw):
        return MotionGoal(seq=0, stamp_ns=0, source="figures", **kw)

    pick = preview(MotionController(config, ik),
                   goal(goal_id="pick", kind="pick", position_base_m=tuple(robots.active().object_pick_base_m)), home)
    q_pick = pick.q_rad[-1]
    target = tuple(scene.task_to_base(np.array([0.05, 0.35])))
    hand = tuple(np.array(target) + np.array([0.12, 0.0, 0.0]))
    free = preview(MotionController(config, ik), goal(goal_id="t", kind="transfer", position_base_m=target), q_pick)
    capped = preview(MotionController(config, ik),
                     goal(goal_id="t", kind="transfer", position_base_m=target, receiver_hand_position_m=hand),
                     q_pick)
    stopped = preview(MotionController(config, ik), goal(goal_id="t", kind="transfer", position_base_m=target),
                      q_pick, stop_at_s=0.5, stop=MotionStop(seq=0, stamp_ns=0, source="figures", reason="release"))
    written = []

    fig, ax = plt.subplots(figsize=(7, 4))
    for rec, label in ((free, "no receiver nearby"), (capped, "receiver's hand 0.12 m beyond the target")):
        ax.plot(rec.time_s, rec.tool_speed_m_s, label=f"{label} ({rec.planned_duration_s:.2f} s)")
    ax.axhline(config.receiver_zone_speed_m_s, color="r", ls="--", lw=1, label="0.25 m/s cap")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("commanded tool speed (m/s)")
    ax.set_title("Transfer reach: minimum-jerk bell-shaped speed, capped near the hand")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = out_dir / "motion_transfer_speed.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    fig, (ax_q, ax_v) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    for j, name in enumerate(robots.active().joints):
        ax_v.plot(stopped.time_s, stopped.dq_rad_s[:, j], label=name)
        ax_q.plot(stopped.time_s, stopped.q_rad[:, j])
    for ax in (ax_q, ax_v):
        ax.axvline(0.5, color="r", ls="--", lw=1)
        ax.grid(alpha=0.3)
    ax_q.set_ylabel("joint position (rad)")
    ax_v.set_ylabel("joint velocity (rad/s)")
    ax_v.set_xlabel("time (s); red: stop message")
    ax_v.legend(ncol=4, fontsize=7)
    ax_q.set_title("Ruckig stop mid-reach (commanded joints)")
    fig.tight_layout()
    path = out_dir / "motion_stop.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    path = out_dir / "motion_pick_transfer_joints.png"
    plot_record(free, path, title="Transfer from the pick pose: commanded joints and tool speed")
    written.append(path)
    return written

