"""The blueprint's combined 3-D view: it shows the human skeleton, hands, object, target, tool
path and robot, in the frame those entities are declared in (Baxter's `base`), z up."""

from __future__ import annotations

from pathlib import Path

import rerun as rr

from services.recorder.blueprint import (BASE_FRAME, WORLD_ENTITIES, links_without_importable_mesh, static_styles,
                                         view_3d)
from services.recorder.core import POINT_STYLES

#: What the 3-D view must show (the task: robot, skeleton, target, gripper trajectory, object).
MUST_SHOW = ("/world/skeleton/raw", "/world/skeleton/bones", "/world/human/hand_corrected",
             "/world/human/hand_raw", "/world/truth/receiver_hand", "/world/truth/object",
             "/world/object/estimate", "/world/transfer_target", "/world/tool", "/world/tool_path",
             "/world/release", "/baxter/visual_geometries/torso/visual_0")


def _included(contents: list[str], entity: str) -> bool:
    """Evaluate Rerun's entity path query (``+``/``-`` rules, ``/**`` = the subtree, the last
    matching rule wins among equally specific ones: enough for the rules used here)."""
    verdict = False
    for rule in contents:
        sign, expr = rule.split(" ", 1)
        if expr.endswith("/**"):
            base = expr[:-3]
            hit = entity == base or entity.startswith(base + "/")
        else:
            hit = entity == expr
        if hit:
            verdict = sign == "+"
    return verdict


def _property(view, archetype: str, field: str):
    value = getattr(view.properties[archetype], field)
    return value.as_arrow_array().to_pylist()


def test_3d_view_includes_every_world_entity_and_the_robot():
    view = view_3d("baxter")
    for entity in MUST_SHOW:
        assert _included(list(view.contents), entity), f"{entity} is not in the 3-D view's contents {view.contents}"
    assert not _included(list(view.contents), "/bus/gripper/command/grip_force_n")
    assert not _included(list(view.contents), "/camera/depth")


def test_3d_view_target_frame_is_the_frame_the_world_entities_are_logged_in():
    view = view_3d("baxter")
    assert _property(view, "SpatialInformation", "target_frame") == [BASE_FRAME]
    # Axes: x forward, y left, z up (Baxter's base frame), not the viewer's RFU (y up) fallback.
    assert _property(view, "SpatialInformation", "axes") == rr.ViewCoordinates.FLU.as_arrow_array().to_pylist()
    frames = {entity: a for entity, a in static_styles() if isinstance(a, rr.CoordinateFrame)}
    for entity in (*POINT_STYLES, *WORLD_ENTITIES):
        assert frames[entity].frame.as_arrow_array().to_pylist() == [BASE_FRAME], entity
    for entity in MUST_SHOW[:-1]:
        assert entity.removeprefix("/") in frames, f"{entity} has no CoordinateFrame"


def test_unimportable_meshes_are_hidden_the_rest_shown(tmp_path: Path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "poly.dae").write_text("<COLLADA><mesh><polylist count='1'/></mesh></COLLADA>")
    (tmp_path / "meshes" / "tri.dae").write_text("<COLLADA><mesh><triangles count='1'/></mesh></COLLADA>")
    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        "<robot name='r'>"
        "<link name='a'><visual><geometry><mesh filename='meshes/poly.dae'/></geometry></visual></link>"
        "<link name='b'><visual><geometry><mesh filename='meshes/tri.dae'/></geometry></visual></link>"
        "<link name='c'><visual><geometry><box size='1 1 1'/></geometry></visual></link>"
        "<link name='d'><visual><geometry><mesh filename='meshes/missing.dae'/></geometry></visual></link>"
        "</robot>")
    monkeypatch.chdir(tmp_path)  # relative mesh paths resolve from the working directory
    assert links_without_importable_mesh(urdf) == ("a", "d")


def test_baxter_arm_meshes_are_hidden_the_torso_kept():
    from handover_model.robots.baxter import urdf_path

    hidden = links_without_importable_mesh(urdf_path())
    assert "right_upper_shoulder" in hidden and "right_wrist" in hidden
    assert "torso" not in hidden
    overrides = view_3d("baxter").visualizer_overrides
    hidden_paths = {path for path, behavior in overrides.items()
                    if behavior.visible.as_arrow_array().to_pylist() == [False]}
    assert {f"baxter/visual_geometries/{link}" for link in hidden} <= hidden_paths
    # Nothing the handover needs is hidden: no world entity, not the torso, not the arm's cylinders.
    assert not any(p.startswith("world") or p.endswith("/torso") or "cylinder" in p for p in hidden_paths)
