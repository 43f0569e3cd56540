"""The recording's layout (Rerun blueprint) and the static look of its entities.

Layout: a 3-D view of the `base` frame (robot, human, object, target, tool path) on the left;
on the right, time series of the transfer loop's signals and a text log of events:

- Grip force (N): command F_G (``gripper/command``), measured (``gripper/state``), grip force at
  release (a marker);
- Wrist force (N): F_sx, F_sy (instances 0 and 1 of ``WristWrench:force_n``);
- Object motion: a_y (m/s², down +) and slip velocity along y (m/s) from ``sensors/object_motion``;
- Gripper mode (0 grasp, 1 slip, 2 release, 3 hold) and joint positions (rad);
- Events: supervisor phases, motion, gripper modes, stops and the release.

The bus signals are components of the ``bus/<key>`` entities (`bus_columns`: one entity per key,
one component per message field); their panels plot them through component mappings
(``Scalars:scalars`` ← ``<MessageType>:<field>``, Rerun's "plot any scalar"), so nothing is
written twice.

The 3-D view is set up explicitly rather than left to the viewer's heuristics: its target frame
is the scene's ``base`` (the frame the URDF's links hang from and every ``world/…`` entity is
declared in with `CoordinateFrame`), its axes are x forward, y left, z up (FLU), and it shows
``/world/**`` (human skeleton, hands, object, target, tool path, markers) and the robot.
Without an explicit target frame the view's frame is the one of its origin entity ``/``
(``tf#/``) and its axes fall back to RFU (y up) because the ``ViewCoordinates`` at ``/world``
is not an ancestor of ``/``.
"""

from __future__ import annotations

import functools
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rerun as rr
import rerun.blueprint as rrb
from rerun.blueprint.encodings import ComponentSourceKind, VisualizerComponentMapping

from services.recorder.columns import TIMELINE_STAMP
from services.recorder.core import POINT_STYLES

@dataclass(frozen=True)
class Signal:
    """A plotted series: `component` of the ``bus/<key>`` `entity`, one legend name and RGB colour
    per instance (``force_n`` has three), `visible` per instance (None: all)."""

    entity: str
    component: str
    names: tuple[str, ...]
    colors: tuple[tuple[int, int, int], ...]
    visible: tuple[bool, ...] | None = None

    def visualizer(self) -> Any:
        """A `SeriesLines` visualizer reading its scalars from `component` (a component mapping)."""
        lines = rr.SeriesLines(names=list(self.names), colors=list(self.colors),
                               visible_series=list(self.visible) if self.visible else None)
        return lines.visualizer(mappings=[VisualizerComponentMapping(
            target="Scalars:scalars", source_kind=ComponentSourceKind.SourceComponent,
            source_component=self.component)])


#: The signal panels: title → series (bus components are plotted through component mappings).
PANELS: dict[str, tuple[Signal, ...]] = {
    "Grip force (N)": (
        Signal("bus/gripper/command", "GripperCommand:grip_force_n", ("F_G command",), ((30, 110, 230),)),
        Signal("bus/gripper/state", "GripperState:measured_grip_force_n", ("F_G measured",), ((120, 180, 255),)),
    ),
    "Wrist force F_sx, F_sy (N)": (
        Signal("bus/sensors/wrist_wrench", "WristWrench:force_n", ("F_sx (pull)", "F_sy (load, down +)", "F_sz"),
               ((220, 80, 40), (40, 160, 60), (120, 120, 120)), (True, True, False)),
    ),
    "Object: a_y (m/s²), slip velocity (m/s)": (
        Signal("bus/sensors/object_motion", "ObjectMotion:accel_y_m_s2", ("a_y (m/s², down +)",), ((200, 50, 160),)),
        Signal("bus/sensors/object_motion", "ObjectMotion:velocity_m_s", ("slip velocity x (m/s)",
                                                                          "slip velocity y (m/s)"),
               ((60, 60, 200), (120, 60, 200)), (False, True)),
    ),
}

#: The release marker on the grip force panel (a point series).
RELEASE_SERIES = "signals/release_grip_force_n"


#: Every 3-D entity the recorder writes (all in the `base` frame).
WORLD_ENTITIES: tuple[str, ...] = (*POINT_STYLES, "world/skeleton/raw", "world/skeleton/bones",
                                   "world/human/hand_correction", "world/object/estimate", "world/tool_path",
                                   "world/motion/goal_arrow", "world/release")


#: Static looks of the review entities sent as columns (`derived`).
_REVIEW_STYLES: tuple[tuple[str, Any], ...] = (
    ("world/skeleton/raw", rr.Points3D.from_fields(radii=[0.02], colors=[(200, 60, 60)], show_labels=False)),
    ("world/skeleton/bones", rr.LineStrips3D.from_fields(radii=[0.008], colors=[(200, 90, 90)])),
    ("world/human/hand_correction", rr.Arrows3D.from_fields(radii=[0.004], colors=[(40, 200, 80)])),
    ("world/object/estimate", rr.Boxes3D.from_fields(colors=[(230, 120, 20)])),
    ("signals/gripper_mode", rr.SeriesLines(names=["mode: 0 grasp 1 slip 2 release 3 hold"], colors=[(90, 90, 90)],
                                            interpolation_mode="StepAfter")),
)


def static_styles() -> list[tuple[str, Any]]:
    """(entity, archetype) to log once as static: point looks, series names/colours, frames."""
    out: list[tuple[str, Any]] = [
        (entity, rr.Points3D.from_fields(radii=[s.radius_m], colors=[s.color_rgb], labels=[s.label]))
        for entity, s in POINT_STYLES.items()
    ]
    out += [(entity, archetype) for entity, archetype in _REVIEW_STYLES]
    out.append((RELEASE_SERIES, rr.SeriesPoints(names=["release (F_G at release)"],
                                                                colors=[(255, 40, 40)], markers=["cross"],
                                                                marker_sizes=[8.0])))
    out.append(("world", rr.ViewCoordinates.FLU))
    # The URDF's links live in named frames under `base`; everything under /world is in
    # the scene's base frame too: say so explicitly, so one 3-D view shows both.
    out += [(entity, rr.CoordinateFrame("base")) for entity in WORLD_ENTITIES]
    return out


#: Default 3-D camera (`base` frame, m): from the robot's front right, the robot on the left, the
#: receiver on the right, looking at the handover region.
EYE_POSITION_M = (1.9, -1.8, 1.0)
EYE_TARGET_M = (0.6, -0.3, 0.05)

#: Frame of the 3-D view: the scene's base (x forward, y left, z up, m).
BASE_FRAME = "base"


@functools.cache
def links_without_importable_mesh(urdf: Path) -> tuple[str, ...]:
    """Links of `urdf` whose visual mesh the Rerun 0.41 viewer cannot import.

    Its Collada importer rejects ``<polylist>`` geometry (every mesh of the default arm but the torso's):
    such a link would draw nothing and the viewer would pop up one warning per mesh. Mesh
    paths ``package://…`` are resolved with ``ROS_PACKAGE_PATH``; unreadable files count as
    not importable.
    """
    roots = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    hidden: list[str] = []
    for link in ET.parse(urdf).getroot().iter("link"):
        for mesh in link.iterfind("visual/geometry/mesh"):
            filename = mesh.get("filename", "")
            if not filename.lower().endswith(".dae"):
                continue
            relative = filename.removeprefix("package://")
            candidates = [root / relative for root in roots] if filename.startswith("package://") else [Path(filename)]
            path = next((c for c in candidates if c.is_file()), None)
            if path is None or b"<polylist" in path.read_bytes():
                hidden.append(link.get("name", ""))
                break
    return tuple(hidden)


@functools.cache
def collision_meshes_are_stl(urdf: Path) -> bool:
    """Whether `urdf` has collision meshes and all are STL (drawn in `primitives` mode)."""
    names = [m.get("filename", "").lower() for c in ET.parse(urdf).getroot().iter("collision") for m in c.iter("mesh")]
    return bool(names) and all(n.endswith(".stl") for n in names)


def _robot_overrides(robot_name: str) -> dict[str, rrb.EntityBehavior]:
    """Hide what the viewer cannot draw: collision meshes/spheres and unimportable visual meshes
    (the arm is then drawn with its collision cylinders and boxes)."""
    try:
        from handover_model import robots

        urdf = robots.urdf_path(robots.active())
        links = links_without_importable_mesh(urdf)
        stl = collision_meshes_are_stl(urdf)
    except Exception:  # noqa: BLE001 - the model is optional for a recording: then show everything
        links, stl = (), False
    overrides = {f"{robot_name}/collision_geometries/{kind}": rrb.EntityBehavior(visible=False)
                 for kind in (("sphere",) if stl else ("mesh", "sphere"))}
    overrides.update({f"{robot_name}/visual_geometries/{link}": rrb.EntityBehavior(visible=False) for link in links})
    return overrides


def view_3d(robot_name: str | None) -> rrb.Spatial3DView:
    """The combined 3-D view: robot, human skeleton and hands, object, target, tool path, markers,
    all in the scene's `base` frame."""
    contents = ["+ /world/**"] + ([f"+ /{robot_name}/**"] if robot_name else [])
    return rrb.Spatial3DView(
        name="Handover (base frame)", origin="/", contents=contents,
        overrides=_robot_overrides(robot_name) if robot_name else {},
        spatial_information=rrb.SpatialInformation(target_frame=BASE_FRAME, axes=rr.ViewCoordinates.FLU),
        eye_controls=rrb.EyeControls3D(position=EYE_POSITION_M, look_target=EYE_TARGET_M, eye_up=(0.0, 0.0, 1.0)))


def signal_view(title: str, signals: tuple[Signal, ...]) -> rrb.TimeSeriesView:
    """A time series view of `signals` (the grip force view also shows the release marker)."""
    overrides: dict[str, list[Any]] = {}
    for signal in signals:
        overrides.setdefault(signal.entity, []).append(signal.visualizer())
    contents = [f"/{entity}" for entity in overrides]
    if signals[0].component == "GripperCommand:grip_force_n":
        contents.append(f"/{RELEASE_SERIES}")
    return rrb.TimeSeriesView(name=title, origin="/", contents=contents, overrides=overrides)


def blueprint(robot_name: str | None, follow_latest: bool = False, replay_in_loop: bool = False) -> rrb.Blueprint:
    """3-D view, signal panels and event log (sent once at the start of a recording).

    `follow_latest`: the time cursor follows the newest data (the end of a recording); used
    for screenshots. `replay_in_loop`: the viewer plays the recording over and over (a viewer
    kept busy: the load of a user watching a replay, `tests/integration/headless_viewer.py`).
    By default the viewer's own choice applies.
    """
    play_state = "following" if follow_latest else ("playing" if replay_in_loop else None)
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                view_3d(robot_name),
                rrb.TextLogView(name="Events", origin="/events"),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                *(signal_view(title, signals) for title, signals in PANELS.items()),
                rrb.TimeSeriesView(name="Gripper mode", origin="/signals/gripper_mode"),
                rrb.TimeSeriesView(name="Joint positions (rad)", origin="/robot/joint_position"),
            ),
            column_shares=[3, 2],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE_STAMP, state="expanded", play_state=play_state,
                      loop_mode="all" if replay_in_loop else None),
    )
