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
    at_release = min(truth, key=lambda m: abs(stamp_s(m) - stamp_s(release)))
    assert np.linalg.norm(np.subtract(at_release.tool_position_m, summary.transfer_point_base_m)) < 0.03
    # The release interrupt holds on every arm: at rest within 0.2 s of the release.
    rest = first_rest_after(by_stamp(rec.joints), stamp_s(release))
    assert rest is not None and rest - stamp_s(release) < 0.2
    # The gripper never pressed harder than this arm's gripper can.
    assert summary.peak_grip_force_n <= min(arm.gripper.force_max_n, 140.0) + 1e-6
