"""Target solids placed on the seabed and their analytic ray intersections.

(Over 400 lines: one ray arithmetic shared by the four basic solids -- local axes, per-ray
parameter columns, the scaled-sphere root of the stone and the rock -- and each solid's
``intersect`` is its kind's batch kernel run on that solid alone, so a solid and a batch of
solids give bit-identical hits; split by solid, every part would import the shared helpers
and the dispatcher every kernel. The pipe, which shares none of them, is
:mod:`sim_harness.world.pipe`.)

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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sim_harness.world.pipe import PipeSolid, pipe_batch

FloatArray = NDArray[np.float64]

_NO_HIT = np.inf


def _components(directions: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The three columns of ``directions`` (n, 3) as contiguous arrays (the arithmetic on
    them then runs on unit strides)."""
    return (np.ascontiguousarray(directions[:, 0]), np.ascontiguousarray(directions[:, 1]),
            np.ascontiguousarray(directions[:, 2]))


def _one_solid(batch: Callable[..., tuple[FloatArray, FloatArray]], solid: object, origin: FloatArray,
               directions: FloatArray, normals: bool) -> tuple[FloatArray, FloatArray]:
    """Rays from ``origin`` (3,) along unit ``directions`` (n, 3) against one solid, with the
    arithmetic of its kind's batch function (its parameters broadcast as scalars).

    Returns ``(t, normal)``: range to the first hit, m (``inf`` for a miss), shape (n,); the
    outward unit normal there, NED, shape (n, 3) (zeros for misses), or shape (0, 3) when
    ``normals`` is False.
    """
    return batch([solid], np.zeros(directions.shape[0], dtype=np.intp), origin, directions, normals)


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
        """First hits of rays from ``origin`` along ``directions`` (:func:`_one_solid`)."""
        return _one_solid(_box_batch, self, origin, directions, normals)


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
        """First hits of rays from ``origin`` along ``directions`` (:func:`_one_solid`)."""
        return _one_solid(_cylinder_batch, self, origin, directions, normals)


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
        """First hits of rays from ``origin`` along ``directions`` (:func:`_one_solid`)."""
        return _one_solid(_ellipsoid_batch, self, origin, directions, normals)


@dataclass(frozen=True)
class CompositeSolid:
    """A union of ellipsoids (an irregular rock); the nearest lobe wins."""

    lobes: tuple[EllipsoidSolid, ...]
    _frames: tuple[tuple[FloatArray, FloatArray, FloatArray], ...] = field(init=False, repr=False, compare=False)
    _lobe_table: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        frames = tuple(
            (_local_axes(lobe.yaw_rad), np.array([lobe.north_m, lobe.east_m, lobe.base_depth_m]),
             np.array([2.0 / lobe.length_m, 2.0 / lobe.width_m, 1.0 / lobe.height_m]))
            for lobe in self.lobes
        )
        table = np.array([[a[0, 0], a[0, 1], a[1, 0], a[1, 1], *sc] for a, _, sc in frames]).T[:, :, None]
        object.__setattr__(self, "_frames", frames)
        object.__setattr__(self, "_lobe_table", table)  # (7, n_lobes, 1): axes entries, scales

    def corners_ned(self) -> FloatArray:
        """Corners of every lobe's bounding box, shape (8 * n_lobes, 3), NED m."""
        return np.concatenate([lobe.corners_ned() for lobe in self.lobes])

    def intersect(
        self, origin: FloatArray, directions: FloatArray, *, normals: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """First hits of rays from ``origin`` (3,) along unit ``directions`` (n, 3).

        All lobes at once on (n_lobes, n) arrays, each (lobe, ray) pair with the arithmetic of
        :meth:`EllipsoidSolid.intersect`; the nearest lobe wins (the first one on ties).
        """
        frames = self._frames
        rows_ = []
        for axes, centre, scale in frames:
            o = (axes @ (origin - centre)) * scale
            rows_.append([*o, float(o @ o) - 1.0])
        o0, o1, o2, c = np.array(rows_).T[:, :, None]  # each (n_lobes, 1)
        a00, a01, a10, a11, s0, s1, s2 = self._lobe_table
        # (n_lobes, n_rays) arrays: the rays run along the contiguous axis
        x, y, z = _components(directions)
        d0, d1, d2, t, _ = _scaled_sphere_hits(x, y, z, self._lobe_table, o0, o1, o2, c)
        if not normals:  # the nearest lobe's distance (the value argmin picks)
            return np.min(t, axis=0), np.zeros((0, 3))
        win = np.argmin(t, axis=0)
        rays = np.arange(directions.shape[0])
        best_t = t[win, rays]
        best_n = np.zeros_like(directions)
        idx = np.flatnonzero(np.isfinite(best_t))
        if idx.size:
            lobe = win[idx]
            ti = best_t[idx]
            # as _ellipsoid_batch: p * scale in the lobe's axes, back to NED as einsum
            # sums it ((term 0 + term 1) + term 2 over the axes' rows)
            ps0 = (o0[lobe, 0] + ti * d0[lobe, idx]) * s0[lobe, 0]
            ps1 = (o1[lobe, 0] + ti * d1[lobe, idx]) * s1[lobe, 0]
            ps2 = (o2[lobe, 0] + ti * d2[lobe, idx]) * s2[lobe, 0]
            g0 = (ps0 * a00[lobe, 0] + ps1 * a10[lobe, 0]) + ps2 * 0.0
            g1 = (ps0 * a01[lobe, 0] + ps1 * a11[lobe, 0]) + ps2 * 0.0
            g2 = (ps0 * 0.0 + ps1 * 0.0) + ps2 * 1.0
            norm = np.sqrt((g0 * g0 + g2 * g2) + g1 * g1)
            best_n[idx] = np.stack([g0, g1, g2], axis=1) / norm[:, None]
        return best_t, best_n


Solid = BoxSolid | CylinderSolid | EllipsoidSolid | CompositeSolid | PipeSolid


# ---------------------------------------------------------------------------- batches
def _scaled_sphere_hits(x: FloatArray, y: FloatArray, z: FloatArray, axes_scale: Sequence[Any] | FloatArray,
                        o0: Any, o1: Any, o2: Any, c: Any) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray,
                                                              NDArray[np.bool_]]:
    """Rays (components ``x, y, z``) against ellipsoids taken to the unit sphere: the ray
    directions in the scaled frames ``d0, d1, d2``, the nearer root ``t`` of
    ``|o + t d|^2 = 1`` (``_NO_HIT`` where it misses, lies behind, or the origin is inside)
    and where it hits. ``axes_scale`` = (a00, a01, a10, a11, s0, s1, s2): the horizontal
    axes' entries and the scales; ``o0, o1, o2`` the scaled origins and ``c = |o|^2 - 1``.
    Scalars or arrays that broadcast with the rays (one arithmetic for every caller)."""
    a00, a01, a10, a11, s0, s1, s2 = axes_scale
    d0 = (x * a00 + y * a01) * s0
    d1 = (x * a10 + y * a11) * s1
    d2 = z * s2
    a = (d0 * d0 + d2 * d2) + d1 * d1
    b = 2.0 * ((d0 * o0 + d2 * o2) + d1 * o1)
    disc = b * b - 4.0 * a * c
    t = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
    ok = (disc >= 0) & (t > 0) & (c > 0)
    return d0, d1, d2, np.where(ok, t, _NO_HIT), ok


def _columns(table: list[list[float]], which: np.ndarray) -> list:
    """Per-ray parameters from a (n_solids, k) table: one scalar per column for a single
    solid (broadcast, no gathering), else one gathered array per column."""
    if len(table) == 1:
        return [float(v) for v in table[0]]
    arr = np.array(table)
    return [np.ascontiguousarray(arr[:, j])[which] for j in range(arr.shape[1])]


def _box_batch(solids: list[BoxSolid], which: np.ndarray, origin: FloatArray, d: FloatArray,
               normals: bool) -> tuple[FloatArray, FloatArray]:
    """:meth:`BoxSolid.intersect` for rays of several boxes (ray i: ``solids[which[i]]``);
    the same arithmetic per ray, so bit for bit the same results."""
    prm = _columns([
        [*(_local_axes(s.yaw_rad) @ (origin - np.array([s.north_m, s.east_m, s.base_depth_m]))),
         *_local_axes(s.yaw_rad)[:2, :2].ravel(), -s.length_m / 2, s.length_m / 2, -s.width_m / 2,
         s.width_m / 2, -s.height_m, s.footing_m]
        for s in solids
    ], which)
    o = (prm[0], prm[1], prm[2])
    a00, a01, a10, a11 = prm[3], prm[4], prm[5], prm[6]
    x, y, z = _components(d)
    cols = (x * a00 + y * a01, x * a10 + y * a11, z)
    entry = exit_ = np.zeros(0)
    entry_axis = np.zeros(d.shape[0], dtype=np.int8)
    with np.errstate(all="ignore"):
        for axis in range(3):
            comp = cols[axis]
            inv = 1.0 / np.where(comp == 0.0, 1e-300, comp)
            t1 = (prm[7 + 2 * axis] - o[axis]) * inv
            t2 = (prm[8 + 2 * axis] - o[axis]) * inv
            near = np.minimum(t1, t2)
            far = np.maximum(t1, t2)
            if axis == 0:
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
    normal = np.zeros_like(d)
    idx = np.nonzero(hit)[0]
    if idx.size:
        ax = entry_axis[idx]
        c0, c1, c2 = (c[idx] for c in cols)
        sgn = -np.sign(np.where(ax == 0, c0, np.where(ax == 1, c1, c2)))
        # rows of the box axes: (a00, a01, 0), (a10, a11, 0), (0, 0, 1)
        def pick(v: FloatArray | float) -> FloatArray | float:
            return v[idx] if isinstance(v, np.ndarray) else v
        rows = np.zeros((idx.size, 3))
        rows[:, 0] = np.where(ax == 0, pick(a00), np.where(ax == 1, pick(a10), 0.0))
        rows[:, 1] = np.where(ax == 0, pick(a01), np.where(ax == 1, pick(a11), 0.0))
        rows[:, 2] = ax == 2
        normal[idx] = sgn[:, None] * rows
    return t, normal


def _cylinder_batch(solids: list[CylinderSolid], which: np.ndarray, origin: FloatArray, d: FloatArray,
                    normals: bool) -> tuple[FloatArray, FloatArray]:
    """:meth:`CylinderSolid.intersect` for rays of several cylinders (same arithmetic)."""
    top, bottom, ox, oy, r2 = _columns([
        [s.base_depth_m - s.height_m, s.base_depth_m + s.footing_m, origin[0] - s.north_m, origin[1] - s.east_m,
         s.radius_m**2]
        for s in solids
    ], which)
    dx, dy, dz = _components(d)
    a = dx * dx + dy * dy
    b = 2.0 * (ox * dx + oy * dy)
    c = ox * ox + oy * oy - r2
    disc = b * b - 4.0 * a * c
    with np.errstate(all="ignore"):
        t_side = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
        z_side = origin[2] + t_side * dz
        side_ok = (a > 0) & (disc >= 0) & (t_side > 0) & (z_side >= top) & (z_side <= bottom)
        t_side = np.where(side_ok, t_side, _NO_HIT)
        t_cap = (top - origin[2]) / dz
        px, py = ox + t_cap * dx, oy + t_cap * dy
        cap_ok = (dz > 0) & (t_cap > 0) & (px * px + py * py <= r2)
    t_cap = np.where(cap_ok, t_cap, _NO_HIT)
    use_cap = t_cap < t_side
    t = np.minimum(t_cap, t_side)
    if not normals:
        return t, np.zeros((0, 3))
    tt = np.where(np.isfinite(t), t, 0.0)
    hx, hy = ox + tt * dx, oy + tt * dy
    rad = np.hypot(hx, hy)
    rad = np.where(rad > 0, rad, 1.0)
    normal = np.stack(np.broadcast_arrays(hx / rad, hy / rad, 0.0), axis=1)
    normal[use_cap] = (0.0, 0.0, -1.0)
    return t, normal


def _ellipsoid_batch(solids: list[EllipsoidSolid], which: np.ndarray, origin: FloatArray, d: FloatArray,
                     normals: bool) -> tuple[FloatArray, FloatArray]:
    """:meth:`EllipsoidSolid.intersect` for rays of several ellipsoids (same arithmetic)."""
    rows = []
    for s in solids:
        axes = _local_axes(s.yaw_rad)
        scale = np.array([2.0 / s.length_m, 2.0 / s.width_m, 1.0 / s.height_m])
        o = (axes @ (origin - np.array([s.north_m, s.east_m, s.base_depth_m]))) * scale
        rows.append([*o, float(o @ o) - 1.0, *axes[:2, :2].ravel(), *scale])
    o0, o1, o2, c, a00, a01, a10, a11, s0, s1, s2 = _columns(rows, which)
    x, y, z = _components(d)
    d0, d1, d2, t, ok = _scaled_sphere_hits(x, y, z, (a00, a01, a10, a11, s0, s1, s2), o0, o1, o2, c)
    if not normals:
        return t, np.zeros((0, 3))
    normal = np.zeros_like(d)
    idx = np.nonzero(ok)[0]
    if idx.size:
        def pick(v: FloatArray | float) -> FloatArray | float:
            return v[idx] if isinstance(v, np.ndarray) else v
        ti = t[idx]
        # p * scale in the solid's axes, then back to NED (rows of the axes as in einsum)
        p0 = (pick(o0) + ti * d0[idx]) * pick(s0)
        p1 = (pick(o1) + ti * d1[idx]) * pick(s1)
        p2 = (pick(o2) + ti * d2[idx]) * pick(s2)
        grad = np.stack([p0 * pick(a00) + p1 * pick(a10), p0 * pick(a01) + p1 * pick(a11), p2], axis=1)
        normal[idx] = grad / np.sqrt((grad[:, 0] * grad[:, 0] + grad[:, 2] * grad[:, 2])
                                     + grad[:, 1] * grad[:, 1])[:, None]
    return t, normal


def _composite_batch(solids: list[CompositeSolid], which: np.ndarray, origin: FloatArray, d: FloatArray,
                     normals: bool) -> tuple[FloatArray, FloatArray]:
    """:meth:`CompositeSolid.intersect` for rays of several rocks, rock by rock (its lobes
    cull the rays by bounding sphere, which beats pairing every ray with every lobe)."""
    t = np.full(d.shape[0], _NO_HIT)
    normal = np.zeros_like(d) if normals else np.zeros((0, 3))
    if len(solids) == 1:
        return solids[0].intersect(origin, d, normals=normals)
    for i, solid in enumerate(solids):
        idx = np.nonzero(which == i)[0]
        if idx.size:
            t_i, n_i = solid.intersect(origin, d[idx], normals=normals)
            t[idx] = t_i
            if normals:
                normal[idx] = n_i
    return t, normal


_Kernel = Callable[[Any, np.ndarray, FloatArray, FloatArray, bool], tuple[FloatArray, FloatArray]]
_BATCH_KERNELS: tuple[tuple[type, _Kernel], ...] = (
    (BoxSolid, _box_batch),
    (CylinderSolid, _cylinder_batch),
    (EllipsoidSolid, _ellipsoid_batch),
    (CompositeSolid, _composite_batch),
    (PipeSolid, pipe_batch),
)


def intersect_batch(
    solids: Sequence[Solid], which: np.ndarray, origin: FloatArray, directions: FloatArray, *,
    normals: bool = True,
) -> tuple[FloatArray, FloatArray]:
    """First hits of rays of many solids at once: ray ``i`` is tested against
    ``solids[which[i]]`` only. Same results as each solid's ``intersect`` on its own rays,
    with a fixed number of array operations per kind of solid instead of per solid.

    Parameters
    ----------
    solids : sequence of Solid
    which : ndarray of int, shape (n,)
        Index into ``solids`` of each ray.
    origin : ndarray, shape (3,)
        Common origin of the rays, NED m.
    directions : ndarray, shape (n, 3)
        Unit ray directions, NED.

    Returns
    -------
    (t, normal)
        ``t`` (n,) first entry distance (``inf`` for a miss), m; ``normal`` (n, 3) outward unit
        normal there ((0, 3) when ``normals`` is False).
    """
    if len(solids) == 1:
        return solids[0].intersect(origin, directions, normals=normals)
    which = np.asarray(which, dtype=np.int64)
    n = directions.shape[0]
    t = np.full(n, _NO_HIT)
    normal = np.zeros((n, 3)) if normals else np.zeros((0, 3))
    kinds = solid_kinds(solids)
    ray_kind = kinds[which] if n else np.zeros(0, dtype=np.int64)
    for k, (_, kernel) in enumerate(_BATCH_KERNELS):
        members = np.flatnonzero(kinds == k)
        if members.size == 0:
            continue
        local = np.full(len(solids), -1, dtype=np.int64)
        local[members] = np.arange(members.size)
        group = [solids[int(i)] for i in members]
        if members.size == len(solids):  # every ray is of this kind: no gathering
            return kernel(group, local[which], origin, directions, normals)
        idx = np.flatnonzero(ray_kind == k)
        if idx.size == 0:
            continue
        # rays grouped by kind (as callers lay them out when they can) are a slice: no copies
        sel: slice | np.ndarray = slice(int(idx[0]), int(idx[-1]) + 1) if idx[-1] - idx[0] + 1 == idx.size else idx
        t_k, n_k = kernel(group, local[which[sel]], origin, directions[sel], normals)
        t[sel] = t_k
        if normals:
            normal[sel] = n_k
    return t, normal


def solid_kinds(solids: Sequence[Solid]) -> np.ndarray:
    """Kind of each solid (the order :func:`intersect_batch` treats them in), shape (n,), int."""
    return np.array([next(k for k, (cls, _) in enumerate(_BATCH_KERNELS) if isinstance(s, cls)) for s in solids],
                    dtype=np.int64)
