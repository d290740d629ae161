"""Geometry core of the sonar renderer: the analytic seabed and ray casting at targets.

Conventions of :mod:`perception.geometry`: a ray of beam azimuth ``a`` and elevation ``e``
(positive down) points along ``(cos e cos a, cos e sin a, sin e)`` in the sonar frame and
``R @ that`` in NED, ``R = sonar_to_ned(tilt, pitch, roll, heading)``.

The seabed plane (no relief) is ``z = depth_m + g_n n + g_e e``. With ``c = (-g_n, -g_e, 1)``
a ray ``d`` from the sonar ``S`` meets it at ``t = H_v / (c . d)``, ``H_v`` the vertical height
of the sonar above the plane. Within the plane of one beam (all elevations at azimuth
``a``), ``c . d = rho cos(e - phi)``, so the seabed at slant range ``r`` lies at the two
elevations ``e = phi +/- arccos(H_v / (rho r))`` ("branches"). Each range cell's seabed is
therefore an exact elevation interval per branch: no rays, no holes. Relief shifts each
range by ``h / (c . d)`` (a two-step fixed point, on a coarse range grid, interpolated).

Targets are ray cast on a global elevation grid ``e_k = k * step`` per beam axis; the
nearest hit (target or seabed) wins. Near a target the seabed is the tangent plane of the
relief at its centre (:class:`LocalSeabed`). The elevation intervals a target occludes are
refined to 1/REFINE_SPLIT of the step (~4e-5 rad at the default 0.08 deg: ~0.3 mm of
seabed range at 2 m) in :mod:`sim_harness.sonar_targets`; the seabed inside them is
removed (the shadow), and the target's hits add echo at their own ranges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from perception.geometry import sonar_to_ned
from sim_harness.world import PlacedTarget, World

FloatArray = np.ndarray

#: An occlusion edge's bracket (one ray step) is split into this many parts to refine it.
REFINE_SPLIT = 32
#: Most elevation rays cast per beam at one target.
MAX_RAYS_PER_BEAM = 600
#: Coarse range step (in cells) on which relief corrections are evaluated.
RELIEF_STRIDE = 32


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
    relief = world.seabed.relief
    if relief is None:
        return LocalSeabed(geo.c_vec, geo.height_v_m)
    n0, e0 = placed.spec.north_m, placed.spec.east_m
    gn, ge = world.seabed.gradient
    rn, re = relief.gradient(n0, e0)
    gn_l, ge_l = gn - float(rn), ge - float(re)
    depth0 = world.seabed_depth_m(n0, e0)
    sonar = geo.origin_ned
    plane_at_sonar = depth0 + gn_l * (sonar[0] - n0) + ge_l * (sonar[1] - e0)
    return LocalSeabed(np.array([-gn_l, -ge_l, 1.0]), float(plane_at_sonar - sonar[2]))


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
class SeabedBranch:
    """One branch of the analytic seabed on range cells ``row0 .. row0 + n - 1`` x all beams.

    ``lo``/``hi``: elevation interval of each range cell's seabed clipped to the aperture
    (``hi <= lo`` when empty), rad; ``span``: ``max(hi - lo, 0)``; ``power``: unoccluded echo
    (beam pattern x scattering x footprint / r^2; no gain, no absorption), linear. Arrays
    have shape (n, n_beams), float32; cells outside the rows hold no seabed of this branch.
    """

    sign: int
    row0: int
    lo: np.ndarray
    hi: np.ndarray
    span: np.ndarray
    power: np.ndarray

    @property
    def rows(self) -> slice:
        """The slice of full-image rows the arrays cover."""
        return slice(self.row0, self.row0 + self.span.shape[0])


def _interp_rows(coarse: FloatArray, stride: int, n_rows: int) -> FloatArray:
    """Linear interpolation onto rows 0..n_rows-1 of values given every ``stride`` rows."""
    x = np.arange(n_rows)
    i = x // stride
    f = ((x % stride) / stride).astype(coarse.dtype)[:, None]
    j = np.minimum(i + 1, coarse.shape[0] - 1)
    return np.asarray(coarse[i] + (coarse[j] - coarse[i]) * f)


def _branch_rows(
    geo: PoseGeometry, sign: int, half_aperture_rad: float, range_edges_m: FloatArray, pad: int
) -> tuple[int, int] | None:
    """Cell rows [i0, i1) where this branch can lie inside the aperture, or None."""
    u_lo = -half_aperture_rad - geo.phi  # e - phi over the aperture
    u_hi = half_aperture_rad - geo.phi
    if sign > 0:
        a, b = np.maximum(u_lo, 0.0), np.minimum(u_hi, math.pi / 2)
    else:
        a, b = np.maximum(-u_hi, 0.0), np.minimum(-u_lo, math.pi / 2)
    ok = b > a
    if not np.any(ok):
        return None
    with np.errstate(divide="ignore"):
        r_min = geo.height_v_m / (geo.rho[ok] * np.cos(a[ok]))
        r_max = geo.height_v_m / (geo.rho[ok] * np.maximum(np.cos(b[ok]), 0.0))
    dr = float(range_edges_m[1] - range_edges_m[0])
    n = range_edges_m.size - 1
    i0 = int(np.clip(math.floor((float(r_min.min()) - range_edges_m[0]) / dr) - 1 - pad, 0, n))
    far = float(r_max.max())
    i1 = n if not math.isfinite(far) else int(np.clip(math.ceil((far - range_edges_m[0]) / dr) + 1 + pad, 0, n))
    return (i0, i1) if i1 > i0 else None


def seabed_branches(
    world: World,
    geo: PoseGeometry,
    *,
    range_edges_m: FloatArray,
    range_centres_m: FloatArray,
    half_aperture_rad: float,
    pattern_coeff: float,
    footprint: np.ndarray,
) -> list[SeabedBranch]:
    """The seabed's echo per range cell and beam, per branch that reaches the aperture.

    ``pattern_coeff``: the elevation beam pattern is ``exp(pattern_coeff * (e / A)^2)`` inside
    the half aperture ``A`` and zero outside; ``footprint`` (n_samples, n_beams) is the beam
    width over r^2 of each cell times any per-row gain. Heavy arithmetic runs in float32.
    """
    material = world.material(world.seabed.material)
    relief = world.seabed.relief
    dr = float(range_edges_m[1] - range_edges_m[0])
    pad = math.ceil(6.0 * relief.amplitude_m / dr) if relief is not None else 0
    f32 = np.float32
    branches = []
    for sign in (-1, 1):
        span_rows = _branch_rows(geo, sign, half_aperture_rad, range_edges_m, pad)
        if span_rows is None:
            continue
        i0, i1 = span_rows
        edges = range_edges_m[i0:i1 + 1]
        n_e = edges.size
        scale = (geo.height_v_m / geo.rho).astype(f32)
        if relief is None:
            ratio = scale[None, :] * (1.0 / edges).astype(f32)[:, None]
            extra_cos = None
        else:
            beams = np.arange(geo.rho.size)
            n_c = max(2, (n_e - 1 + RELIEF_STRIDE - 1) // RELIEF_STRIDE + 1)
            r_c = edges[0] + np.arange(n_c) * (RELIEF_STRIDE * dr)
            corr = np.zeros((n_c, geo.rho.size))
            for _ in range(2):  # fixed point: the ray whose relief hit lies at range r_c
                x0 = np.minimum(geo.height_v_m / (geo.rho[None, :] * (r_c[:, None] + corr)), 1.0)
                e_c = geo.phi + sign * np.arccos(x0)
                d = geo.directions(beams[None, :], e_c)
                p = geo.origin_ned + r_c[:, None, None] * d
                k = dot3(d, geo.c_vec)
                h = relief.height_m(p[..., 0], p[..., 1])
                corr = np.where(k > 1e-6, h / np.maximum(k, 1e-6), 0.0)
            gn_r, ge_r = relief.gradient(p[..., 0], p[..., 1])
            shift = _interp_rows(corr.astype(f32), RELIEF_STRIDE, n_e)
            ratio = scale[None, :] / (edges.astype(f32)[:, None] + shift)
            extra_cos = _interp_rows((gn_r * d[..., 0] + ge_r * d[..., 1]).astype(f32), RELIEF_STRIDE, n_e)
        ratio = np.minimum(ratio, f32(1.0))
        acos = np.arccos(ratio)
        phi = geo.phi.astype(f32)
        edges_e = phi + acos if sign > 0 else phi - acos
        ha = f32(half_aperture_rad)
        np.maximum(edges_e, -ha, out=edges_e)
        np.minimum(edges_e, ha, out=edges_e)
        # along a branch the elevation moves away from phi as the range grows
        near_e, far_e = edges_e[:-1], edges_e[1:]
        lo, hi = (near_e, far_e) if sign > 0 else (far_e, near_e)
        span = hi - lo
        np.maximum(span, f32(0.0), out=span)
        mid = lo + hi
        mid *= f32(0.5)
        m2 = mid * mid
        # cos(e - phi) is the ratio at the cell edges: average them (exact to O(dr^2))
        cos_inc = ratio[:-1] + ratio[1:]
        cos_inc *= (0.5 * geo.rho / geo.c_norm).astype(f32)
        if extra_cos is not None:
            cos_inc += f32(0.5 / geo.c_norm) * (extra_cos[:-1] + extra_cos[1:])
            np.clip(cos_inc, f32(0.0), f32(1.0), out=cos_inc)
        if half_aperture_rad <= 0.3:
            # beam pattern x cos(mid): cos(x) = exp(-x^2 / 2) to 2e-5 for |x| <= 0.15 rad
            power = np.exp(f32(pattern_coeff / half_aperture_rad**2 - 0.5) * m2)
        else:
            power = np.exp(f32(pattern_coeff / half_aperture_rad**2) * m2)
            power *= np.cos(mid)
        if material.roughness == 1.0:
            power *= cos_inc
            power *= f32(10.0 ** (material.backscatter_db / 10.0))
        else:
            power *= material.sigma_over_cos(cos_inc)
        power *= span
        power *= footprint[i0:i1]
        branches.append(SeabedBranch(sign, i0, lo, hi, span, power))
    return branches


@dataclass(frozen=True, eq=False)
class TargetCast:
    """Rays cast at one target on the block (beams j0..j1-1) x (elevations k0..k1-1)."""

    placed: PlacedTarget
    seabed: LocalSeabed
    j0: int
    k0: int
    elevation_rad: FloatArray  # (n_k,)
    t: FloatArray  # (n_j, n_k) target hit distance, inf if miss
    cos_incidence: FloatArray  # (n_j, n_k) cosine between each ray and the hit's normal
    t_seabed: FloatArray  # (n_j, n_k)
    occluding: np.ndarray  # (n_j, n_k) target hit before the seabed

    @property
    def beams(self) -> np.ndarray:
        """Beam indices of the block's rows."""
        return np.arange(self.j0, self.j0 + self.t.shape[0])


def cast_target(
    world: World,
    geo: PoseGeometry,
    placed: PlacedTarget,
    *,
    beam_azimuth_rad: FloatArray,
    step_rad: float,
    half_aperture_rad: float,
    max_range_m: float,
) -> TargetCast | None:
    """Cast the beam-axis rays that can meet ``placed``; None if no beam axis can.

    The rays span the target's elevation extent in each beam plane (from its bounding
    corners), so occlusion runs and shadow truth are complete even outside the aperture;
    only for a target so close that this exceeds MAX_RAYS_PER_BEAM steps is the span cut
    to the aperture +-10 deg (its truth may then be partial)."""
    q = (placed.corners_ned - geo.origin_ned) @ geo.rot  # sonar frame
    if np.all(q[:, 0] <= 0) or np.min(np.linalg.norm(q, axis=1)) > max_range_m:
        return None
    if np.all(q[:, 0] > 0):
        az = np.arctan2(q[:, 1], q[:, 0])
        inside = np.nonzero((beam_azimuth_rad >= az.min()) & (beam_azimuth_rad <= az.max()))[0]
    else:
        inside = np.arange(beam_azimuth_rad.size)
    if inside.size == 0:
        return None
    j0, j1 = int(inside[0]), int(inside[-1]) + 1
    a = beam_azimuth_rad[j0:j1]
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
    elevation = np.arange(k0, k1) * step_rad
    beams = np.arange(j0, j1)
    d = geo.directions(beams[:, None], elevation[None, :])
    flat_d = d.reshape(-1, 3)
    t, normal = placed.solid.intersect(geo.origin_ned, flat_d)
    cos_inc = -dot3(normal, flat_d)
    shape = (j1 - j0, k1 - k0)
    t = t.reshape(shape)
    seabed = local_seabed(world, geo, placed)
    t_sb = seabed.slant_m(d)
    occluding = t < t_sb
    if not np.any(occluding):
        return None
    return TargetCast(placed, seabed, j0, k0, elevation, t, cos_inc.reshape(shape), t_sb, occluding)
