"""The arm in the recording: its model (static, once) and its joint transforms (batched).

The arm is the active description's (`handover_model.robots`), placed in the scene frame
`base` as the stack places it (`robots.placed_urdf_file`).

Model (`RecorderConfig.robot_model`):

- ``primitives`` (default, ~60 kB): Rerun's own URDF loader (`rr.urdf.UrdfTree`) emits the
  model's chunks; the meshes (`Asset3D`), the collision spheres (two 0.22 m balls round the
  head, hidden by the blueprint anyway) and the entities left without geometry are dropped, the
  rest is kept: the static joint transforms (``tf_static``), the collision cylinders and boxes
  (arms, grippers) and the URDF's small visual primitives (display, sonar ring, hand camera),
  one chunk per entity (the loader's three per entity cost ~1 kB each). An arm whose links have
  only meshes (Panda, UR5, SO-ARM101) is drawn as the convex hulls of its STL collision meshes
  (hull by coal/Qhull, a few hundred vertices each), at the collision entities; a torso that
  has only meshes (the default arm's) as the convex hull of its collision mesh (193 vertices,
  382 triangles) at the torso's visual entity.
- ``meshes`` (~16 MB): `rr.log_file_from_path(urdf)`: every Collada mesh. The Rerun 0.41 viewer
  can import only the torso's (the others use ``<polylist>``); the arms are drawn with the same
  collision cylinders as in ``primitives``.
- ``none``: no model; the joint series are still recorded.

Joint transforms: `UrdfTree.compute_joint_transform_batches` turns a batch of joint states
(names and positions, rad) into one transform per joint and message in one native call; they are
sent with `send_columns` to ``transforms`` (child frame = the joint's child link), for one joint
state in `pose_every`.
"""

from __future__ import annotations

import logging
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import rerun as rr

from services.recorder.columns import TIMELINE_RECEIVE, TIMELINE_STAMP
from services.recorder.config import RobotModelMode

log = logging.getLogger(__name__)

#: Colour of the torso's hull (dark grey, RGB).
TORSO_RGB = (60, 60, 60)
#: Colour of the links' hulls of an arm drawn by its STL collision meshes (light grey, RGB).
LINK_RGB = (190, 190, 195)


def _mesh_file(urdf: Path, link: str, kind: str) -> Path | None:
    """The mesh file of `link`'s first `kind` (``visual``/``collision``) geometry, resolved with
    ``ROS_PACKAGE_PATH`` for ``package://`` names."""
    roots = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    for node in ET.parse(urdf).getroot().iterfind(f"link[@name='{link}']/{kind}/geometry/mesh"):
        name = node.get("filename", "")
        relative = name.removeprefix("package://")
        candidates = [r / relative for r in roots] if name.startswith("package://") else [urdf.parent / name]
        return next((c for c in candidates if c.is_file()), None)
    return None


def convex_hull_mesh(mesh_file: Path, rgb: tuple[int, int, int]) -> rr.Mesh3D:
    """The convex hull of a mesh file (m) as a `Mesh3D` with outward-facing triangles (coal
    loads the mesh and builds the hull with Qhull: ~5 ms for the torso)."""
    import coal

    vertices = coal.StdVec_Vec3s()
    vertices.extend(np.asarray(coal.MeshLoader().load(str(mesh_file), np.ones(3)).vertices(), dtype=np.float64))
    hull = coal.ConvexBase.convexHull(vertices, True, "Qt")
    points = np.asarray(hull.points(), dtype=np.float64)
    triangles = np.array([[hull.polygons(i)[k] for k in range(3)] for i in range(hull.num_polygons)], dtype=np.int64)
    a, b, c = (points[triangles[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - points.mean(axis=0)) < 0
    triangles[inward] = triangles[inward][:, ::-1]
    return rr.Mesh3D(vertex_positions=points.astype(np.float32), triangle_indices=triangles.astype(np.uint32),
                     albedo_factor=[*rgb, 255])


#: Archetypes that only place an entity (no geometry of their own).
_PLACEMENT = frozenset({b"rerun.archetypes.InstancePoses3D", b"rerun.archetypes.CoordinateFrame"})


def primitive_model(chunks, keep: frozenset[str] = frozenset()) -> tuple[list, list[tuple[str, pa.RecordBatch]]]:
    """Split the URDF loader's `chunks` into (chunks kept as they are, (entity, merged static
    batch) per geometry entity) without meshes, collision spheres or geometry-less entities
    (those in `keep` stay even without geometry)."""
    by_entity: dict[str, list] = {}
    for chunk in chunks:
        by_entity.setdefault(chunk.entity_path, []).append(chunk)
    as_is, merged = [], []
    for entity, group in by_entity.items():
        if "/collision_geometries/sphere/" in entity:
            continue
        if len(group) == 1 and "_geometries/" not in entity:
            as_is.append(group[0])  # tf_static, the robot's root frame
            continue
        fields, arrays = [], []
        for batch in (c.to_record_batch() for c in group):
            for f, column in zip(batch.schema, batch.columns, strict=True):
                meta = f.metadata or {}
                if meta.get(b"rerun:kind") == b"data" and meta.get(b"rerun:archetype") != b"rerun.archetypes.Asset3D":
                    fields.append(f)
                    arrays.append(column)
        has_geometry = any((f.metadata or {}).get(b"rerun:archetype") not in _PLACEMENT for f in fields)
        if fields and (has_geometry or entity in keep):
            merged.append((entity, pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields))))
    return as_is, merged


def stl_collision_meshes(urdf: Path, robot_name: str) -> dict[str, Path]:
    """Entity (as Rerun's URDF loader names it) → file of every STL collision mesh of `urdf`,
    resolved with ``ROS_PACKAGE_PATH``."""
    roots = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    out = {}
    for link in ET.parse(urdf).getroot().iter("link"):
        for k, collision in enumerate(link.findall("collision")):
            for node in collision.iterfind("geometry/mesh"):
                name = node.get("filename", "")
                if not name.lower().endswith(".stl"):
                    continue
                relative = name.removeprefix("package://")
                candidates = [r / relative for r in roots] if name.startswith("package://") else [urdf.parent / name]
                found = next((c for c in candidates if c.is_file()), None)
                if found is not None:
                    out[f"/{robot_name}/collision_geometries/mesh/{link.get('name')}/collision_{k}"] = found
    return out


class RobotModel:
    """The active arm's model logged once (static) in `mode`, and its joint transforms."""

    def __init__(self, rec: rr.RecordingStream, mode: RobotModelMode, pose_every: int = 1) -> None:
        from handover_model import robots

        robots.urdf_path(robots.active())  # sets ROS_PACKAGE_PATH so the meshes resolve
        path = robots.placed_urdf_file(robots.active())
        self.tree = rr.urdf.UrdfTree.from_file_path(path)
        self.robot_name = self.tree.name
        self.pose_every = pose_every
        self._joint_states_seen = 0
        if mode == "meshes":
            rec.log_file_from_path(path, static=True)
        else:
            torso_entity = f"/{self.robot_name}/visual_geometries/torso/visual_0"
            hulls = stl_collision_meshes(path, self.robot_name)  # arms drawn by their meshes only
            as_is, merged = primitive_model(self.tree.stream(include_joint_transforms=True),
                                            frozenset({torso_entity, *hulls}))
            rr.send_chunks(as_is, recording=rec)
            for entity, batch in merged:
                rec.send_record_batch(batch, index=None, entity_path=entity)
            for entity, mesh in hulls.items():
                rec.log(entity, convex_hull_mesh(mesh, LINK_RGB), static=True)
            torso = _mesh_file(path, "torso", "collision")
            if torso is not None:
                rec.log(torso_entity, convex_hull_mesh(torso, TORSO_RGB), static=True)

    def send_transforms(self, rec: rr.RecordingStream, names: pa.Array, positions_rad: pa.Array,
                        stamps_ns: np.ndarray, receives_ns: np.ndarray) -> int:
        """Send the transforms of one joint state in `pose_every` of a batch (`names`: list<utf8>,
        `positions_rad`: list<float64>, one row per message); returns the transforms sent."""
        start = (-self._joint_states_seen) % self.pose_every
        self._joint_states_seen += len(stamps_ns)
        rows = np.arange(start, len(stamps_ns), self.pose_every)
        if not rows.size:
            return 0
        take = pa.array(rows)
        batches = self.tree.compute_joint_transform_batches(names.take(take), positions_rad.take(take), clamp=True)
        per_row = np.asarray(pc.list_value_length(batches), dtype=np.int64)
        flat = batches.flatten()
        if not len(flat):
            return 0
        translation = np.asarray(flat.field("translation").flatten(), dtype=np.float32).reshape(-1, 3)
        quaternion = np.asarray(flat.field("quaternion").flatten(), dtype=np.float32).reshape(-1, 4)
        indexes = [rr.TimeColumn(TIMELINE_STAMP,
                                 timestamp=np.repeat(stamps_ns[rows], per_row).astype("datetime64[ns]")),
                   rr.TimeColumn(TIMELINE_RECEIVE,
                                 timestamp=np.repeat(receives_ns[rows], per_row).astype("datetime64[ns]"))]
        rec.send_columns("transforms", indexes=indexes, columns=rr.Transform3D.columns(
            translation=translation, quaternion=quaternion, parent_frame=flat.field("parent_frame"),
            child_frame=flat.field("child_frame")))
        return len(flat)
