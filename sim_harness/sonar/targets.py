"""Targets in a sonar frame: their echo, the seabed they hide and their truth.

Pure functions used by :class:`sim_harness.sonar.renderer.SonarRenderer` on the target rays
and occlusion runs of :mod:`sim_harness.sonar.target_rays`; geometry and conventions in
:mod:`sim_harness.sonar.geometry`. Images are (n_samples, n_beams); "flat" image indices
are ``row * n_beams + column``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_harness.sonar.geometry import PoseGeometry, TargetCast
from sim_harness.sonar.physics import elevation_gain, sigma_over_cos
from sim_harness.sonar.seabed import SeabedBranch
from sim_harness.sonar.target_rays import RayBatch, Runs, Sampling
from sim_harness.sonar.truth import TargetTruth
from sim_harness.world.materials import SPECULAR_GAIN, SPECULAR_WIDTH_RAD
from sim_harness.world.world import World

FloatArray = np.ndarray

#: On a rock, consecutive hits farther apart than this many range cells lie on different
#: lobes and are not joined.
SPLAT_MAX_CELLS = 16


def _spread(c_from: np.ndarray, c_to: np.ndarray, weight: FloatArray) -> tuple[np.ndarray, np.ndarray, FloatArray]:
    """Spread each weight uniformly over the integer cells from ``c_from`` to ``c_to``
    (inclusive, either order): (segment index, cell, weight per cell) per covered cell."""
    lo = np.minimum(c_from, c_to)
    n = np.abs(c_to - c_from) + 1
    seg = np.repeat(np.arange(lo.size), n)
    start = np.repeat(np.cumsum(n) - n, n)
    cell = lo[seg] + (np.arange(seg.size) - start)
    return seg, cell, (weight / n)[seg]


@dataclass(frozen=True, eq=False)
class TargetPower:
    """Target echo with gain on a stretch of the flat image: ``power`` (float64) holds flat
    indices ``first_cell .. first_cell + power.size - 1``; every other cell has none."""

    first_cell: int
    power: FloatArray

    def rows(self, n_beams: int) -> tuple[int, int]:
        """The image rows [start, stop) the echo touches (of an image ``n_beams`` wide)."""
        if self.power.size == 0:
            return 0, 0
        return self.first_cell // n_beams, (self.first_cell + self.power.size - 1) // n_beams + 1

    def add_to(self, image: np.ndarray) -> None:
        """Add the echo into the C-contiguous (n_samples, n_beams) float32 ``image``, in place
        (summed in float64, rounded once to float32)."""
        part = image.reshape(-1)[self.first_cell:self.first_cell + self.power.size]
        np.add(part, self.power, out=part, casting="unsafe")


def target_echo(
    world: World, casts: list[TargetCast], batch: RayBatch, runs: Runs, sp: Sampling
) -> tuple[TargetPower, np.ndarray, np.ndarray]:
    """Echo of the visible target hits, with gain (:class:`TargetPower`); the highlight mask,
    shape (n_samples, n_beams); the owner image (1-based cast index, nearest wins), uint8.

    A hit is visible when its target is the nearest along the ray and it lies inside the
    aperture. Each ray stands for its elevation step: its echo is spread uniformly over the
    range cells between its hit and the next ray's hit on the same surface (and, at the run
    edges, out to the refined edge hit), so no range cell of a target is left empty. On a
    box, cylinder or stone consecutive visible hits always lie on one surface; on a rock
    (several lobes) hits more than SPLAT_MAX_CELLS apart are not joined."""
    n_s, n_b = sp.n_samples, sp.n_beams
    owner = np.zeros(n_s * n_b, dtype=np.uint8)
    if not casts:
        return TargetPower(0, np.zeros(0)), np.zeros((n_s, n_b), dtype=bool), owner.reshape(n_s, n_b)
    # the nearest target along every ray of the global (beam x elevation step) grid
    k_lo = min(c.k0 for c in casts)
    k_hi = max(c.k0 + c.elevation_rad.size for c in casts)
    best = np.full((n_b, k_hi - k_lo + 1), np.inf)
    for c in casts:
        blk = best[c.j0:c.j0 + c.t.shape[0], c.k0 - k_lo:c.k0 - k_lo + c.t.shape[1]]
        np.minimum(blk, np.where(c.occluding, c.t, np.inf), out=blk)
    k0 = np.array([c.k0 for c in casts])
    kglob = k0[batch.target] - k_lo + batch.col
    visible = (batch.occluding & (batch.t <= best.ravel()[batch.beam * best.shape[1] + kglob])
               & (np.abs(batch.e) <= sp.half_aperture_rad))
    phys = sp.physics
    mu = np.array([10.0 ** (world.material(c.placed.spec.material).backscatter_db / 10.0) for c in casts])
    rough = np.array([world.material(c.placed.spec.material).roughness for c in casts])
    if phys.target_roughness is not None:
        rough = np.full(len(casts), float(phys.target_roughness))
    is_rock = np.array([c.placed.spec.shape == "rock" for c in casts])
    v = np.nonzero(visible)[0]
    tv, ev, tg = batch.t[v], batch.e[v], batch.target[v]
    cos_inc = np.clip(batch.cos_incidence[v], 0.0, 1.0)
    if phys.is_historical_target:
        sigma = rough[tg] * cos_inc
        if np.any(rough < 1.0):
            theta = np.arccos(cos_inc)
            spec = SPECULAR_GAIN * np.exp(-((theta / SPECULAR_WIDTH_RAD) ** 2)) / np.maximum(cos_inc, 1e-6)
            sigma = sigma + (1.0 - rough[tg]) * spec
    else:
        sigma = sigma_over_cos(cos_inc, rough[tg], lambert_exponent=phys.target_lambert_exponent,
                               specular_gain=phys.specular_gain, specular_width_rad=phys.specular_width_rad)
    if phys.elevation_pattern == "gaussian":
        pattern = np.exp(sp.pattern_coeff * (ev / sp.half_aperture_rad) ** 2)
    else:
        pattern = elevation_gain(ev, half_aperture_rad=sp.half_aperture_rad,
                                 edge_db=sp.pattern_coeff * 10.0 / math.log(10.0), physics=phys)
    dr, step = sp.range_resolution_m, sp.ray_step_rad
    p = (pattern * mu[tg] * sigma * np.cos(ev) * step
         * sp.beam_width_rad[batch.beam[v]] / (tv * tv))
    cell_all = np.zeros(batch.t.size, dtype=np.int64)
    cell_all[v] = np.floor((tv - sp.window_start_m) / dr).astype(np.int64)
    nxt = np.minimum(v + 1, batch.t.size - 1)
    joined = visible[nxt] & (nxt == v + 1)
    joined &= ~is_rock[tg] | (np.abs(cell_all[nxt] - cell_all[v]) <= SPLAT_MAX_CELLS)
    c_from = cell_all[v]
    c_to = np.where(joined, cell_all[nxt], c_from)
    rays = v
    weight = p
    # the refined run edges: from each edge ray out to the exact edge hit
    inner = np.concatenate([runs.first, runs.last])
    t_edge = np.concatenate([runs.lo_t, runs.hi_t])
    e_edge = np.concatenate([runs.lo, runs.hi])
    ok = visible[inner] & np.isfinite(t_edge)
    if np.any(ok):
        inner, t_edge, e_edge = inner[ok], t_edge[ok], e_edge[ok]
        p_of = np.zeros(batch.t.size)
        p_of[v] = p
        part = np.abs(e_edge - batch.e[inner]) / step
        rays = np.concatenate([rays, inner])
        c_from = np.concatenate([c_from, cell_all[inner]])
        c_to = np.concatenate([c_to, np.floor((t_edge - sp.window_start_m) / dr).astype(np.int64)])
        weight = np.concatenate([weight, p_of[inner] * part])
    seg, cell, w = _spread(np.clip(c_from, -1, n_s), np.clip(c_to, -1, n_s), weight)
    keep = (cell >= 0) & (cell < n_s) & (w > 0)
    seg, cell, w = seg[keep], cell[keep], w[keep]
    ray = rays[seg]
    flat = cell * n_b + batch.beam[ray]
    # only the flat range the hits touch: the rest of the image gets no target echo
    first_cell = int(flat.min()) if flat.size else 0
    power = np.bincount(flat - first_cell, weights=w * sp.row_gain.ravel()[cell])
    # nearer targets overwrite: a stable sort, farthest first (uint8 keys sort by radix)
    far_first = np.argsort((len(casts) - 1 - batch.target[ray]).astype(np.uint8), kind="stable")
    owner[flat[far_first]] = (batch.target[ray[far_first]] + 1).astype(np.uint8)
    highlight = np.zeros(n_s * n_b, dtype=bool)
    highlight[flat] = True
    return TargetPower(first_cell, power), highlight.reshape(n_s, n_b), owner.reshape(n_s, n_b)


def _interval_cells(
    geo: PoseGeometry, branch: SeabedBranch, beam: np.ndarray, lo: FloatArray, hi: FloatArray,
    sp: Sampling, pad: int,
) -> tuple[np.ndarray, FloatArray, np.ndarray]:
    """Cells of one seabed branch that elevation intervals (beam, [lo, hi]) overlap.

    Returns (local flat index ``row * n_beams + beam`` within the branch's rows, overlap in
    rad, interval index) for every overlapped cell.
    """
    n_b = sp.n_beams
    dr = sp.range_resolution_m
    rho, phi = geo.rho[beam], geo.phi[beam]
    s = branch.sign
    side_a = np.minimum(phi, phi + s * math.pi / 2 * 0.999)
    side_b = np.maximum(phi, phi + s * math.pi / 2 * 0.999)
    a = np.clip(lo, side_a, side_b)
    z = np.clip(hi, side_a, side_b)
    keep = z > a
    r_a = geo.height_v_m / (rho * np.cos(a - phi))
    r_z = geo.height_v_m / (rho * np.cos(z - phi))
    c0 = np.floor((np.minimum(r_a, r_z) - sp.window_start_m) / dr).astype(np.int64) - pad
    c1 = np.floor((np.maximum(r_a, r_z) - sp.window_start_m) / dr).astype(np.int64) + pad
    n_rows = branch.span.shape[0]
    c0 = np.clip(c0 - branch.row0, 0, n_rows - 1)
    c1 = np.clip(c1 - branch.row0, 0, n_rows - 1)
    keep &= c1 >= c0
    idx = np.nonzero(keep)[0]
    lengths = c1[idx] - c0[idx] + 1
    rep = np.repeat(idx, lengths)
    start = np.repeat(np.cumsum(lengths) - lengths, lengths)
    cell = c0[rep] + (np.arange(rep.size) - start)
    local = cell * n_b + beam[rep]
    ov = np.minimum(branch.hi.ravel()[local], hi[rep]) - np.maximum(branch.lo.ravel()[local], lo[rep])
    hit = ov > 0
    return local[hit], ov[hit], rep[hit]


def hidden_seabed(
    world: World,
    geo: PoseGeometry,
    branches: list[SeabedBranch],
    runs: Runs,
    owner: np.ndarray,
    highlight: np.ndarray,
    sp: Sampling,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per branch, the hidden seabed: (flat image indices, unique; hidden elevation span
    per cell, <= the cell's span).

    The occluded intervals of all targets are merged per beam first, so seabed hidden by
    two targets is removed once. Writes into ``owner`` (flat, uint8) the 1-based index of
    the nearest target hiding each non-highlight cell."""
    n_b = sp.n_beams
    out: list[tuple[np.ndarray, np.ndarray]] = []
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float32))
    if runs.beam.size == 0 or not branches:
        return [empty for _ in branches]
    beam, lo, hi, who = runs.beam, runs.lo, runs.hi, runs.target + 1
    # merge overlapping intervals per beam: sorted by (beam, lo), an interval starts a new
    # group unless it begins inside the running maximum of his in its beam (offsetting each
    # beam's elevations by 4 rad keeps one running maximum from leaking into the next beam)
    order = np.lexsort((lo, beam))
    b_s, lo_s, hi_s, w_s = beam[order], lo[order], hi[order], who[order]
    offset = 4.0 * b_s
    running = np.maximum.accumulate(hi_s + offset)
    new_group = np.ones(order.size, dtype=bool)
    new_group[1:] = (b_s[1:] != b_s[:-1]) | (lo_s[1:] + offset[1:] > running[:-1])
    starts = np.nonzero(new_group)[0]
    mb, mlo = b_s[starts], lo_s[starts]
    mhi = np.maximum.reduceat(hi_s, starts)
    w_min = np.minimum.reduceat(w_s, starts)
    mixed = bool(np.any(np.maximum.reduceat(w_s, starts) != w_min))  # did different targets merge?
    mw = w_min.astype(np.uint8)
    relief = world.seabed.relief
    pad = 3 + (math.ceil(6.0 * relief.amplitude_m / sp.range_resolution_m) if relief is not None else 0)
    highlight_flat = highlight.ravel()
    far_first = np.argsort(-who, kind="stable")  # own each cell by the nearest target hiding it
    for branch in branches:
        local, ov, rep = _interval_cells(geo, branch, mb, mlo, mhi, sp, pad)
        if local.size == 0:
            out.append(empty)
            continue
        unique, inverse = np.unique(local, return_inverse=True)
        hidden = np.bincount(inverse, weights=ov).astype(np.float32)
        np.minimum(hidden, branch.span.ravel()[unique], out=hidden)
        out.append((unique + branch.row0 * n_b, hidden))
        if mixed:
            local, _, rep = _interval_cells(
                geo, branch, beam[far_first], lo[far_first], hi[far_first], sp, pad
            )
            who_cell = who[far_first][rep].astype(np.uint8)
        else:
            who_cell = mw[rep]
        full = local + branch.row0 * n_b
        free = ~highlight_flat[full]
        owner[full[free]] = who_cell[free]
    return out


def target_truths(geo: PoseGeometry, casts: list[TargetCast], runs: Runs, sp: Sampling) -> tuple[TargetTruth, ...]:
    """Per-target shadow truth (see :mod:`sim_harness.sonar.truth`) from the refined runs."""
    if runs.beam.size == 0:
        return ()
    far_is_hi = runs.hi_t_seabed >= runs.lo_t_seabed
    e_far = np.where(far_is_hi, runs.hi, runs.lo)
    start = np.where(far_is_hi, runs.hi_t, runs.lo_t)
    end = np.where(far_is_hi, runs.hi_t_seabed, runs.lo_t_seabed)
    foot = np.where(far_is_hi, runs.lo_t_seabed, runs.hi_t_seabed)
    # keep, per target and beam, the run whose shadow reaches farthest
    order = np.lexsort((-end, runs.beam, runs.target))
    tg_o, bm_o = runs.target[order], runs.beam[order]
    first = np.concatenate([[True], (tg_o[1:] != tg_o[:-1]) | (bm_o[1:] != bm_o[:-1])])
    sel = order[first]
    target, beams = runs.target[sel], runs.beam[sel]
    e_far, start, end, foot, t_min = e_far[sel], start[sel], end[sel], foot[sel], runs.t_min[sel]
    rho, phi = geo.rho[beams], geo.phi[beams]
    ratio = geo.height_v_m / (rho * start)
    sign = np.where(e_far >= phi, 1.0, -1.0)
    e_start = phi + sign * np.arccos(np.clip(ratio, -1.0, 1.0))
    half = sp.half_aperture_rad
    in_band = (ratio <= 1.0) & (np.abs(e_far) <= half) & (np.abs(e_start) <= half)
    in_window = (start >= sp.window_start_m) & (end <= sp.window_end_m)
    bounds = np.searchsorted(target, np.arange(len(casts) + 1))
    out = []
    for i, cast in enumerate(casts):
        a, b = int(bounds[i]), int(bounds[i + 1])
        if b == a:
            continue
        spec = cast.placed.spec
        centre = np.array([spec.north_m, spec.east_m, cast.placed.base_depth_m - spec.height_m / 2])
        q = (centre - geo.origin_ned) @ geo.rot
        az = math.atan2(q[1], q[0])
        ci = a + int(np.argmin(np.abs(sp.azimuth_rad[beams[a:b]] - az)))
        out.append(
            TargetTruth(
                target_id=spec.target_id,
                shape=spec.shape,
                index=i + 1,
                north_m=spec.north_m,
                east_m=spec.east_m,
                height_m=spec.height_m,
                height_normal_m=spec.height_m / geo.c_norm,
                top_depth_m=cast.placed.top_depth_m,
                beams=beams[a:b],
                shadow_start_m=start[a:b],
                shadow_end_m=end[a:b],
                highlight_start_m=t_min[a:b],
                hidden_seabed_start_m=foot[a:b],
                in_band=in_band[a:b],
                in_window=in_window[a:b],
                central_beam=int(beams[ci]),
                azimuth_rad=float(sp.azimuth_rad[beams[ci]]),
                central_shadow_start_m=float(start[ci]),
                central_shadow_end_m=float(end[ci]),
                whole_shadow_in_band=bool(np.all(in_band[a:b])),
                whole_shadow_in_window=bool(np.all(in_window[a:b])),
            )
        )
    return tuple(out)
