"""Vectorised ray intersections for the depth renderer (numpy, no loops over pixels).

Rays start at one origin `o` (the camera) and run along directions `d` that need not be
unit length: the returned parameter t is such that the hit is `o + t d`. With the camera's
rays scaled to z = 1 in the optical frame, t is the depth along the optical axis.
Misses are +inf.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Capsule:
    """A segment `a`–`b` swept by a sphere of `radius_m` (`base` frame, metres).

    A sphere is a capsule with a == b.
    """

    a_m: np.ndarray
    b_m: np.ndarray
    radius_m: float


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in `base` from `lower_m` to `upper_m` (metres)."""

    lower_m: np.ndarray
    upper_m: np.ndarray


def _sphere_entry(b: np.ndarray, c: np.ndarray | float, dd: np.ndarray) -> np.ndarray:
    """Entry parameter into a sphere, +inf on a miss or a hit behind the origin.

    With `oc` the origin minus the sphere's centre: b = d·oc, c = oc·oc − r², dd = d·d."""
    h = b * b - dd * c
    ok = h >= 0.0
    t = (-b - np.sqrt(np.where(ok, h, 0.0))) / dd
    return np.where(ok & (t > 0.0), t, np.inf)


def ray_capsule(origin_m: np.ndarray, dirs: np.ndarray, capsule: Capsule,
                dd: np.ndarray | None = None) -> np.ndarray:
    """Smallest positive ray parameter of the hit with `capsule`, +inf on a miss.

    The capsule lies inside the infinite cylinder around its axis. A ray that misses that
    cylinder misses the capsule; one that enters it between the ends hits the body there;
    one that enters it beyond an end can only hit that end's sphere (Quílez's capsule
    intersection). Rays parallel to the axis test both end spheres. The origin must be
    outside the capsule (the camera is).

    Args:
        origin_m: (3,) common ray origin.
        dirs: (..., 3) ray directions.
        capsule: the capsule.
        dd: (...,) the rays' squared lengths ``dirs · dirs``, when the caller keeps them
            (the renderer does: they do not change between frames).

    Returns:
        (...,) ray parameters t.
    """
    pa = np.asarray(capsule.a_m, float)
    ba = np.asarray(capsule.b_m, float) - pa
    oa = np.asarray(origin_m, float) - pa
    r2 = capsule.radius_m**2
    if dd is None:
        dd = np.einsum("...i,...i->...", dirs, dirs)
    rdoa = dirs @ oa
    oaoa = float(oa @ oa)
    baba = float(ba @ ba)
    if baba <= 1e-12:
        return _sphere_entry(rdoa, oaoa - r2, dd)
    baoa = float(ba @ oa)
    ob = oa - ba
    obob = float(ob @ ob)
    bard = dirs @ ba
    a = baba * dd - bard * bard
    b = baba * rdoa - baoa * bard
    c = baba * oaoa - baoa * baoa - r2 * baba
    h = b * b - a * c
    hit = (h >= 0.0) & (a > 1e-12)
    t_cyl = (-b - np.sqrt(np.where(hit, h, 0.0))) / np.where(hit, a, 1.0)
    y = baoa + t_cyl * bard
    body = hit & (y > 0.0) & (y < baba) & (t_cyl > 0.0)
    beyond_b = y >= baba
    t_cap = _sphere_entry(np.where(beyond_b, rdoa - bard, rdoa), np.where(beyond_b, obob - r2, oaoa - r2), dd)
    t = np.where(body, t_cyl, np.where(hit, t_cap, np.inf))
    parallel = a <= 1e-12
    if np.any(parallel):
        t[parallel] = np.minimum(_sphere_entry(rdoa[parallel], oaoa - r2, dd[parallel]),
                                 _sphere_entry(rdoa[parallel] - bard[parallel], obob - r2, dd[parallel]))
    return t


def ray_box(origin_m: np.ndarray, dirs: np.ndarray, box: Box) -> np.ndarray:
    """Entry parameter of each ray into an axis-aligned box (slab method), +inf on a miss."""
    o = np.asarray(origin_m, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / dirs
        t1 = (np.asarray(box.lower_m, float) - o) * inv
        t2 = (np.asarray(box.upper_m, float) - o) * inv
    t1 = np.nan_to_num(t1, nan=-np.inf)
    t2 = np.nan_to_num(t2, nan=np.inf)
    t_near = np.max(np.minimum(t1, t2), axis=-1)
    t_far = np.min(np.maximum(t1, t2), axis=-1)
    hit = (t_far >= t_near) & (t_near > 0.0)
    return np.where(hit, t_near, np.inf)


def ray_horizontal_plane(origin_m: np.ndarray, dirs: np.ndarray, z_m: float) -> np.ndarray:
    """Ray parameter of the hit with the plane z = `z_m` (from either side), +inf on a miss."""
    dz = dirs[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z_m - float(origin_m[2])) / dz
    return np.where(np.isfinite(t) & (t > 0.0), t, np.inf)


def point_capsule_distance(points_m: np.ndarray, capsule: Capsule) -> np.ndarray:
    """Distance (N,) from points (N, 3) to the capsule's surface (negative inside)."""
    a = np.asarray(capsule.a_m, float)
    ba = np.asarray(capsule.b_m, float) - a
    pa = np.asarray(points_m, float) - a
    baba = float(ba @ ba)
    h = np.clip(pa @ ba / baba, 0.0, 1.0) if baba > 1e-12 else np.zeros(len(pa))
    return np.linalg.norm(pa - h[:, None] * ba, axis=1) - capsule.radius_m
