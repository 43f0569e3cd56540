"""Ray casting of one capsule into a rectangle of the camera's rays, with fewer array passes.

`BlockCaster.capsule` returns, pixel for pixel, the same float64 values as
`handover_model.shapes.ray_capsule` (the same operations on the same operands in the same
order, so the same roundings), but

- writes into scratch buffers kept between calls instead of allocating a temporary per step;
- divides by the cylinder's `a` without masking it first (a pixel whose ray misses the
  infinite cylinder is set to +inf at the end whatever its intermediate values);
- solves the end spheres only on the pixels that need them: rays that hit the infinite
  cylinder outside the segment (a few percent of a rectangle), gathered by index.

The rays start at the camera (`origin_m`) and are scaled to unit depth, so the results are
depths along the optical axis (m); +inf is a miss.
"""

from __future__ import annotations

import numpy as np

from handover_model.shapes import Capsule

#: `ray_capsule`'s threshold (m⁴ for a, m² for |b − a|²) below which a ray is parallel to
#: the axis, or the capsule is a sphere.
_EPS = 1e-12
_N_FLOAT = 9
_N_BOOL = 4


def _sphere_entry(b: np.ndarray, c: np.ndarray | float, dd: np.ndarray) -> np.ndarray:
    """`handover_model.shapes._sphere_entry` on flat arrays: the same arithmetic, new array."""
    h = b * b
    h -= dd * c
    ok = h >= 0.0
    np.sqrt(h, out=h, where=ok)
    t = np.negative(b)
    t -= h
    t /= dd
    ok &= t > 0.0
    t[~ok] = np.inf
    return t


class BlockCaster:
    """Casts capsules into rectangles of a fixed set of camera rays.

    Args:
        origin_m: (3,) the rays' common origin (m, `base`).
        rays: (H, W, 3) ray directions (`base`); the ray parameter is the returned depth.
        dd: (H, W) the rays' squared lengths.
    """

    def __init__(self, origin_m: np.ndarray, rays: np.ndarray, dd: np.ndarray) -> None:
        self.origin_m = np.asarray(origin_m, float)
        self.rays = rays
        self.dd = dd
        n = dd.size
        self._f = np.empty((_N_FLOAT, n))
        self._b = np.empty((_N_BOOL, n), bool)

    def capsule(self, capsule: Capsule, rect: tuple[int, int, int, int]) -> np.ndarray:
        """Depth (v1 − v0, u1 − u0) of `capsule` over the pixels of `rect` (u0, u1, v0, v1),
        +inf where the ray misses it; equal to `ray_capsule` on the same rays."""
        u0, u1, v0, v1 = rect
        shape = (v1 - v0, u1 - u0)
        n = shape[0] * shape[1]
        dirs = self.rays[v0:v1, u0:u1]
        f = [self._f[i, :n] for i in range(_N_FLOAT)]
        m = [self._b[i, :n] for i in range(_N_BOOL)]
        rdoa, bard, dd, a, b, h, tmp, t, y = f
        np.copyto(dd.reshape(shape), self.dd[v0:v1, u0:u1])
        pa = np.asarray(capsule.a_m, float)
        ba = np.asarray(capsule.b_m, float) - pa
        oa = self.origin_m - pa
        r2 = capsule.radius_m**2
        np.matmul(dirs, oa, out=rdoa.reshape(shape))
        oaoa = float(oa @ oa)
        baba = float(ba @ ba)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            if baba <= _EPS:
                return _sphere_entry(rdoa, oaoa - r2, dd).reshape(shape)
            baoa = float(ba @ oa)
            ob = oa - ba
            obob = float(ob @ ob)
            np.matmul(dirs, ba, out=bard.reshape(shape))
            np.multiply(dd, baba, out=a)
            a -= np.multiply(bard, bard, out=tmp)
            np.multiply(rdoa, baba, out=b)
            b -= np.multiply(bard, baoa, out=tmp)
            c = baba * oaoa - baoa * baoa - r2 * baba
            np.multiply(b, b, out=h)
            h -= np.multiply(a, c, out=tmp)
            hit, cyl, body, cond = m
            np.greater(a, _EPS, out=cyl)
            np.greater_equal(h, 0.0, out=hit)
            hit &= cyl
            # t_cyl = (−b − sqrt(h)) / a on the hits (elsewhere: any value, masked below).
            np.maximum(h, 0.0, out=h)
            np.sqrt(h, out=h)
            np.negative(b, out=t)
            t -= h
            t /= a
            np.multiply(t, bard, out=y)
            y += baoa
            np.greater(y, 0.0, out=body)
            body &= hit
            body &= np.less(y, baba, out=cond)
            body &= np.greater(t, 0.0, out=cond)
            out = np.where(body, t, np.inf)
            caps = np.flatnonzero(np.not_equal(hit, body, out=cond))  # hit but not on the body
            if caps.size:
                y_c, bard_c = y[caps], bard[caps]
                beyond_b = y_c >= baba
                b_c = rdoa[caps]
                np.subtract(b_c, bard_c, out=b_c, where=beyond_b)
                out[caps] = _sphere_entry(b_c, np.where(beyond_b, obob - r2, oaoa - r2), dd[caps])
            if not cyl.all():
                par = np.flatnonzero(~cyl)
                out[par] = np.minimum(_sphere_entry(rdoa[par], oaoa - r2, dd[par]),
                                     _sphere_entry(rdoa[par] - bard[par], obob - r2, dd[par]))
        return out.reshape(shape)
