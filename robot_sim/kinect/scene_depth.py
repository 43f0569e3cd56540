"""Depth of a scene whose static part never moves, frame after frame, casting only what moved.

`SceneDepthRenderer` renders the static part (floor, table, the robot's fixed parts, the receiver's
legs) once. Each frame it takes the moving primitives (the arm's capsules, the receiver's
upper body, the object's box) and keeps, per primitive, the depth tile cast over its
conservative pixel rectangle (`DepthRenderer.capsule_rects`), keyed by the primitive's exact
geometry (the float64 bytes of its ends and radius, or corners). A primitive whose geometry
is bit for bit the one of the previous frame reuses its tile; the others are cast
(`BlockCaster`). The frame is the static image with every tile composited by min depth.
When every key equals the previous frame's, the image is the previous one: nothing is cast or
composited and `changed` is False.

The result equals `render_reference` (every primitive cast over the whole scene each frame)
bit for bit: the tiles hold the same values as `ray_capsule`/`ray_box` give, outside its
rectangle a primitive has no hit, and min is exact and order-free.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robot_sim.kinect.block_cast import BlockCaster
from robot_sim.kinect.camera import KinectCamera
from robot_sim.kinect.depth import DepthRenderer, Rect
from handover_model.shapes import Box, Capsule, ray_box


@dataclass(frozen=True)
class StaticScene:
    """The part of a scene that never moves (m, `base`)."""

    capsules: tuple[Capsule, ...] = ()
    boxes: tuple[Box, ...] = ()
    floor_z_m: float | None = None


def render_reference(renderer: DepthRenderer, static: StaticScene, capsules: Sequence[Capsule],
                     boxes: Sequence[Box]) -> np.ndarray:
    """The straightforward render: the whole scene (static and moving) cast in one go, as
    every frame did before the cache. `SceneDepthRenderer.render` must equal it exactly
    (tests and the benchmark's baseline). Depth (H, W), m, +inf = no hit."""
    return renderer.render([*static.capsules, *capsules], [*static.boxes, *boxes], floor_z_m=static.floor_z_m)


def _capsule_key(capsule: Capsule) -> bytes:
    return b"c" + np.concatenate([np.asarray(capsule.a_m, float), np.asarray(capsule.b_m, float),
                                  [float(capsule.radius_m)]]).tobytes()


def _box_key(box: Box) -> bytes:
    return b"b" + np.concatenate([np.asarray(box.lower_m, float), np.asarray(box.upper_m, float)]).tobytes()


#: A cast primitive: its rectangle and depth tile, or None when it is not in view.
_Tile = tuple[Rect, np.ndarray] | None


class SceneDepthRenderer:
    """Depth images of a static scene plus moving primitives, reusing what did not move.

    Args:
        camera: the (fixed) camera.
        static: the part of the scene that never moves; cast once here.

    Attributes:
        renderer: the plain renderer (rays, rectangles; `render_reference` uses it).
        background_m: the static part's depth (H, W), m, read-only.
        changed: whether the last `render` gave a different image from the one before.
        cast, reused: primitives cast and primitives whose tile was reused, all frames.
    """

    def __init__(self, camera: KinectCamera, static: StaticScene) -> None:
        self.renderer = DepthRenderer(camera)
        self.static = static
        self.background_m = self.renderer.render(list(static.capsules), list(static.boxes),
                                                 floor_z_m=static.floor_z_m)
        self.background_m.flags.writeable = False
        self._caster = BlockCaster(camera.position_m, self.renderer.rays, self.renderer.dd)
        self._depth = self.background_m.copy()
        self._view = self._depth.view()
        self._view.flags.writeable = False
        self._tiles: dict[bytes, _Tile] = {}
        self._keys: list[bytes] | None = None
        self.changed = True
        self.cast = 0
        self.reused = 0

    def _cast_box(self, box: Box, rect: Rect) -> np.ndarray:
        u0, u1, v0, v1 = rect
        return ray_box(self.renderer.camera.position_m, self.renderer.rays[v0:v1, u0:u1], box)

    def render(self, capsules: Sequence[Capsule], boxes: Sequence[Box] = ()) -> np.ndarray:
        """Depth (H, W), m, +inf = no hit, of the static scene with `capsules` and `boxes`
        (m, `base`). Returns a read-only view that the next call overwrites (copy to keep)."""
        keys = [_capsule_key(c) for c in capsules] + [_box_key(b) for b in boxes]
        if keys == self._keys:
            self.changed = False
            self.reused += len(keys)
            return self._view
        old, new = self._tiles, {}
        new_capsules = [(k, c) for k, c in zip(keys, capsules) if k not in old]
        new_boxes = [(k, b) for k, b in zip(keys[len(capsules):], boxes) if k not in old]
        rects = self.renderer.capsule_rects([c for _, c in new_capsules])
        for (key, capsule), rect in zip(new_capsules, rects, strict=True):
            new[key] = None if rect is None else (rect, self._caster.capsule(capsule, rect))
        for (key, box), rect in zip(new_boxes, self.renderer.box_rects([b for _, b in new_boxes]), strict=True):
            new[key] = None if rect is None else (rect, self._cast_box(box, rect))
        self.cast += len(new)
        for key in keys:
            if key not in new:
                new[key] = old[key]
                self.reused += 1
        self._tiles, self._keys = new, keys
        depth = self._depth
        np.copyto(depth, self.background_m)
        for tile in new.values():
            if tile is not None:
                (u0, u1, v0, v1), t = tile
                np.minimum(depth[v0:v1, u0:u1], t, out=depth[v0:v1, u0:u1])
        self.changed = True
        return self._view
