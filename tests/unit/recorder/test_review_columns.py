"""Review state (tool path, release marker), column batching and the blueprint's static styles."""

from __future__ import annotations

import msgspec
import numpy as np
import pyarrow as pa

from bus_schema import messages as m
from services.recorder.blueprint import SIGNALS, blueprint, static_styles
from services.recorder.columns import ColumnBuffer
from services.recorder.core import POINT_STYLES, SKELETON_BONES, message_rows, skeleton_bones
from services.recorder.review import ReviewState, ToolPath
from tests.samples import SAMPLES

H = {"seq": 0, "stamp_ns": 1, "source": "t"}


def test_tool_path_keeps_points_5mm_apart_and_restarts():
    path = ToolPath()
    for x_m in (0.0, 0.001, 0.004, 0.006, 0.0115, 0.02):
        path.add((x_m, 0.0, 0.0))
    assert [p[0] for p in path.points] == [0.0, 0.006, 0.0115, 0.02]
    path.restart()
    assert path.points == [] and path.changed


def test_tool_path_is_capped():
    path = ToolPath(min_spacing_m=0.0, max_points=3)
    for i in range(5):
        path.add((float(i), 0.0, 0.0))
    assert [p[0] for p in path.points] == [2.0, 3.0, 4.0]


def test_release_marker_is_at_the_last_tool_position_and_new_episode_restarts_the_path():
    state = ReviewState()
    state.on_message(m.SupervisorState(**H, phase="reach", episode_id=1))
    for x_m in (0.5, 0.6, 0.7):
        state.on_message(msgspec.structs.replace(SAMPLES["sim/truth"], tool_position_m=(x_m, 0.0, 0.1)))
    logged = dict(state.on_message(m.ReleaseEvent(**H, grip_force_n=4.0, controller="SG")))
    np.testing.assert_allclose(logged["world/release"].positions.as_arrow_array().to_pylist(), [[0.7, 0.0, 0.1]],
                               atol=1e-6)  # float32
    entity, strip = state.path_update()
    assert entity == "world/tool_path" and len(state.tool_path.points) == 3
    assert state.path_update() is None  # unchanged since
    state.on_message(m.SupervisorState(**H, phase="locate", episode_id=2))
    assert state.tool_path.points == []


def test_skeleton_bones_connect_known_joints_only():
    joints = [m.SkeletonJoint(name=n, position_m=(float(i), 0.0, 0.0)) for i, n in enumerate(m.SKELETON_JOINTS)]
    assert len(skeleton_bones(joints)) == len(SKELETON_BONES)
    assert skeleton_bones(joints[:3]) == [[(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], [(1.0, 0.0, 0.0), (2.0, 0.0, 0.0)]]


def test_gripper_mode_series_and_points_have_styles():
    from bus_schema import topics

    rows = message_rows(topics.GRIPPER_STATE, SAMPLES["gripper/state"])
    assert ("signals/gripper_mode", 3.0) in rows.scalars  # "hold"
    truth = message_rows(topics.SIM_TRUTH, SAMPLES["sim/truth"])
    assert {e for e, _ in truth.points} <= set(POINT_STYLES)
    assert dict(truth.points)["world/tool"] == SAMPLES["sim/truth"].tool_position_m


def test_column_buffer_makes_one_dense_batch_per_key_and_entity_set():
    buf = ColumnBuffer()
    buf.add("a", 10, 11, [("x/v", 1.0), ("x/w", 2.0)], [("p", (1.0, 2.0, 3.0))])
    buf.add("a", 20, 21, [("x/v", 3.0), ("x/w", 4.0)], [("p", (4.0, 5.0, 6.0))])
    buf.add("a", 30, 31, [("x/v", 5.0)], [])  # another entity set: another batch
    buf.add("b", 40, 41, [], [])  # nothing to write
    assert buf.pending_rows == 3
    batches = buf.take_batches()
    assert buf.pending_rows == 0 and buf.take_batches() == []
    assert [b.num_rows for b in batches] == [2, 1]
    first = batches[0]
    assert first.column("time").cast(pa.int64()).to_pylist() == [10, 20]
    assert first.column("receive_time").cast(pa.int64()).to_pylist() == [11, 21]
    assert first.column("/x/w:Scalars:scalars").to_pylist() == [[2.0], [4.0]]
    np.testing.assert_allclose(first.column("/p:Points3D:positions").to_pylist(), [[[1, 2, 3]], [[4, 5, 6]]])
    meta = first.schema.field("/x/v:Scalars:scalars").metadata
    assert meta[b"rerun:entity_path"] == b"/x/v" and meta[b"rerun:component_type"] == b"rerun.components.Scalar"


def test_static_styles_cover_every_point_entity_and_signal():
    entities = {e for e, _ in static_styles()}
    assert set(POINT_STYLES) <= entities and set(SIGNALS) <= entities
    assert blueprint("baxter") is not None and blueprint(None) is not None
