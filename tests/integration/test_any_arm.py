"""The default handover on every described arm: `handover-up --robot NAME` with all seven
services as real processes on a loopback Zenoh bus, judged from what the test observed on the
bus (sim truth is ground truth, never used by the stack for control). Baxter, the default arm,
has its own end-to-end tests (test_handover_e2e.py). ~30 s per arm on 2 cores."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model import robots
from tests.faults.invariants import by_stamp, first_rest_after, stamp_s
from tests.faults.matrix import run_again_if_stopped_before_the_fault

pytestmark = pytest.mark.integration

ARMS = sorted(set(robots.BUILTIN) - {robots.DEFAULT_ROBOT})


def _release_miss_m(rec, truth: list, release, transfer_point_m) -> float:
    """How far (m) the tool was at the release from where it should have been.

    Once the arm is at the transfer point (the supervisor's ``transfer`` phase), the release
    happens there: the distance to the planned point. A receiver who takes the object before
    (the release comes during the reach; on a busy machine a re-plan can re-route the arm
    just then) takes it on the way: the distance to the straight path of the last transfer
    goal, from where the tool was when that goal was sent to its point."""
    def tool_at(stamp: float) -> np.ndarray:
        return np.array(min(truth, key=lambda m: abs(stamp_s(m) - stamp)).tool_position_m)

    released_s = stamp_s(release)
    tool = tool_at(released_s)
    if any(m.phase == "transfer" and stamp_s(m) <= released_s for _t, m in rec.states):
        return float(np.linalg.norm(tool - np.asarray(transfer_point_m)))
    goal = max((g for _t, g in rec.goals if g.kind == "transfer" and stamp_s(g) <= released_s), key=stamp_s)
    start, end = tool_at(stamp_s(goal)), np.asarray(goal.position_base_m)
    along = float(np.clip(np.dot(tool - start, end - start) / max(np.dot(end - start, end - start), 1e-12), 0, 1))
    return float(np.linalg.norm(tool - (start + along * (end - start))))


@pytest.mark.parametrize("name", ARMS)
def test_the_default_handover_passes_on_the_arm(name):
    arm = robots.describe(name)
    rec, _ = run_again_if_stopped_before_the_fault(f"{name} taking receiver", [], receiver="taking", seed=1,
                                                   extra_args=("--robot", name))
    console = "\n".join(line for _t, line in rec.lines[-40:])
    assert rec.summaries, f"no episode summary; launcher said: {rec.exit_line}\n{console}"
    summary = rec.summaries[-1][1]
    assert rec.exit_code == 0 and summary.outcome == "released", f"{summary.reason}\n{console}"
    assert f"[launcher] robot: {name} ({arm.title})" in [line for _t, line in rec.lines]
    # The arm that moved is this arm: its joints, within its limits.
    joints = rec.joints[-1][1]
    assert tuple(joints.names) == arm.joints
    model = robots.ArmModel(arm)
    q = np.array([m.position_rad for _t, m in rec.joints])
    assert np.all(q >= model.limits.lower_rad - 1e-6) and np.all(q <= model.limits.upper_rad + 1e-6)
    # The object started where this arm's description puts it, was picked, and ended in the
    # receiver's hand, never dropped.
    truth = [m for _t, m in rec.truth]
    assert truth[0].object_position_m == pytest.approx(arm.object_pick_base_m, abs=1e-6)
    assert not any(m.dropped for m in truth)
    assert any(m.held_by == "gripper" for m in truth)
    assert truth[-1].held_by == "receiver"
    assert np.linalg.norm(np.subtract(truth[-1].object_position_m, truth[-1].receiver_hand_position_m)) < 0.02
    # The tool went to the DJT point: where the release happened is the planned transfer point.
    t_release, release = rec.releases[0]
    miss_m = _release_miss_m(rec, truth, release, summary.transfer_point_base_m)
    assert miss_m < 0.03, f"released {miss_m * 1000:.0f} mm from where the arm was sent"
    # The release interrupt holds on every arm: at rest within 0.2 s of the release.
    rest = first_rest_after(by_stamp(rec.joints), stamp_s(release))
    assert rest is not None and rest - stamp_s(release) < 0.2
    # The gripper never pressed harder than this arm's gripper can.
    assert summary.peak_grip_force_n <= min(arm.gripper.force_max_n, 140.0) + 1e-6
