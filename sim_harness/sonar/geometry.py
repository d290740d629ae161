"""Geometry core of the sonar renderer: per-pose geometry and ray casting at targets.

Conventions of :mod:`perception.geometry`: a ray of beam azimuth ``a`` and elevation ``e``
(positive down) points along ``(cos e cos a, cos e sin a, sin e)`` in the sonar frame and
``R @ that`` in NED, ``R = sonar_to_ned(tilt, pitch, roll, heading)``.

The seabed plane (no relief) is ``z = depth_m + g_n n + g_e e``; with ``c = (-g_n, -g_e, 1)``
a ray ``d`` from the sonar meets it at ``t = H_v / (c . d)``, ``H_v`` the vertical height of
the sonar above the plane; within one beam plane ``c . d = rho cos(e - phi)``
(:class:`PoseGeometry`). The analytic seabed echo is in :mod:`sim_harness.sonar.seabed`.

Targets are ray cast on a global elevation grid ``e_k = k * step`` per beam axis; the
nearest hit (target or seabed) wins. Of each target's block of rays only those whose beam
plane section of the target's boxes (:mod:`sim_harness.sonar.hulls`) they can reach are
cast; the others are misses whichever way, so this saves work without changing a frame.
Near a target the seabed is the tangent plane of the relief at its centre
(:class:`LocalSeabed`). The elevation intervals a target occludes are
refined to 1/REFINE_SPLIT of the step (~4e-5 rad at the default 0.08 deg: ~0.3 mm of
seabed range at 2 m) in :mod:`sim_harness.sonar.target_rays`; the seabed inside them is
removed (the shadow), and the target's hits add echo at their own ranges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from perception.geometry import sonar_to_ned
from sim_harness.sonar.hulls import beam_step_bounds, solid_hulls
from sim_harness.world.shapes import intersect_batch, solid_kinds
from sim_harness.world.world import PlacedTarget, World

FloatArray = np.ndarray

#: An occlusion edge's bracket (one ray step) is split into this many parts to refine it.
REFINE_SPLIT = 32
#: Most elevation rays cast per beam at one target.
MAX_RAYS_PER_BEAM = 600


def dot3(a: FloatArray, b: FloatArray) -> FloatArray:
    """``sum(a * b, axis=-1)`` over a last axis of length 3 (broadcast), without einsum.

    Summed as ``(a0 b0 + a2 b2) + a1 b1``, the order of numpy's 3-term einsum, so the
    results are bit for bit those of ``np.einsum("...j,...j->...", a, b)``.
    """
    return (a[..., 0] * b[..., 0] + a[..., 2] * b[..., 2]) + a[..., 1] * b[..., 1]


@dataclass(frozen=True, eq=False)
class PoseGeometry:
    """Per-pose constants of the seabed and ray geometry (arrays over beams)."""

    origin_ned: FloatArray  # (3,)
    rot: FloatArray  # (3, 3) sonar -> NED
    height_v_m: float  # vertical height above the plane
    c_vec: FloatArray  # (3,) (-g_n, -g_e, 1)
    c_norm: float
    horiz: FloatArray  # (n_b, 3) NED direction of each beam's e = 0 ray
    rho: FloatArray  # (n_b,)
    phi: FloatArray  # (n_b,)

    def directions(self, beams: np.ndarray, elevation_rad: FloatArray) -> FloatArray:
        """NED unit rays for beam indices and elevations (broadcast), shape (..., 3)."""
        ce = np.cos(elevation_rad)[..., None]
        se = np.sin(elevation_rad)[..., None]
        return ce * self.horiz[beams] + se * self.rot[:, 2]


def pose_geometry(
    world: World,
    *,
    north_m: float,
    east_m: float,
    depth_m: float,
    heading_rad: float,
    pitch_rad: float,
    roll_rad: float,
    tilt_rad: float,
    beam_azimuth_rad: FloatArray,
) -> PoseGeometry:
    """Build :class:`PoseGeometry` (the caller has validated the pose)."""
    rot = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad, heading_rad=heading_rad)
    gn, ge = world.seabed.gradient
    c = np.array([-gn, -ge, 1.0])
    height = world.seabed.plane_depth_m(north_m, east_m) - depth_m
    horiz = np.cos(beam_azimuth_rad)[:, None] * rot[:, 0] + np.sin(beam_azimuth_rad)[:, None] * rot[:, 1]
    alpha = horiz @ c
    beta = float(rot[:, 2] @ c)
    return PoseGeometry(
        origin_ned=np.array([north_m, east_m, depth_m], dtype=np.float64),
        rot=rot,
        height_v_m=float(height),
        c_vec=c,
        c_norm=float(np.linalg.norm(c)),
        horiz=horiz,
        rho=np.hypot(alpha, beta),
        phi=np.arctan2(beta, alpha),
    )


@dataclass(frozen=True)
class LocalSeabed:
    """The seabed near one target as a plane: the world's plane plus the relief's tangent
    plane at the target's centre (relief is gentle: its curvature over a target's size is
    well under a millimetre). A ray ``d`` meets it at ``t = height_m / (c . d)``."""

    c_vec: FloatArray  # (3,)
    height_m: float  # vertical height of the sonar above this plane

    def slant_m(self, directions: FloatArray) -> FloatArray:
        """Slant range where NED unit rays (..., 3) meet the plane; ``inf`` if never, m."""
        k = dot3(directions, self.c_vec)
        with np.errstate(divide="ignore"):
            return np.where(k > 0, self.height_m / np.where(k > 0, k, 1.0), np.inf)


def local_seabed(world: World, geo: PoseGeometry, placed: PlacedTarget) -> LocalSeabed:
    """:class:`LocalSeabed` around ``placed`` for the sonar of ``geo``."""
    return _local_plane(world, placed).for_sonar(geo.origin_ned)


@dataclass(frozen=True)
class _LocalPlane:
    """The seabed's tangent plane at a target's centre: depth ``depth0_m`` there, gradient
    (``gn``, ``ge``) (d depth / d north, d depth / d east)."""

    north_m: float
    east_m: float
    depth0_m: float
    gn: float
    ge: float

    def for_sonar(self, sonar_ned: FloatArray) -> LocalSeabed:
        plane_at_sonar = (self.depth0_m + self.gn * (sonar_ned[0] - self.north_m)
                          + self.ge * (sonar_ned[1] - self.east_m))
        return LocalSeabed(np.array([-self.gn, -self.ge, 1.0]), float(plane_at_sonar - sonar_ned[2]))


def _local_plane(world: World, placed: PlacedTarget) -> _LocalPlane:
    n0, e0 = placed.spec.north_m, placed.spec.east_m
    gn, ge = world.seabed.gradient
    relief = world.seabed.relief
    if relief is None:
        return _LocalPlane(0.0, 0.0, world.seabed.depth_m, gn, ge)
    rn, re = relief.gradient(n0, e0)
    return _LocalPlane(n0, e0, world.seabed_depth_m(n0, e0), gn - float(rn), ge - float(re))


def seabed_slant_m(world: World, geo: PoseGeometry, directions: FloatArray, *, iterations: int = 3) -> FloatArray:
    """Slant range where NED unit rays (..., 3) meet the seabed with its relief, m.

    Fixed-point iteration on the plane hit, ``t <- t_plane - h(S + t d) / (c . d)``; relief
    is gentle (slope <= 0.25), so a few iterations converge to well under a millimetre.
    ``inf`` for rays that never reach the plane.
    """
    k = dot3(directions, geo.c_vec)
    with np.errstate(divide="ignore"):
        t_plane = np.where(k > 0, geo.height_v_m / np.where(k > 0, k, 1.0), np.inf)
    relief = world.seabed.relief
    if relief is None:
        return t_plane
    finite = np.isfinite(t_plane)
    kk = np.where(k > 0, k, 1.0)
    t = np.where(finite, t_plane, 0.0)
    for _ in range(iterations):
        p = geo.origin_ned + t[..., None] * directions
        t = np.where(finite, t_plane - relief.height_m(p[..., 0], p[..., 1]) / kk, 0.0)
    return np.where(finite, t, np.inf)
@dataclass(frozen=True, eq=False)
class TargetCast:
    """Rays cast at one target on the block (beams j0..j1-1) x (elevations k0..k1-1)."""

    placed: PlacedTarget
    seabed: LocalSeabed
    j0: int
    k0: int
    elevation_rad: FloatArray  # (n_k,)
    t: FloatArray  # (n_j, n_k) target hit distance, inf if miss
    # (n_j, n_k) cosine between each ray and the hit's normal, and the local seabed's slant
    # range: meaningful where the ray hits (rays that cannot meet the target are not cast:
    # 0 and inf there)
    cos_incidence: FloatArray
    t_seabed: FloatArray
    occluding: np.ndarray  # (n_j, n_k) target hit before the seabed

    @property
    def beams(self) -> np.ndarray:
        """Beam indices of the block's rows."""
        return np.arange(self.j0, self.j0 + self.t.shape[0])


@dataclass(frozen=True, eq=False)
class TargetTable:
    """Pose-independent data of a world's targets, built once per renderer.

    ``corners`` (n, 3) all targets' bounding corners end to end, NED m, ``corner_start``
    (n_targets + 1,) where each target's begin; ``planes`` the seabed's tangent plane at
    each target's centre; ``hulls`` per target the (m, 8, 3) corners of boxes that hold the
    whole solid (every point a ray can hit), NED m, or None when unknown
    (:func:`sim_harness.sonar.hulls.solid_hulls`).
    """

    corners: FloatArray
    corner_start: np.ndarray
    planes: tuple[_LocalPlane, ...]
    hulls: tuple[FloatArray | None, ...]


def target_table(world: World) -> TargetTable:
    """:class:`TargetTable` of ``world``."""
    counts = [p.corners_ned.shape[0] for p in world.placed]
    corners = np.concatenate([p.corners_ned for p in world.placed]) if counts else np.zeros((0, 3))
    return TargetTable(corners, np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
                       tuple(_local_plane(world, p) for p in world.placed),
                       tuple(solid_hulls(p.solid) for p in world.placed))


def _beam_spans(
    table: TargetTable, q_all: FloatArray, beam_azimuth_rad: FloatArray, max_range_m: float
) -> list[tuple[int, int, int]]:
    """(target index, j0, j1) of every target some beam axis [j0, j1) can meet, from the
    sonar-frame corners ``q_all`` (n, 3) of all targets (in one pass over them all)."""
    starts = table.corner_start[:-1]
    if starts.size == 0:
        return []
    x = q_all[:, 0]
    max_x = np.maximum.reduceat(x, starts)
    min_x = np.minimum.reduceat(x, starts)
    near = np.minimum.reduceat(np.linalg.norm(q_all, axis=1), starts)
    az = np.arctan2(q_all[:, 1], x)
    lo = np.searchsorted(beam_azimuth_rad, np.minimum.reduceat(az, starts), side="left")
    hi = np.searchsorted(beam_azimuth_rad, np.maximum.reduceat(az, starts), side="right")
    # a target straddling the sonar's y-z plane may meet any beam
    lo = np.where(min_x > 0, lo, 0)
    hi = np.where(min_x > 0, hi, beam_azimuth_rad.size)
    ok = (max_x > 0) & (near <= max_range_m) & (hi > lo)
    return [(int(i), int(lo[i]), int(hi[i])) for i in np.nonzero(ok)[0]]


def _elevation_steps(q: FloatArray, a: FloatArray, step_rad: float, half_aperture_rad: float) -> tuple[int, int] | None:
    """Elevation steps [k0, k1) whose rays in the beams of azimuths ``a`` can meet a target
    with sonar-frame corners ``q`` (n, 3); None if none can."""
    denom = q[:, 0:1] * np.cos(a) + q[:, 1:2] * np.sin(a)  # (n_corners, n_j)
    if np.all(denom > 0):
        elev = np.arctan2(q[:, 2:3], denom)
        e_min, e_max = float(elev.min()), float(elev.max())
    else:
        e_min, e_max = -math.pi / 2 + 1e-6, math.pi / 2 - 1e-6
    k0 = math.floor(e_min / step_rad) - 2
    k1 = math.ceil(e_max / step_rad) + 3
    if k1 - k0 > MAX_RAYS_PER_BEAM:
        margin = math.radians(10.0)
        k0 = max(k0, math.floor((-half_aperture_rad - margin) / step_rad))
        k1 = min(k1, math.ceil((half_aperture_rad + margin) / step_rad))
        k1 = min(k1, k0 + MAX_RAYS_PER_BEAM)
        if k1 <= k0:
            return None
    return k0, k1


def cast_targets(
    world: World,
    geo: PoseGeometry,
    table: TargetTable,
    *,
    beam_azimuth_rad: FloatArray,
    step_rad: float,
    half_aperture_rad: float,
    max_range_m: float,
) -> list[TargetCast]:
    """Cast the beam-axis rays that can meet each target, all targets in one batch; a
    :class:`TargetCast` per target that occludes the seabed somewhere, in the world's order.

    Per target, the rays span its elevation extent in each beam plane (from its bounding
    corners), so occlusion runs and shadow truth are complete even outside the aperture;
    only for a target so close that this exceeds MAX_RAYS_PER_BEAM steps is the span cut
    to the aperture +-10 deg (its truth may then be partial). Within the block a beam's rays
    outside :func:`~sim_harness.sonar.hulls.beam_step_bounds` are not cast (misses: ``t``
    inf, not occluding)."""
    q_all = (table.corners - geo.origin_ned) @ geo.rot  # sonar frame
    blocks = []
    for i, j0, j1 in _beam_spans(table, q_all, beam_azimuth_rad, max_range_m):
        ks = _elevation_steps(q_all[table.corner_start[i]:table.corner_start[i + 1]], beam_azimuth_rad[j0:j1],
                              step_rad, half_aperture_rad)
        if ks is not None:
            blocks.append((i, j0, j1, *ks))
    if not blocks:
        return []
    # blocks of one kind of solid next to each other: intersect_batch then slices, not copies
    kind = solid_kinds([world.placed[b[0]].solid for b in blocks])
    blocks = [blocks[i] for i in np.argsort(kind, kind="stable")]
    # every block's rays end to end: (target block, beam, elevation step); only the rays
    # each beam can meet the target with (beam_step_bounds) are cast, the rest are misses
    n_j = np.array([j1 - j0 for _, j0, j1, _, _ in blocks])
    n_k = np.array([k1 - k0 for _, _, _, k0, k1 in blocks])
    size = n_j * n_k
    start = np.cumsum(size) - size
    cos_e, sin_e, columns, col_beam, n_boxes = [], [], [], [], []
    for i, j0, j1, k0, k1 in blocks:  # geo.directions on each block's grid, by rows
        elevation = np.arange(k0, k1) * step_rad
        cos_e.append(np.cos(elevation))
        sin_e.append(np.sin(elevation))
        hull = table.hulls[i]
        m = 0 if hull is None else hull.shape[0]
        n_boxes.append(np.full(j1 - j0, m))
        if m:  # the columns of beam_step_bounds: every box for every beam
            columns.append(np.tile((hull - geo.origin_ned) @ geo.rot, (j1 - j0, 1, 1)))
            col_beam.append(np.repeat(np.arange(j0, j1), m))
    row_block = np.repeat(np.arange(len(blocks)), n_j)
    k_lo = np.array([b[3] for b in blocks])[row_block]
    k_hi = np.array([b[4] for b in blocks])[row_block]
    lo_all, hi_all = k_lo.copy(), k_hi.copy()
    boxes = np.concatenate(n_boxes)
    if columns:
        bounded = boxes > 0
        m_rows = boxes[bounded]
        lo_b, hi_b, behind = beam_step_bounds(np.concatenate(columns).transpose(1, 2, 0),
                                              beam_azimuth_rad[np.concatenate(col_beam)],
                                              np.cumsum(m_rows) - m_rows, step_rad)
        k0_b, k1_b = k_lo[bounded], k_hi[bounded]
        lo_all[bounded] = np.where(behind, k0_b, np.clip(lo_b, k0_b, k1_b))
        hi_all[bounded] = np.where(behind, k1_b, np.clip(hi_b, k0_b, k1_b))
    n_all = np.maximum(hi_all - lo_all, 0)
    lo_all -= k_lo
    row_in_block = np.arange(row_block.size) - np.repeat(np.cumsum(n_j) - n_j, n_j)
    e_start = np.cumsum(n_k) - n_k  # each block's elevations in the concatenated cos_e, sin_e
    cast_start = np.cumsum(n_all) - n_all
    within = np.arange(int(n_all.sum())) - np.repeat(cast_start, n_all)
    col = np.repeat(lo_all, n_all) + within  # column of each cast ray in its block
    ray_row = np.repeat(np.arange(row_block.size), n_all)
    which = row_block[ray_row]
    flat = start[which] + row_in_block[ray_row] * n_k[which] + col  # its place in the full grid
    e_idx = e_start[which] + col
    beams = np.array([j0 for _, j0, _, _, _ in blocks])[which] + row_in_block[ray_row]
    d = np.concatenate(cos_e)[e_idx][:, None] * geo.horiz[beams]
    d += np.concatenate(sin_e)[e_idx][:, None] * geo.rot[:, 2]
    placed = [world.placed[b[0]] for b in blocks]
    t_cast, normal = intersect_batch([p.solid for p in placed], which, geo.origin_ned, d)
    seabeds = [table.planes[b[0]].for_sonar(geo.origin_ned) for b in blocks]
    c_vec = np.array([sb.c_vec for sb in seabeds])[which]
    height = np.array([sb.height_m for sb in seabeds])[which]
    kc = dot3(d, c_vec)
    total = int(size.sum())
    t = np.full(total, np.inf)
    t[flat] = t_cast
    cos_inc = np.zeros(total)
    cos_inc[flat] = -dot3(normal, d)
    t_sb = np.full(total, np.inf)
    with np.errstate(divide="ignore"):
        t_sb[flat] = np.where(kc > 0, height / np.where(kc > 0, kc, 1.0), np.inf)
    occluding = np.zeros(total, dtype=bool)
    occluding[flat] = t_cast < t_sb[flat]
    casts = []
    for b, (_, j0, j1, k0, k1) in enumerate(blocks):
        sl = slice(int(start[b]), int(start[b] + size[b]))
        if not np.any(occluding[sl]):
            continue
        shape = (j1 - j0, k1 - k0)
        casts.append(TargetCast(placed[b], seabeds[b], j0, k0, np.arange(k0, k1) * step_rad, t[sl].reshape(shape),
                                cos_inc[sl].reshape(shape), t_sb[sl].reshape(shape), occluding[sl].reshape(shape)))
    return casts
