"""Target solids placed on the seabed and their analytic ray intersections.

All coordinates are local NED metres (x north, y east, z down; see
:mod:`perception.geometry`). A solid's yaw turns its length axis clockwise from north.
Every solid reaches from its top down to ``base_depth_m + footing_m``: the footing sinks it
into the seabed so that no gap opens on a slope or on relief; the seabed hides the buried
part because the nearest hit wins.

``intersect(origin, directions, normals=True)`` returns, per ray, the first entry distance
``t`` (``inf`` for a miss, and for rays that start inside) and the outward unit normal there
(an empty (0, 3) array when ``normals`` is False).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

_NO_HIT = np.inf


def _local_axes(yaw_rad: float) -> FloatArray:
    """Rows: the length axis, the width axis and down, in NED."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def _box_corners(north_m: float, east_m: float, base_depth_m: float, yaw_rad: float, length_m: float,
                 width_m: float, z_top_m: float, z_bottom_m: float) -> FloatArray:
    """The 8 corners, shape (8, 3), NED m, of a yawed box from ``z_top_m`` to ``z_bottom_m``
    (depths relative to the base, positive down)."""
    hl, hw = length_m / 2, width_m / 2
    local = np.array([[u, v, z] for u in (-hl, hl) for v in (-hw, hw) for z in (z_top_m, z_bottom_m)],
                     dtype=np.float64)
    return local @ _local_axes(yaw_rad) + np.array([north_m, east_m, base_depth_m])


@dataclass(frozen=True)
class BoxSolid:
    """A box: ``length_m`` along the yaw axis, ``width_m`` across, top ``height_m`` above base."""

    north_m: float
    east_m: float
    base_depth_m: float
    length_m: float
    width_m: float
    height_m: float
    yaw_rad: float
    footing_m: float

    def corners_ned(self) -> FloatArray:
        """The 8 corners, shape (8, 3), NED m."""
        return _box_corners(self.north_m, self.east_m, self.base_depth_m, self.yaw_rad,
                            self.length_m, self.width_m, -self.height_m, self.footing_m)

    def intersect(
        self, origin: FloatArray, directions: FloatArray, *, normals: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """First hits of rays from ``origin`` (3,) along unit ``directions`` (n, 3)."""
        axes = _local_axes(self.yaw_rad)
        o = axes @ (origin - np.array([self.north_m, self.east_m, self.base_depth_m]))
        x, y, z = directions[:, 0], directions[:, 1], directions[:, 2]
        # the ray in box axes, column by column (no BLAS: its threads hurt here). The axes'
        # zero entries add nothing, so these are bit for bit ``directions @ axes.T``.
        cols = (x * axes[0, 0] + y * axes[0, 1], x * axes[1, 0] + y * axes[1, 1], z)
        half = (self.length_m / 2, self.width_m / 2)
        bounds = ((-half[0], half[0]), (-half[1], half[1]), (-self.height_m, self.footing_m))
        entry = exit_ = np.zeros(0)
        entry_axis = np.zeros(directions.shape[0], dtype=np.int8)
        with np.errstate(all="ignore"):
            for axis in range(3):
                comp = cols[axis]
                # a zero component: treat as tiny, so the slab is all or nothing
                inv = 1.0 / np.where(comp == 0.0, 1e-300, comp)
                lo, hi = bounds[axis]
                t1 = (lo - o[axis]) * inv
                t2 = (hi - o[axis]) * inv
                near = np.minimum(t1, t2)
                far = np.maximum(t1, t2)
                if axis == 0:  # the first slab sets the interval
                    entry, exit_ = near, far
                    continue
                np.minimum(exit_, far, out=exit_)
                later = near > entry
                np.copyto(entry, near, where=later)
                entry_axis[later] = axis
        hit = (entry <= exit_) & (entry > 0)
        t = np.where(hit, entry, _NO_HIT)
        if not normals:
            return t, np.zeros((0, 3))
        normal = np.zeros_like(directions)
        idx = np.nonzero(hit)[0]
        if idx.size:
            ax = entry_axis[idx]
            d_ax = np.choose(ax, [c[idx] for c in cols])
            # the entry face's outward normal, in NED: -sign(d_axis) * (row `ax` of axes)
            normal[idx] = -np.sign(d_ax)[:, None] * axes[ax]
        return t, normal


@dataclass(frozen=True)
class CylinderSolid:
    """A vertical cylinder of ``radius_m``, top ``height_m`` above its base."""

    north_m: float
    east_m: float
    base_depth_m: float
    radius_m: float
    height_m: float
    footing_m: float

    def corners_ned(self) -> FloatArray:
        """Corners of the bounding box, shape (8, 3), NED m."""
        r = self.radius_m
        return np.array(
            [
                [self.north_m + a, self.east_m + b, self.base_depth_m + z]
                for a in (-r, r)
                for b in (-r, r)
                for z in (-self.height_m, self.footing_m)
            ]
        )

    def intersect(
        self, origin: FloatArray, directions: FloatArray, *, normals: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """First hits of rays from ``origin`` (3,) along unit ``directions`` (n, 3)."""
        top = self.base_depth_m - self.height_m
        bottom = self.base_depth_m + self.footing_m
        ox, oy = origin[0] - self.north_m, origin[1] - self.east_m
        dx, dy, dz = directions[:, 0], directions[:, 1], directions[:, 2]
        a = dx * dx + dy * dy
        b = 2.0 * (ox * dx + oy * dy)
        c = ox * ox + oy * oy - self.radius_m**2
        disc = b * b - 4.0 * a * c
        with np.errstate(all="ignore"):
            t_side = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
            z_side = origin[2] + t_side * dz
            side_ok = (a > 0) & (disc >= 0) & (t_side > 0) & (z_side >= top) & (z_side <= bottom)
            t_side = np.where(side_ok, t_side, _NO_HIT)
            t_cap = (top - origin[2]) / dz
            px, py = ox + t_cap * dx, oy + t_cap * dy
            cap_ok = (dz > 0) & (t_cap > 0) & (px * px + py * py <= self.radius_m**2)
        t_cap = np.where(cap_ok, t_cap, _NO_HIT)
        use_cap = t_cap < t_side
        t = np.minimum(t_cap, t_side)
        if not normals:
            return t, np.zeros((0, 3))
        hx, hy = ox + np.where(np.isfinite(t), t, 0.0) * dx, oy + np.where(np.isfinite(t), t, 0.0) * dy
        rad = np.hypot(hx, hy)
        rad = np.where(rad > 0, rad, 1.0)
        normal = np.stack([hx / rad, hy / rad, np.zeros_like(hx)], axis=1)
        normal[use_cap] = (0.0, 0.0, -1.0)
        return t, normal


@dataclass(frozen=True)
class EllipsoidSolid:
    """An ellipsoid centred at ``base_depth_m`` whose upper half stands ``height_m`` tall.

    Semi-axes: ``length_m / 2`` along the yaw axis, ``width_m / 2`` across, ``height_m``
    vertical. The lower half lies under the seabed (a rounded stone half buried).
    """

    north_m: float
    east_m: float
    base_depth_m: float
    length_m: float
    width_m: float
    height_m: float
    yaw_rad: float

    def corners_ned(self) -> FloatArray:
        """Corners of the bounding box of the upper half (plus a little below), NED m."""
        return _box_corners(self.north_m, self.east_m, self.base_depth_m, self.yaw_rad,
                            self.length_m, self.width_m, -self.height_m, 0.5 * self.height_m)

    def intersect(
        self, origin: FloatArray, directions: FloatArray, *, normals: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """First hits of rays from ``origin`` (3,) along unit ``directions`` (n, 3)."""
        axes = _local_axes(self.yaw_rad)
        scale = np.array([2.0 / self.length_m, 2.0 / self.width_m, 1.0 / self.height_m])
        o = (axes @ (origin - np.array([self.north_m, self.east_m, self.base_depth_m]))) * scale
        # explicit column arithmetic, summed in the order numpy's 3-term einsum uses
        # ((term 0 + term 2) + term 1), so the results are bit for bit those of einsum (the
        # axes' zero entries add nothing)
        x, y, z = directions[:, 0], directions[:, 1], directions[:, 2]
        d0 = (x * axes[0, 0] + y * axes[0, 1]) * scale[0]
        d1 = (x * axes[1, 0] + y * axes[1, 1]) * scale[1]
        d2 = z * scale[2]
        a = (d0 * d0 + d2 * d2) + d1 * d1
        b = 2.0 * ((d0 * o[0] + d2 * o[2]) + d1 * o[1])
        c = float(o @ o) - 1.0
        disc = b * b - 4.0 * a * c
        t = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
        ok = (disc >= 0) & (t > 0) & (c > 0)
        t = np.where(ok, t, _NO_HIT)
        if not normals:
            return t, np.zeros((0, 3))
        normal = np.zeros_like(directions)
        idx = np.nonzero(ok)[0]
        if idx.size:
            d = np.stack([d0[idx], d1[idx], d2[idx]], axis=1)
            p = o + t[idx, None] * d
            grad = np.einsum("ij,jk->ik", p * scale, axes)  # gradient of |M x|^2 / 2, back in NED
            normal[idx] = grad / np.sqrt(np.einsum("ij,ij->i", grad, grad))[:, None]
        return t, normal


@dataclass(frozen=True)
class CompositeSolid:
    """A union of ellipsoids (an irregular rock); the nearest lobe wins."""

    lobes: tuple[EllipsoidSolid, ...]

    def corners_ned(self) -> FloatArray:
        """Corners of every lobe's bounding box, shape (8 * n_lobes, 3), NED m."""
        return np.concatenate([lobe.corners_ned() for lobe in self.lobes])

    def intersect(
        self, origin: FloatArray, directions: FloatArray, *, normals: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """First hits of rays from ``origin`` (3,) along unit ``directions`` (n, 3)."""
        best_t = np.full(directions.shape[0], _NO_HIT)
        best_lobe = np.full(directions.shape[0], -1, dtype=np.int16)
        for i, lobe in enumerate(self.lobes):
            t, _ = lobe.intersect(origin, directions, normals=False)
            closer = t < best_t
            np.copyto(best_t, t, where=closer)
            best_lobe[closer] = i
        if not normals:
            return best_t, np.zeros((0, 3))
        # normals only where each lobe wins (a ray's arithmetic does not depend on the others)
        best_n = np.zeros_like(directions)
        for i, lobe in enumerate(self.lobes):
            idx = np.nonzero(best_lobe == i)[0]
            if idx.size:
                best_n[idx] = lobe.intersect(origin, directions[idx], normals=True)[1]
        return best_t, best_n


Solid = BoxSolid | CylinderSolid | EllipsoidSolid | CompositeSolid
