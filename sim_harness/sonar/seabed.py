"""The analytic seabed of the sonar renderer: its echo per range cell and beam, per branch.

The seabed plane (no relief) is ``z = depth_m + g_n n + g_e e``. With ``c = (-g_n, -g_e, 1)``
a ray ``d`` from the sonar ``S`` meets it at ``t = H_v / (c . d)``, ``H_v`` the vertical height
of the sonar above the plane. Within the plane of one beam (all elevations at azimuth
``a``), ``c . d = rho cos(e - phi)``, so the seabed at slant range ``r`` lies at the two
elevations ``e = phi +/- arccos(H_v / (rho r))`` ("branches"). Each range cell's seabed is
therefore an exact elevation interval per branch: no rays, no holes. Relief shifts each
range by ``h / (c . d)`` (a two-step fixed point on a coarse grid of every RELIEF_STRIDE-th
range cell and RELIEF_BEAM_STRIDE-th beam, interpolated).

Geometry and conventions in :mod:`sim_harness.sonar.geometry`. Heavy arithmetic runs in
float32 on (range cells x beams) arrays; the elevation of each cell edge uses a polynomial
arccos (:func:`arccos01_f32`), and the seabed texture is sampled on every few range cells
(TEXTURE_SAMPLE_CELLS) and interpolated. Large arrays are bounded against arrays of the
bound (:func:`constant_f32`), which numpy does several times faster than against a scalar.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from sim_harness.sonar.geometry import FloatArray, PoseGeometry, dot3
from sim_harness.sonar.physics import SonarPhysics, elevation_gain, sigma_over_cos
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import World

#: Coarse range step (in cells) on which relief corrections are evaluated.
RELIEF_STRIDE = 32
#: Beam step on which relief corrections are evaluated (interpolated linearly between);
#: 4 beams of the ARIS 128-beam mode are ~1 deg, 5 cm at 3 m: the relief (wavelengths of
#: metres) is linear to ~0.1 mm over that.
RELIEF_BEAM_STRIDE = 4

#: Abramowitz & Stegun 4.4.45: ``arccos(x) = sqrt(1 - x) * sum(a_k x^k)`` on [0, 1], |error|
#: <= 2e-8 rad (coefficients a_7 .. a_0, for Horner's rule).
_ACOS_COEFFS = (-0.0012624911, 0.0066700901, -0.0170881256, 0.0308918810,
                -0.0501743046, 0.0889789874, -0.2145988016, 1.5707963050)


@functools.lru_cache(maxsize=16)
def _constant_bank(value: float, size: int) -> np.ndarray:
    """``size`` float32 copies of ``value``, read-only."""
    out = np.full(size, value, dtype=np.float32)
    out.flags.writeable = False
    return out


def constant_f32(value: float | np.floating, shape: tuple[int, ...]) -> np.ndarray:
    """A read-only float32 array of ``shape`` holding ``value`` (C-contiguous; cached).

    numpy's float32 ``maximum``/``minimum`` against a scalar run a loop several times
    slower than against an array of the same shape, with the same results (both are
    exact), so the bounds of large arrays are such arrays, taken from a cached bank.
    """
    size = math.prod(shape)
    bank = _constant_bank(float(np.float32(value)), 1 << max(size - 1, 0).bit_length())
    return bank[:size].reshape(shape)


def arccos01_f32(x: np.ndarray) -> np.ndarray:
    """``arccos(x)`` for float32 ``x`` in [0, 1] (any shape), float32, rad.

    A polynomial (A&S 4.4.45, 2e-8 rad) evaluated in float32: within ~2e-7 rad of
    ``np.arccos``, and about ten times faster (numpy's float32 arccos is scalar libm).
    Values above 1 give 0; below 0 the polynomial is not accurate (callers pass cosines
    in [0, 1]).
    """
    f32 = np.float32
    x = np.asarray(x, dtype=f32)
    out = x * f32(_ACOS_COEFFS[0])
    out += f32(_ACOS_COEFFS[1])
    for a in _ACOS_COEFFS[2:]:
        out *= x
        out += f32(a)
    root = np.subtract(f32(1.0), x)
    np.maximum(root, constant_f32(0.0, root.shape), out=root)
    np.sqrt(root, out=root)
    out *= root
    return out


@dataclass(frozen=True, eq=False)
class SeabedBranch:
    """One branch of the analytic seabed on range cells ``row0 .. row0 + n - 1`` x all beams.

    ``lo``/``hi``: elevation interval of each range cell's seabed clipped to the aperture
    (``hi <= lo`` when empty), rad; ``span``: ``max(hi - lo, 0)``; ``power``: unoccluded echo
    (beam pattern x scattering x seabed texture x footprint, as given), linear. Arrays
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


def _interp_rows(coarse: np.ndarray, stride: int, n_rows: int) -> np.ndarray:
    """Linear interpolation onto rows 0..n_rows-1 of values given every ``stride`` rows.

    ``coarse`` (..., n_coarse, n_cols) with ``(n_coarse - 1) * stride >= n_rows - 1``;
    returns (..., n_rows, n_cols) in its dtype.
    """
    n_c = coarse.shape[-2]
    blocks = -(-n_rows // stride)  # row blocks [q * stride, (q + 1) * stride)
    lo = coarse[..., :blocks, :]
    hi = coarse[..., np.minimum(np.arange(1, blocks + 1), n_c - 1), :]
    f = (np.arange(stride) / stride).astype(coarse.dtype)[:, None]
    out = np.multiply((hi - lo)[..., :, None, :], f)
    out += lo[..., :, None, :]
    out = out.reshape(*coarse.shape[:-2], blocks * stride, coarse.shape[-1])
    return np.asarray(out[..., :n_rows, :])


@functools.cache
def _beam_subset(n_beams: int, stride: int) -> tuple[np.ndarray, np.ndarray]:
    """Every ``stride``-th beam and the last: (their indices, (n_sub, n_beams) matrix that
    interpolates values on them linearly in beam index onto every beam)."""
    sub = np.unique(np.append(np.arange(0, n_beams, stride), n_beams - 1))
    eye = np.eye(sub.size)
    matrix = np.stack([np.interp(np.arange(n_beams), sub, row) for row in eye])
    sub.flags.writeable = False
    matrix.flags.writeable = False
    return sub, matrix


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
    start = float(range_edges_m[0])
    i0 = min(max(math.floor((float(r_min.min()) - start) / dr) - 1 - pad, 0), n)
    far = float(r_max.max())
    i1 = n if not math.isfinite(far) else min(max(math.ceil((far - start) / dr) + 1 + pad, 0), n)
    return (i0, i1) if i1 > i0 else None


#: The texture is sampled on every k-th range cell (interpolated linearly between), k the
#: largest with k range cells <= TEXTURE_SAMPLE_CELLS tile cells (at most TEXTURE_MAX_STRIDE).
#: At half a tile cell (1/8 of the correlation length) the interpolation error is ~1 % of
#: the texture's dB in rms (0.02-0.03 dB at 3 dB, at most ~0.35 dB next to the bilinear
#: tile's kinks), far below one ping's speckle.
TEXTURE_SAMPLE_CELLS = 0.5
#: Largest range-cell step between texture samples.
TEXTURE_MAX_STRIDE = 8


@functools.cache
def _row_interp(n_rows: int, stride: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation onto rows 0..n_rows-1 from rows ``0, stride, 2 stride, ..`` and the
    last: (those rows, (n_rows,) lower and upper node index, (n_rows, 1) float32 weight)."""
    nodes = np.unique(np.append(np.arange(0, n_rows, stride), n_rows - 1))
    rows = np.arange(n_rows)
    upper = np.clip(np.searchsorted(nodes, rows, side="right"), 1, max(nodes.size - 1, 1))
    lower = upper - 1 if nodes.size > 1 else np.zeros_like(upper)
    upper = np.minimum(upper, nodes.size - 1)
    gap = np.maximum(nodes[upper] - nodes[lower], 1)
    weight = ((rows - nodes[lower]) / gap).astype(np.float32)[:, None]
    for a in (nodes, lower, upper, weight):
        a.flags.writeable = False
    return nodes, lower, upper, weight


def _texture_gain(
    texture: SeabedTexture, geo: PoseGeometry, sign: int, ratio: np.ndarray, centres_m: FloatArray
) -> np.ndarray:
    """The seabed texture's gain at each cell's ground point, shape (n, n_beams), float32.

    ``ratio`` (n + 1, n_beams) is ``cos(e - phi)`` at the cell edges of one branch (with the
    relief's range shift folded in), ``centres_m`` (n,) the cells' centre ranges. In the beam
    plane, ``d(e) = cos(u) A + sin(u) B`` with ``u = e - phi``, ``A = cos(phi) h + sin(phi) z``
    and ``B = -sin(phi) h + cos(phi) z`` (``h`` the beam's e = 0 ray, ``z`` the sonar's down
    axis), so the ground point at range ``r`` is ``S + r (cos(u) A + sign sin(u) B)``.
    Sampled on every few cells (TEXTURE_SAMPLE_CELLS) and interpolated along range.
    """
    f32 = np.float32
    inv_cell = 1.0 / texture.cell_m
    n = centres_m.size
    dr = float(centres_m[1] - centres_m[0]) if n > 1 else texture.cell_m
    stride = min(max(math.floor(TEXTURE_SAMPLE_CELLS * texture.cell_m / dr), 1), TEXTURE_MAX_STRIDE)
    nodes, lower, upper, weight = _row_interp(n, stride)
    r = (centres_m[nodes] * inv_cell).astype(f32)[:, None]  # cell-centre range in tile cells
    # r cos(u) (the edges' mean of cos u) and r sin(u) = sqrt(r^2 - (r cos u)^2)
    r_cos = ratio[:-1] + ratio[1:] if stride == 1 else ratio[nodes] + ratio[nodes + 1]
    r_cos *= f32(0.5) * r
    r_sin = r_cos * r_cos
    np.subtract(r * r, r_sin, out=r_sin)
    np.maximum(r_sin, constant_f32(0.0, r_sin.shape), out=r_sin)
    np.sqrt(r_sin, out=r_sin)
    cphi, sphi = np.cos(geo.phi)[:, None], np.sin(geo.phi)[:, None]
    a_vec = cphi * geo.horiz + sphi * geo.rot[:, 2]
    b_vec = (-sphi * geo.horiz + cphi * geo.rot[:, 2]) * sign
    # the sonar's position modulo the tile (float64), the rest in tile cells (float32)
    base = np.mod(geo.origin_ned[:2], texture.tile_m) * inv_cell
    coords = []
    tmp = np.empty_like(r_cos)
    for axis in (0, 1):
        x = r_cos * a_vec[:, axis].astype(f32)
        np.multiply(r_sin, b_vec[:, axis].astype(f32), out=tmp)
        x += tmp
        x += f32(base[axis])
        coords.append(x)
    gain = texture.sample_cells(coords[0], coords[1], overwrite=True)
    if stride == 1:
        return gain
    if nodes.size == 1:
        return np.repeat(gain, n, axis=0)
    # upper == lower + 1: the differences between neighbouring nodes, gathered once
    step = gain[1:] - gain[:-1]
    out = np.take(step, lower, axis=0)  # whole rows: copies, not an element-wise gather
    out *= weight
    out += np.take(gain, lower, axis=0)
    return out


def seabed_branches(
    world: World,
    geo: PoseGeometry,
    *,
    range_edges_m: FloatArray,
    range_centres_m: FloatArray,
    half_aperture_rad: float,
    pattern_coeff: float,
    footprint: np.ndarray,
    physics: SonarPhysics | None = None,
) -> list[SeabedBranch]:
    """The seabed's echo per range cell and beam, per branch that reaches the aperture.

    ``pattern_coeff``: the elevation beam pattern is ``exp(pattern_coeff * (e / A)^2)`` inside
    the half aperture ``A`` and zero outside (``physics.elevation_pattern`` "gaussian"; with
    "flat" the pattern of :func:`sim_harness.sonar.physics.elevation_gain` whose edge level is
    ``pattern_coeff * 10 / ln 10`` dB); ``footprint`` (n_samples, n_beams) is the beam width
    over r^2 of each cell times any per-row gain; ``physics`` (default: the historical
    choices) also sets the backscatter law. Heavy arithmetic runs in float32.
    """
    phys = physics if physics is not None else SonarPhysics()
    material = world.material(world.seabed.material)
    historical_law = phys.seabed_lambert_exponent == 2.0 and (
        material.roughness == 1.0 or (phys.specular_gain == 10.0 and phys.specular_width_rad == math.radians(12.0))
    )
    relief = world.seabed.relief
    texture = world.seabed.texture
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
            beams, to_all = _beam_subset(geo.rho.size, RELIEF_BEAM_STRIDE)
            rho, phi = geo.rho[beams], geo.phi[beams]
            n_c = max(2, (n_e - 1 + RELIEF_STRIDE - 1) // RELIEF_STRIDE + 1)
            r_c = edges[0] + np.arange(n_c) * (RELIEF_STRIDE * dr)
            corr = np.zeros((n_c, beams.size))
            for _ in range(2):  # fixed point: the ray whose relief hit lies at range r_c
                x0 = np.minimum(geo.height_v_m / (rho[None, :] * (r_c[:, None] + corr)), 1.0)
                e_c = phi + sign * np.arccos(x0)
                d = geo.directions(beams[None, :], e_c)
                p = geo.origin_ned + r_c[:, None, None] * d
                k = dot3(d, geo.c_vec)
                # float32 trigonometry: the corrections are float32 anyway (and ~1e-7 m off)
                h, gn_r, ge_r = relief.height_and_gradient(p[..., 0], p[..., 1], dtype=np.float32)
                corr = np.where(k > 1e-6, h / np.maximum(k, 1e-6), 0.0)
            coarse = np.stack([corr, gn_r * d[..., 0] + ge_r * d[..., 1]]) @ to_all  # (2, n_c, n_beams)
            shift, extra_cos = _interp_rows(coarse.astype(f32), RELIEF_STRIDE, n_e)
            ratio = scale[None, :] / (edges.astype(f32)[:, None] + shift)
        np.minimum(ratio, constant_f32(1.0, ratio.shape), out=ratio)
        acos = arccos01_f32(ratio)
        phi = geo.phi.astype(f32)
        edges_e = phi + acos if sign > 0 else phi - acos
        ha = f32(half_aperture_rad)
        np.maximum(edges_e, constant_f32(-ha, edges_e.shape), out=edges_e)  # clip to the aperture
        np.minimum(edges_e, constant_f32(ha, edges_e.shape), out=edges_e)
        # along a branch the elevation moves away from phi as the range grows
        near_e, far_e = edges_e[:-1], edges_e[1:]
        lo, hi = (near_e, far_e) if sign > 0 else (far_e, near_e)
        span = hi - lo
        np.maximum(span, constant_f32(0.0, span.shape), out=span)
        mid = lo + hi
        mid *= f32(0.5)
        m2 = mid * mid
        # cos(e - phi) is the ratio at the cell edges: average them (exact to O(dr^2))
        cos_inc = ratio[:-1] + ratio[1:]
        cos_inc *= (0.5 * geo.rho / geo.c_norm).astype(f32)
        if extra_cos is not None:
            extra = extra_cos[:-1] + extra_cos[1:]
            extra *= f32(0.5 / geo.c_norm)
            cos_inc += extra
            np.maximum(cos_inc, constant_f32(0.0, cos_inc.shape), out=cos_inc)  # clip to [0, 1]
            np.minimum(cos_inc, constant_f32(1.0, cos_inc.shape), out=cos_inc)
        if phys.elevation_pattern != "gaussian":
            edge_db = pattern_coeff * 10.0 / math.log(10.0)
            power = elevation_gain(mid, half_aperture_rad=half_aperture_rad, edge_db=edge_db, physics=phys)
            power *= np.cos(mid)
        elif half_aperture_rad <= 0.3:
            # beam pattern x cos(mid): cos(x) = exp(-x^2 / 2) to 2e-5 for |x| <= 0.15 rad
            m2 *= f32(pattern_coeff / half_aperture_rad**2 - 0.5)
            power = np.exp(m2, out=m2)
        else:
            m2 *= f32(pattern_coeff / half_aperture_rad**2)
            power = np.exp(m2, out=m2)
            power *= np.cos(mid)
        if not historical_law:
            law = sigma_over_cos(cos_inc, material.roughness, lambert_exponent=phys.seabed_lambert_exponent,
                                 specular_gain=phys.specular_gain, specular_width_rad=phys.specular_width_rad)
            power *= (law * 10.0 ** (material.backscatter_db / 10.0)).astype(f32)
        elif material.roughness == 1.0:
            power *= cos_inc
            power *= f32(10.0 ** (material.backscatter_db / 10.0))
        else:
            power *= material.sigma_over_cos(cos_inc)
        power *= span
        power *= footprint[i0:i1]
        if texture is not None:
            power *= _texture_gain(texture, geo, sign, ratio, range_centres_m[i0:i1])
        branches.append(SeabedBranch(sign, i0, lo, hi, span, power))
    return branches
