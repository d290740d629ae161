"""Which rays of a target's block can meet it: boxes that hold each solid, and per beam
the elevation steps whose rays can reach those boxes.

Used by :func:`sim_harness.sonar.geometry.cast_targets`, which casts only those rays (the
others are misses, so a frame is the same as when every ray of the block is cast). A beam
plane cuts a box in a convex polygon (:func:`beam_step_bounds`); the boxes are grown by
HULL_MARGIN_M, far above rounding, and the steps get a margin of two either side.
Conventions of :mod:`sim_harness.sonar.geometry` (sonar frame x forward, y starboard, z
down; beam azimuth ``a``, elevation positive down).
"""

from __future__ import annotations

import math

import numpy as np

from sim_harness.world.pipe import PipeSolid
from sim_harness.world.shapes import BoxSolid, CompositeSolid, CylinderSolid, EllipsoidSolid

FloatArray = np.ndarray

#: Boxes of :func:`solid_hulls` are grown by this much on every side, m (far above rounding).
HULL_MARGIN_M = 1e-6


def _hull_box(north_m: float, east_m: float, depth_m: float, yaw_rad: float, half_u_m: float, half_v_m: float,
              z_top_m: float, z_bottom_m: float) -> FloatArray:
    """The 8 corners (8, 3), NED m, of a box yawed by ``yaw_rad`` about (north, east), from
    ``z_top_m`` to ``z_bottom_m`` relative to ``depth_m``, grown by HULL_MARGIN_M."""
    m = HULL_MARGIN_M
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    local = np.array([[u, v, z] for u in (-half_u_m - m, half_u_m + m) for v in (-half_v_m - m, half_v_m + m)
                      for z in (z_top_m - m, z_bottom_m + m)])
    axes = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return local @ axes + np.array([north_m, east_m, depth_m])


def solid_hulls(solid: object) -> FloatArray | None:
    """Corners (m, 8, 3) of boxes whose union holds every point of ``solid`` a ray can hit,
    NED m (a whole ellipsoid, also its buried half); None for a kind not known here."""
    if isinstance(solid, BoxSolid):
        s = solid
        return _hull_box(s.north_m, s.east_m, s.base_depth_m, s.yaw_rad, s.length_m / 2, s.width_m / 2,
                         -s.height_m, s.footing_m)[None]
    if isinstance(solid, CylinderSolid):
        c = solid
        return _hull_box(c.north_m, c.east_m, c.base_depth_m, 0.0, c.radius_m, c.radius_m,
                         -c.height_m, c.footing_m)[None]
    if isinstance(solid, EllipsoidSolid):
        e = solid
        return _hull_box(e.north_m, e.east_m, e.base_depth_m, e.yaw_rad, e.length_m / 2, e.width_m / 2,
                         -e.height_m, e.height_m)[None]
    if isinstance(solid, CompositeSolid):
        lobes = [solid_hulls(lobe) for lobe in solid.lobes]
        return None if any(h is None for h in lobes) else np.concatenate(lobes)  # type: ignore[arg-type]
    if isinstance(solid, PipeSolid):
        p = solid
        return _hull_box(p.north_m, p.east_m, p.base_depth_m, p.yaw_rad, p.length_m / 2, p.radius_m,
                         -2.0 * p.radius_m, 0.0)[None]
    return None


#: The 28 pairs of a box's 8 corners: the plane section of the box is the convex hull of
#: where the plane crosses them.
_PAIR_A, _PAIR_B = np.triu_indices(8, 1)


def beam_step_bounds(hulls_sonar: FloatArray, azimuth_rad: FloatArray, group_start: np.ndarray,
                     step_rad: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Elevation steps [lo, hi) whose rays of a beam can meet a solid held by boxes.

    Column ``c`` pairs a box of sonar-frame corners ``hulls_sonar[:, :, c]`` (8, 3, n) with
    the beam of azimuth ``azimuth_rad[c]``; consecutive columns from ``group_start[g]`` to
    the next start are one (solid, beam) pair, whose bounds are returned: (lo, hi, all),
    ``all`` True where the box section reaches behind the sonar (every step can meet it).

    A beam plane cuts a box in a convex polygon whose vertices lie where the plane crosses
    the box's edges; the elevation ``atan2(z, x cos a + y sin a)`` of the points of that
    polygon is a linear-fractional function, extreme at vertices. So every ray of the beam
    that meets the box lies between the crossings' elevations (of all 28 corner pairs, a
    superset of the edges; corners within HULL_MARGIN_M of the plane count as crossings),
    with two steps of margin either side. A pair whose plane misses every box gets
    ``lo == hi``.
    """
    ca, sa = np.cos(azimuth_rad), np.sin(azimuth_rad)
    x, y, z = hulls_sonar[:, 0], hulls_sonar[:, 1], hulls_sonar[:, 2]  # (8, n)
    side = y * ca - x * sa  # signed distance of each corner from the beam plane
    ahead = x * ca + y * sa
    sa_, sb_ = side[_PAIR_A], side[_PAIR_B]
    cross = sa_ * sb_ < 0
    f = sa_ / np.where(cross, sa_ - sb_, 1.0)
    pa, za = ahead[_PAIR_A], z[_PAIR_A]
    den = np.concatenate([pa + f * (ahead[_PAIR_B] - pa), ahead])  # (36, n) candidate points
    num = np.concatenate([za + f * (z[_PAIR_B] - za), z])
    use = np.concatenate([cross, np.abs(side) <= HULL_MARGIN_M])
    elev = np.arctan2(num, den)
    behind = np.logical_or.reduceat(np.any(use & (den <= 1e-9), axis=0), group_start)
    some = np.logical_or.reduceat(np.any(use, axis=0), group_start) & ~behind
    e_min = np.minimum.reduceat(np.min(np.where(use, elev, np.inf), axis=0), group_start)
    e_max = np.maximum.reduceat(np.max(np.where(use, elev, -np.inf), axis=0), group_start)
    lo = np.floor(np.where(some, e_min, 0.0) / step_rad).astype(np.int64) - 2
    hi = np.ceil(np.where(some, e_max, 0.0) / step_rad).astype(np.int64) + 3
    return np.where(some, lo, 0), np.where(some, hi, 0), behind
