"""Targets in a sonar frame: ray casts, their occlusion runs, echo, hidden seabed and truth.

Pure functions used by :class:`sim_harness.sonar.SonarRenderer`; geometry and conventions
in :mod:`sim_harness.sonar_geometry`. Images are (n_samples, n_beams); "flat" image indices
are ``row * n_beams + column``.

After each target's rays are cast (:func:`sim_harness.sonar_geometry.cast_target`), every
later step runs on all targets at once: the casts are laid end to end in one
:class:`RayBatch` (each block row followed by one padding ray, so runs never cross rows);
only the ray-solid intersections of the edge refinement go target by target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_harness.scene_errors import SonarConfigError
from sim_harness.sonar_geometry import (
    REFINE_SPLIT,
    PoseGeometry,
    SeabedBranch,
    TargetCast,
    cast_target,
    seabed_slant_m,
)
from sim_harness.truth import TargetTruth
from sim_harness.world import SPECULAR_GAIN, SPECULAR_WIDTH_RAD, World

FloatArray = np.ndarray

#: On a rock, consecutive hits farther apart than this many range cells lie on different
#: lobes and are not joined.
SPLAT_MAX_CELLS = 16


@dataclass(frozen=True, eq=False)
class Sampling:
    """The renderer's fixed sampling of the sonar volume.

    ``azimuth_rad``/``beam_width_rad`` (n_beams,); ``row_gain`` (n_samples, 1) float32 display
    gain per range row; ``window_*`` the outer cell edges, m; ``pattern_coeff`` the elevation
    beam pattern ``exp(pattern_coeff * (e / half_aperture)^2)``; ``ray_step_rad`` the
    elevation step of target rays.
    """

    n_samples: int
    n_beams: int
    window_start_m: float
    window_end_m: float
    range_resolution_m: float
    azimuth_rad: np.ndarray
    beam_width_rad: np.ndarray
    half_aperture_rad: float
    pattern_coeff: float
    ray_step_rad: float
    row_gain: np.ndarray


def cast_all(world: World, geo: PoseGeometry, sp: Sampling) -> list[TargetCast]:
    """Cast rays at every target a beam axis can meet, nearest first (the truth's order)."""
    casts = []
    for placed in world.placed:
        cast = cast_target(
            world,
            geo,
            placed,
            beam_azimuth_rad=sp.azimuth_rad,
            step_rad=sp.ray_step_rad,
            half_aperture_rad=sp.half_aperture_rad,
            max_range_m=sp.window_end_m,
        )
        if cast is not None:
            casts.append(cast)
    casts.sort(key=lambda c: float(np.min(np.where(c.occluding, c.t, np.inf))))
    if len(casts) > 255:
        raise SonarConfigError(f"{len(casts)} targets in view; at most 255 are labelled", key="targets")
    return casts


@dataclass(frozen=True, eq=False)
class RayBatch:
    """All cast rays end to end, shape (n,) each; padding rays end every block row.

    ``target`` is the 0-based cast index (casts nearest first), ``col`` the ray's column in
    its block, ``key`` the ray's cell in the global (beam x elevation step) grid.
    """

    target: np.ndarray
    beam: np.ndarray
    col: np.ndarray
    e: FloatArray
    t: FloatArray
    t_seabed: FloatArray
    cos_incidence: FloatArray
    occluding: np.ndarray
    pad: np.ndarray


def ray_batch(casts: list[TargetCast]) -> RayBatch:
    """Lay the casts end to end (see :class:`RayBatch`)."""
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("target", "beam", "col", "e", "t", "tsb", "cos", "occ")}
    for i, c in enumerate(casts):
        n_j, n_k = c.t.shape
        shape = (n_j, n_k + 1)
        parts["target"].append(np.full(n_j * (n_k + 1), i, dtype=np.int64))
        parts["beam"].append(np.repeat(np.arange(c.j0, c.j0 + n_j), n_k + 1))
        parts["col"].append(np.tile(np.arange(n_k + 1), n_j))
        parts["e"].append(np.tile(np.append(c.elevation_rad, c.elevation_rad[-1]), n_j))
        for key, block, fill in (("t", c.t, np.inf), ("tsb", c.t_seabed, np.inf),
                                 ("cos", c.cos_incidence, 0.0), ("occ", c.occluding, False)):
            padded = np.full(shape, fill, dtype=block.dtype)
            padded[:, :n_k] = block
            parts[key].append(padded.ravel())
    cat = {k: np.concatenate(v) for k, v in parts.items()}
    widths = np.concatenate([np.full(c.t.shape[0] * (c.t.shape[1] + 1), c.t.shape[1]) for c in casts])
    return RayBatch(cat["target"], cat["beam"], cat["col"], cat["e"], cat["t"], cat["tsb"], cat["cos"],
                    cat["occ"], cat["col"] == widths)


@dataclass(frozen=True, eq=False)
class Runs:
    """Occluded elevation runs of all targets, one per (target, beam, run), refined.

    ``lo``/``hi`` bound each run's elevations (rad); ``*_t``/``*_t_seabed`` are the target and
    seabed slant ranges of the rays just inside each end, m; ``t_min`` the run's nearest
    target hit; ``first``/``last`` the batch indices of its first and last grid ray.
    """

    target: np.ndarray
    beam: np.ndarray
    first: np.ndarray
    last: np.ndarray
    lo: FloatArray
    hi: FloatArray
    lo_t: FloatArray
    hi_t: FloatArray
    lo_t_seabed: FloatArray
    hi_t_seabed: FloatArray
    t_min: FloatArray


def occlusion_runs(world: World, geo: PoseGeometry, casts: list[TargetCast], batch: RayBatch) -> Runs:
    """Find every occluded run and refine both its edges to 1 / REFINE_SPLIT of a ray step."""
    occ = batch.occluding
    step = np.diff(np.concatenate([[0], occ.view(np.int8), [0]]))
    first = np.nonzero(step == 1)[0]
    stop = np.nonzero(step == -1)[0]  # exclusive; always a padding ray or beyond
    last = stop - 1
    n = first.size
    # brackets [occluded inner ray, free outer ray]; no outer ray at a block edge
    outer_lo = first - 1
    valid_lo = batch.col[first] > 0
    valid_hi = ~batch.pad[stop]
    inner = np.concatenate([first, last])
    outer = np.concatenate([np.where(valid_lo, outer_lo, first), np.where(valid_hi, stop, last)])
    e_in, e_out = batch.e[inner], batch.e[outer]
    target = batch.target[inner]
    beam = batch.beam[inner]
    frac = np.arange(1, REFINE_SPLIT) / REFINE_SPLIT
    cand = e_in[:, None] + (e_out - e_in)[:, None] * frac
    d = geo.directions(np.repeat(beam, frac.size), cand.ravel())
    occ_c = np.zeros(d.shape[0], dtype=bool)
    t_c = np.full(d.shape[0], np.inf)
    tsb_c = np.full(d.shape[0], np.inf)
    ray_target = np.repeat(target, frac.size)
    order = np.argsort(ray_target, kind="stable")
    bounds = np.searchsorted(ray_target[order], np.arange(len(casts) + 1))
    for i, c in enumerate(casts):
        idx = order[bounds[i]:bounds[i + 1]]
        if idx.size == 0:
            continue
        t_i, _ = c.placed.solid.intersect(geo.origin_ned, d[idx], normals=False)
        tsb_i = c.seabed.slant_m(d[idx])
        t_c[idx], tsb_c[idx], occ_c[idx] = t_i, tsb_i, t_i < tsb_i
    m = inner.size
    rows = np.arange(m)
    ext_occ = np.concatenate([np.ones((m, 1), bool), occ_c.reshape(m, -1), np.zeros((m, 1), bool)], axis=1)
    pick = np.argmin(ext_occ, axis=1) - 2  # last occluded candidate; -1: the inner ray
    cand_e = cand[rows, np.maximum(pick, 0)]
    cand_t = t_c.reshape(m, -1)[rows, np.maximum(pick, 0)]
    cand_tsb = tsb_c.reshape(m, -1)[rows, np.maximum(pick, 0)]
    use = pick >= 0
    edge_e = np.where(use, cand_e, e_in)
    edge_t = np.where(use, cand_t, batch.t[inner])
    edge_tsb = np.where(use, cand_tsb, batch.t_seabed[inner])
    if world.seabed.relief is not None:
        # the true seabed, not the target's tangent plane (never nearer than the hit itself)
        edge_tsb = np.maximum(seabed_slant_m(world, geo, geo.directions(beam, edge_e)), edge_t)
    t_occ = np.where(occ, batch.t, np.inf)
    t_min = np.minimum.reduceat(np.append(t_occ, np.inf), np.ravel(np.column_stack([first, stop])))[::2]
    t_min = np.minimum(t_min, np.minimum(edge_t[:n], edge_t[n:]))  # a refined edge may lie nearer
    return Runs(target[:n], beam[:n], first, last, edge_e[:n], edge_e[n:], edge_t[:n], edge_t[n:],
                edge_tsb[:n], edge_tsb[n:], t_min)


def no_runs() -> Runs:
    """The runs of a frame without targets."""
    i, f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return Runs(i, i, i, i, f, f, f, f, f, f, f)


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
    visible = batch.occluding & (batch.t <= best[batch.beam, kglob]) & (np.abs(batch.e) <= sp.half_aperture_rad)
    mu = np.array([10.0 ** (world.material(c.placed.spec.material).backscatter_db / 10.0) for c in casts])
    rough = np.array([world.material(c.placed.spec.material).roughness for c in casts])
    is_rock = np.array([c.placed.spec.shape == "rock" for c in casts])
    v = np.nonzero(visible)[0]
    tv, ev, tg = batch.t[v], batch.e[v], batch.target[v]
    cos_inc = np.clip(batch.cos_incidence[v], 0.0, 1.0)
    sigma = rough[tg] * cos_inc
    if np.any(rough < 1.0):
        theta = np.arccos(cos_inc)
        spec = SPECULAR_GAIN * np.exp(-((theta / SPECULAR_WIDTH_RAD) ** 2)) / np.maximum(cos_inc, 1e-6)
        sigma = sigma + (1.0 - rough[tg]) * spec
    dr, step = sp.range_resolution_m, sp.ray_step_rad
    p = (np.exp(sp.pattern_coeff * (ev / sp.half_aperture_rad) ** 2) * mu[tg] * sigma * np.cos(ev) * step
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
    power = np.bincount(flat - first_cell, weights=w * sp.row_gain[cell, 0])
    far_first = np.argsort(-batch.target[ray], kind="stable")  # nearer targets overwrite
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
    col = beam[rep]
    ov = np.minimum(branch.hi[cell, col], hi[rep]) - np.maximum(branch.lo[cell, col], lo[rep])
    hit = ov > 0
    return cell[hit] * n_b + col[hit], ov[hit], rep[hit]


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
    order = np.lexsort((lo, beam))
    merged: list[list[float]] = []
    mixed = False  # did intervals of different targets merge?
    for i in order:
        b, a, z, w = int(beam[i]), float(lo[i]), float(hi[i]), int(who[i])
        if merged and merged[-1][0] == b and a <= merged[-1][2]:
            merged[-1][2] = max(merged[-1][2], z)
            mixed |= merged[-1][3] != w
            merged[-1][3] = min(merged[-1][3], w)
        else:
            merged.append([b, a, z, w])
    m = np.array(merged)
    mb, mlo, mhi, mw = m[:, 0].astype(np.int64), m[:, 1], m[:, 2], m[:, 3].astype(np.uint8)
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
    """Per-target shadow truth (see :mod:`sim_harness.truth`) from the refined runs."""
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
