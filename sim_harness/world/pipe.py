"""A pipe section lying on the seabed: a horizontal circular cylinder with flat ends.

The pipe's axis runs along its yaw (the length axis of :func:`local_axes`), ``radius_m``
above the seabed at its centre, so it touches the seabed along its length; the ends are
discs. A ray meets the side where ``v^2 + (z - z_c)^2 = r^2`` in the pipe's axes
(``u`` along the axis, ``v`` across, ``z`` down, ``z_c`` the axis depth) with
``|u| <= length / 2``, or an end disc at ``u = +-length / 2``; the nearer hit wins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
_NO_HIT = np.inf


def local_axes(yaw_rad: float) -> FloatArray:
    """Rows: the length axis, the width axis and down, in NED."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class PipeSolid:
    """A pipe of ``radius_m`` and ``length_m`` lying with its axis along ``yaw_rad``, its
    bottom on the seabed at ``base_depth_m`` (NED m)."""

    north_m: float
    east_m: float
    base_depth_m: float
    length_m: float
    radius_m: float
    yaw_rad: float

    def corners_ned(self) -> FloatArray:
        """Corners of the bounding box, shape (8, 3), NED m."""
        hl, r = self.length_m / 2, self.radius_m
        local = np.array([[u, v, z] for u in (-hl, hl) for v in (-r, r) for z in (-2 * r, 0.01)], dtype=np.float64)
        return local @ local_axes(self.yaw_rad) + np.array([self.north_m, self.east_m, self.base_depth_m])

    def intersect(
        self, origin: FloatArray, directions: FloatArray, *, normals: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """First hits of rays from ``origin`` (3,) along unit ``directions`` (n, 3):
        ``(t, normal)`` as :func:`sim_harness.world.shapes.intersect_batch` returns them."""
        return pipe_batch([self], np.zeros(directions.shape[0], dtype=np.intp), origin, directions, normals)


def pipe_batch(solids: list[PipeSolid], which: np.ndarray, origin: FloatArray, d: FloatArray,
               normals: bool) -> tuple[FloatArray, FloatArray]:
    """Rays ``d`` (n, 3) from ``origin`` (3,), ray ``i`` against ``solids[which[i]]``."""
    rot = np.stack([local_axes(s.yaw_rad) for s in solids])  # (k, 3, 3)
    centre = np.array([[s.north_m, s.east_m, s.base_depth_m - s.radius_m] for s in solids])
    half = np.array([s.length_m / 2 for s in solids])[which]
    r = np.array([s.radius_m for s in solids])[which]
    o = np.einsum("kij,kj->ki", rot, origin[None, :] - centre)[which]  # origin in each pipe's axes
    dl = np.einsum("nij,nj->ni", rot[which], d)
    ou, ov, oz = o[:, 0], o[:, 1], o[:, 2]
    du, dv, dz = dl[:, 0], dl[:, 1], dl[:, 2]
    a = dv * dv + dz * dz
    b = 2.0 * (ov * dv + oz * dz)
    c = ov * ov + oz * oz - r * r
    disc = b * b - 4.0 * a * c
    with np.errstate(all="ignore"):
        t_side = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
        side_ok = (a > 0) & (disc >= 0) & (t_side > 0) & (np.abs(ou + t_side * du) <= half)
        t_side = np.where(side_ok, t_side, _NO_HIT)
        # the end the ray faces: u = -half when moving toward +u, else +half
        end_u = np.where(du > 0, -half, half)
        t_end = (end_u - ou) / du
        pv, pz = ov + t_end * dv, oz + t_end * dz
        end_ok = (du != 0) & (t_end > 0) & (pv * pv + pz * pz <= r * r)
    t_end = np.where(end_ok, t_end, _NO_HIT)
    use_end = t_end < t_side
    t = np.minimum(t_side, t_end)
    if not normals:
        return t, np.zeros((0, 3))
    tt = np.where(np.isfinite(t), t, 0.0)
    hv, hz = ov + tt * dv, oz + tt * dz
    rad = np.hypot(hv, hz)
    rad = np.where(rad > 0, rad, 1.0)
    local_n = np.stack([np.zeros_like(hv), hv / rad, hz / rad], axis=1)
    local_n[use_end] = 0.0
    local_n[use_end, 0] = np.where(du[use_end] > 0, -1.0, 1.0)
    normal = np.einsum("nji,nj->ni", rot[which], local_n)  # back to NED: R^T n
    normal[~np.isfinite(t)] = 0.0
    return t, normal
