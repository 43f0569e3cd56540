"""The recording draws the arm actually used (`handover_model.robots.active`), placed in `base`."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
import rerun as rr

from handover_model import robots
from services.recorder.config import RecorderConfig
from services.recorder.readback import entity_row_counts
from services.recorder.robot import RobotModel
from services.recorder.writer import RecordingWriter
from tests.unit.recorder.stream import PREFIX


@pytest.fixture
def arm(request):
    previous = robots.active()
    desc = robots.use(robots.describe(request.param))
    yield desc
    robots.use(previous)


@pytest.mark.parametrize("arm", ["panda", "ur5", "so_arm101"], indirect=True)
def test_the_recording_holds_the_active_arm_and_not_baxter(arm, tmp_path):
    out = tmp_path / f"{arm.name}.rrd"
    RecordingWriter(out, PREFIX, RecorderConfig(robot_model="primitives")).close(finalise=False)
    entities = entity_row_counts(out)
    drawn = [e for e in entities if "_geometries/" in e]
    assert drawn, sorted(entities)
    assert not any("baxter" in e for e in entities)
    # Each link of the chain is drawn (collision meshes in STL, the arms' only geometry).
    links = {e.split("/")[-2] for e in drawn}
    assert len(links) >= arm.dof, sorted(links)
    assert out.stat().st_size < 1_500_000  # convex hulls, not the meshes (SO-ARM101: 9.6 MB of STL)


@pytest.mark.parametrize("arm", ["panda"], indirect=True)
def test_the_arms_transforms_place_its_root_at_the_base_pose(arm, tmp_path):
    out = tmp_path / "pose.rrd"
    rec = rr.RecordingStream("test", recording_id="pose-arm")
    rec.save(str(out), write_footer=False)
    model = RobotModel(rec, "primitives")
    assert model.robot_name == "panda"
    names = pa.array([list(arm.joints)], type=pa.list_(pa.string()))
    positions = pa.array([list(arm.home_rad)], type=pa.list_(pa.float64()))
    stamps = np.array([1], dtype=np.int64)
    assert model.send_transforms(rec, names, positions, stamps, stamps) == arm.dof
    # The static joint that places the arm: base → panda_link0 at base_xyz_m.
    static = [c for c in model.tree.stream(include_joint_transforms=True) if c.entity_path == "/tf_static"]
    table = pa.Table.from_batches([c.to_record_batch() for c in static])
    children = table.column("Transform3D:child_frame").combine_chunks().flatten().to_pylist()
    parents = table.column("Transform3D:parent_frame").combine_chunks().flatten().to_pylist()
    translations = np.array(table.column("Transform3D:translation").combine_chunks().flatten().to_pylist())
    i = children.index("panda_link0")
    assert parents[i] == "base"
    assert translations[i] == pytest.approx(arm.base_xyz_m, abs=1e-6)
