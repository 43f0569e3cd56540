"""Review state (tool path, release marker), derived 3-D entities and the blueprint's styles and panels."""

from __future__ import annotations

import msgspec
import numpy as np

from bus_schema import TOPICS, messages as m, topics
from services.recorder.blueprint import PANELS, RELEASE_SERIES, blueprint, signal_view, static_styles
from services.recorder.bus_columns import field_plans, numeric_series
from services.recorder.core import POINT_STYLES, SKELETON_BONES, skeleton_bones
from services.recorder.derived import derived_columns
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


def _positions(derived):
    column = next(c for c in derived.columns if "positions" in str(c.component_descriptor())
                  or "strips" in str(c.component_descriptor()))
    return column.as_arrow_array().to_pylist()


def test_points_have_styles_and_the_message_positions():
    truth = SAMPLES["sim/truth"]
    derived = {d.entity: d for d in derived_columns(topics.SIM_TRUTH, [truth, truth])}
    assert set(derived) <= set(POINT_STYLES)
    np.testing.assert_allclose(_positions(derived["world/tool"]), [[truth.tool_position_m]] * 2, atol=1e-6)


def test_skeleton_joints_and_bones_per_frame():
    joints = [m.SkeletonJoint(name=n, position_m=(float(i), 0.0, 0.0)) for i, n in enumerate(m.SKELETON_JOINTS)]
    frames = [m.Skeleton(**H, tracked=True, joints=joints), m.Skeleton(**H, tracked=False),
              m.Skeleton(**H, tracked=True, joints=joints[:3])]
    derived = {d.entity: d for d in derived_columns(topics.SKELETON, frames)}
    assert derived["world/skeleton/raw"].rows.tolist() == [0, 2]
    raw = _positions(derived["world/skeleton/raw"])
    assert [len(r) for r in raw] == [len(joints), 3]
    bones = _positions(derived["world/skeleton/bones"])
    assert [len(b) for b in bones] == [len(SKELETON_BONES), 2]
    np.testing.assert_allclose(bones[1], [[[0, 0, 0], [1, 0, 0]], [[1, 0, 0], [2, 0, 0]]])


def test_panels_plot_numeric_bus_components_that_exist():
    """Every plotted component is a numeric field of the message type of its entity's key."""
    by_entity = {f"bus/{t.suffix}": t for t in TOPICS}
    for title, signals in PANELS.items():
        for signal in signals:
            plans = {p.component: p for p in field_plans(by_entity[signal.entity].type)}
            assert signal.component in plans and numeric_series(plans[signal.component]), (title, signal)
            assert len(signal.names) == len(signal.colors)
        view = signal_view(title, signals)
        assert view is not None
    wrist = PANELS["Wrist force F_sx, F_sy (N)"][0]
    assert wrist.visible == (True, True, False)  # F_sx and F_sy, not F_sz


def test_static_styles_cover_every_point_entity_and_derived_entity():
    entities = {e for e, _ in static_styles()}
    assert set(POINT_STYLES) <= entities and RELEASE_SERIES in entities
    assert {"world/skeleton/raw", "world/skeleton/bones", "world/human/hand_correction",
            "world/object/estimate", "signals/gripper_mode"} <= entities
    assert blueprint("baxter") is not None and blueprint(None) is not None


def test_the_blueprint_sets_the_time_panel_only_when_asked():
    """The recorder's own blueprint leaves playback to the viewer; screenshots follow the newest
    data; the viewer load of the busy-machine tests replays the recording in a loop."""
    def playback(**kwargs):
        panel = blueprint("baxter", **kwargs).time_panel
        return panel.play_state, panel.loop_mode

    assert playback() == (None, None)
    assert playback(follow_latest=True) == ("following", None)
    assert playback(replay_in_loop=True) == ("playing", "all")
