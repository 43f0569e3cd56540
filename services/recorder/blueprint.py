"""The recording's layout (Rerun blueprint) and the static look of its entities.

Layout: a 3-D view of the `base` frame (robot, human, object, target, tool path) on the left;
on the right, time series of the transfer loop's signals and a text log of events:

- Grip force (N): command F_G (``gripper/command``), measured (``gripper/state``), grip force at
  release (a marker);
- Wrist force (N): F_sx, F_sy (``sensors/wrist_wrench/force_n/0``, ``/1``);
- Object motion: a_y (m/s², down +) and slip velocity along y (m/s) from ``sensors/object_motion``;
- Gripper mode (0 grasp, 1 slip, 2 release, 3 hold) and joint positions (rad);
- Events: supervisor phases, motion, gripper modes, stops and the release.
"""

from __future__ import annotations

from typing import Any

import rerun as rr
import rerun.blueprint as rrb

from services.recorder.columns import TIMELINE_STAMP
from services.recorder.core import POINT_STYLES

#: Time series shown in the signal panels: entity → (legend name, RGB colour).
SIGNALS: dict[str, tuple[str, tuple[int, int, int]]] = {
    "bus/gripper/command/grip_force_n": ("F_G command", (30, 110, 230)),
    "bus/gripper/state/measured_grip_force_n": ("F_G measured", (120, 180, 255)),
    "bus/sensors/wrist_wrench/force_n/0": ("F_sx (pull)", (220, 80, 40)),
    "bus/sensors/wrist_wrench/force_n/1": ("F_sy (load, down +)", (40, 160, 60)),
    "bus/sensors/object_motion/accel_y_m_s2": ("a_y (m/s², down +)", (200, 50, 160)),
    "bus/sensors/object_motion/velocity_m_s/1": ("slip velocity y (m/s)", (120, 60, 200)),
    "signals/gripper_mode": ("mode: 0 grasp 1 slip 2 release 3 hold", (90, 90, 90)),
}


#: Every 3-D entity the recorder writes (all in the `base` frame).
WORLD_ENTITIES: tuple[str, ...] = (*POINT_STYLES, "world/skeleton/raw", "world/skeleton/bones",
                                   "world/human/hand_correction", "world/object/estimate", "world/tool_path",
                                   "world/motion/goal_arrow", "world/release")


def static_styles() -> list[tuple[str, Any]]:
    """(entity, archetype) to log once as static: point looks and series names/colours."""
    out: list[tuple[str, Any]] = [
        (entity, rr.Points3D.from_fields(radii=[s.radius_m], colors=[s.color_rgb], labels=[s.label]))
        for entity, s in POINT_STYLES.items()
    ]
    out += [(entity, rr.SeriesLines(names=[name], colors=[rgb])) for entity, (name, rgb) in SIGNALS.items()]
    out.append(("signals/release_grip_force_n", rr.SeriesPoints(names=["release (F_G at release)"],
                                                                colors=[(255, 40, 40)], markers=["cross"],
                                                                marker_sizes=[8.0])))
    out.append(("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP))
    # The URDF's links live in named frames under `base`; everything under /world is in
    # Baxter's base frame too: say so explicitly, so one 3-D view shows both.
    out += [(entity, rr.CoordinateFrame("base")) for entity in WORLD_ENTITIES]
    return out


#: Default 3-D camera: from the robot's right (−y), the robot on the left, the receiver on the right.
EYE_POSITION_M = (2.9, -2.6, 1.6)
EYE_TARGET_M = (0.6, -0.3, 0.1)


def blueprint(robot_name: str | None, follow_latest: bool = False) -> rrb.Blueprint:
    """3-D view, signal panels and event log (sent once at the start of a recording).

    `follow_latest`: the time cursor follows the newest data (the end of a recording); used
    for screenshots. By default the viewer's own choice applies.
    """
    # Rerun 0.41 cannot import the arm's Collada meshes (polylist): the arm is drawn with its
    # collision cylinders and boxes instead; collision meshes and spheres stay hidden.
    overrides = {f"{robot_name}/collision_geometries/{kind}": rrb.EntityBehavior(visible=False)
                 for kind in ("mesh", "sphere")} if robot_name else {}
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(name="Handover (base frame)", origin="/", overrides=overrides,
                                  contents=["+ /world/**"] + ([f"+ /{robot_name}/**"] if robot_name else []),
                                  eye_controls=rrb.EyeControls3D(position=EYE_POSITION_M, look_target=EYE_TARGET_M,
                                                                 eye_up=(0.0, 0.0, 1.0))),
                rrb.TextLogView(name="Events", origin="/events"),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                rrb.TimeSeriesView(name="Grip force (N)", origin="/", contents=[
                    "/bus/gripper/command/grip_force_n", "/bus/gripper/state/measured_grip_force_n",
                    "/signals/release_grip_force_n"]),
                rrb.TimeSeriesView(name="Wrist force F_sx, F_sy (N)", origin="/", contents=[
                    "/bus/sensors/wrist_wrench/force_n/0", "/bus/sensors/wrist_wrench/force_n/1"]),
                rrb.TimeSeriesView(name="Object: a_y (m/s²), slip velocity (m/s)", origin="/", contents=[
                    "/bus/sensors/object_motion/accel_y_m_s2", "/bus/sensors/object_motion/velocity_m_s/1"]),
                rrb.TimeSeriesView(name="Gripper mode", origin="/signals/gripper_mode"),
                rrb.TimeSeriesView(name="Joint positions (rad)", origin="/robot/joint_position"),
            ),
            column_shares=[3, 2],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE_STAMP, state="expanded",
                      play_state="following" if follow_latest else None),
    )
