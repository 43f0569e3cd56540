"""Baxter in the recording: the primitive model (no meshes, small) and batched joint transforms."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
import rerun as rr

from handover_model.robots.baxter import RIGHT_ARM_JOINTS, urdf_path
from services.recorder.config import RecorderConfig
from services.recorder.readback import _reader, entity_row_counts
from services.recorder.robot import RobotModel, convex_hull_mesh, primitive_model
from services.recorder.writer import RecordingWriter
from tests.unit.recorder.stream import PREFIX


@pytest.fixture(scope="module")
def tree():
    return rr.urdf.UrdfTree.from_file_path(urdf_path())


def _components(batch: pa.RecordBatch) -> set[str]:
    return {(f.metadata or {}).get(b"rerun:archetype", b"").decode() for f in batch.schema}


def test_primitive_model_keeps_cylinders_and_boxes_and_drops_meshes_and_spheres(tree):
    as_is, merged = primitive_model(tree.stream(include_joint_transforms=True))
    archetypes = [_components(b) for _, b in merged]
    entities = [e for e, _ in merged]
    assert not any("rerun.archetypes.Asset3D" in a for a in archetypes)
    assert not any("/collision_geometries/sphere/" in e or "/collision_geometries/mesh/" in e for e in entities)
    cylinders = [e for e in entities if "/collision_geometries/cylinder/" in e]
    boxes = [e for e in entities if "/collision_geometries/box/" in e]
    assert len(cylinders) == 24 and len(boxes) == 10  # the URDF's collision primitives
    # One chunk per entity, each placed in its link's frame, with its geometry.
    assert len(set(entities)) == len(entities)
    assert all({"rerun.archetypes.CoordinateFrame", "rerun.archetypes.InstancePoses3D"} <= a for a in archetypes)
    assert {c.entity_path for c in as_is} == {"/tf_static", "/baxter"}  # joint transforms, root frame


def test_torso_hull_is_closed_outward_and_small():
    from services.recorder.robot import _mesh_file

    torso = _mesh_file(urdf_path(), "torso", "collision")
    mesh = convex_hull_mesh(torso, (60, 60, 60))
    points = np.array(mesh.vertex_positions.as_arrow_array().to_pylist())
    triangles = np.array(mesh.triangle_indices.as_arrow_array().to_pylist())
    assert 100 <= len(points) <= 400 and len(triangles) == 2 * len(points) - 4  # a closed convex triangulation
    a, b, c = (points[triangles[:, k]] for k in range(3))
    volume_m3 = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6  # > 0 iff the faces point outwards
    extent_m = points.max(axis=0) - points.min(axis=0)
    assert volume_m3 > 0.05 and np.all(extent_m > 0.3) and np.all(extent_m < 1.0)  # Baxter's torso, in metres


def test_primitive_model_costs_tens_of_kilobytes_the_meshes_megabytes(tmp_path):
    """The model's own data, as streamed: without the footer `close` adds when it finalises (an
    index of every chunk; for the primitives' 65 static entities ~0.28 MB more, see finalise)."""
    sizes = {}
    for mode in ("none", "primitives", "meshes"):
        out = tmp_path / f"{mode}.rrd"
        RecordingWriter(out, PREFIX, RecorderConfig(robot_model=mode)).close(finalise=False)
        sizes[mode] = out.stat().st_size
    assert sizes["primitives"] - sizes["none"] < 200_000
    assert sizes["meshes"] - sizes["none"] > 10_000_000
    counts = entity_row_counts(tmp_path / "primitives.rrd")
    assert counts["/baxter/visual_geometries/torso/visual_0"] >= 1


def test_joint_transforms_one_state_in_n_equal_the_urdf_joints(tmp_path, tree):
    out = tmp_path / "pose.rrd"
    rec = rr.RecordingStream("test", recording_id="pose")
    rec.save(str(out), write_footer=False)
    model = RobotModel(rec, "primitives", pose_every=4)
    n = 10
    q = np.linspace(0.1, 0.9, n)  # within every right-arm joint's limits
    names = pa.array([list(RIGHT_ARM_JOINTS)] * n, type=pa.list_(pa.string()))
    positions = pa.array([[float(v)] * 7 for v in q], type=pa.list_(pa.float64()))
    stamps = np.arange(n, dtype=np.int64) * 10_000_000 + 1
    assert model.send_transforms(rec, names, positions, stamps, stamps) == 3 * 7  # states 0, 4, 8
    assert model.send_transforms(rec, names.slice(0, 2), positions.slice(0, 2), stamps[:2] + 200_000_000,
                                 stamps[:2]) == 0  # states 10, 11: the next is 12
    rec.flush()
    rec.disconnect()
    rows = []
    for chunk in _reader(out).stream():
        if chunk.entity_path == "/transforms" and not chunk.is_static:
            batch = chunk.to_record_batch()
            rows += list(zip(batch.column("time").cast(pa.int64()).to_pylist(),
                             batch.column("Transform3D:child_frame").to_pylist(),
                             batch.column("Transform3D:quaternion").to_pylist(), strict=True))
    assert sorted({t for t, _, _ in rows}) == stamps[[0, 4, 8]].tolist()
    joint = tree.get_joint_by_name("right_e1")
    expected = joint.compute_transform(float(q[4]))
    quat = next(qq for t, child, qq in rows if t == stamps[4] and child == [joint.child_link])
    np.testing.assert_allclose(quat[0], expected.quaternion.as_arrow_array().to_pylist()[0], atol=1e-6)
