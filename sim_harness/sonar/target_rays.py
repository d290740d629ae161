"""Target rays in a sonar frame: the renderer's sampling, the ray casts laid end to end
and their occlusion runs, refined at both edges.

Pure functions used by :class:`sim_harness.sonar.renderer.SonarRenderer`; geometry and
conventions in :mod:`sim_harness.sonar.geometry`; what the runs give (echo, hidden seabed,
truth) in :mod:`sim_harness.sonar.targets`.

All targets' rays are cast in one batch (:func:`sim_harness.sonar.geometry.cast_targets`;
ray-solid intersections by kind of solid, :func:`sim_harness.world.shapes.intersect_batch`), and
every later step runs on all targets at once: the casts are laid end to end in one
:class:`RayBatch` (each block row followed by one padding ray, so runs never cross rows).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim_harness.sonar.geometry import (
    REFINE_SPLIT,
    PoseGeometry,
    TargetCast,
    TargetTable,
    cast_targets,
    dot3,
    seabed_slant_m,
    target_table,
)
from sim_harness.sonar.physics import SonarPhysics
from sim_harness.world.errors import SonarConfigError
from sim_harness.world.shapes import intersect_batch, solid_kinds
from sim_harness.world.world import World

FloatArray = np.ndarray

#: Occlusion edges are refined on every REFINE_COARSE-th of the REFINE_SPLIT grid first.
REFINE_COARSE = 8


@dataclass(frozen=True, eq=False)
class Sampling:
    """The renderer's fixed sampling of the sonar volume.

    ``azimuth_rad``/``beam_width_rad`` (n_beams,); ``row_gain`` (n_samples, 1) float32 display
    gain per range row; ``window_*`` the outer cell edges, m; ``pattern_coeff`` the elevation
    beam pattern ``exp(pattern_coeff * (e / half_aperture)^2)``; ``ray_step_rad`` the
    elevation step of target rays; ``physics`` the renderer's physical choices (elevation
    pattern shape, target backscatter law).
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
    physics: SonarPhysics = SonarPhysics()


def cast_all(world: World, geo: PoseGeometry, sp: Sampling, table: TargetTable | None = None) -> list[TargetCast]:
    """Cast rays at every target a beam axis can meet, nearest first (the truth's order).

    ``table``: the world's :func:`~sim_harness.sonar.geometry.target_table` (built here when
    not given; a renderer builds it once)."""
    casts = cast_targets(
        world,
        geo,
        table if table is not None else target_table(world),
        beam_azimuth_rad=sp.azimuth_rad,
        step_rad=sp.ray_step_rad,
        half_aperture_rad=sp.half_aperture_rad,
        max_range_m=sp.window_end_m,
    )
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
    n_j = np.array([c.t.shape[0] for c in casts], dtype=np.int64)
    n_k = np.array([c.t.shape[1] for c in casts], dtype=np.int64)
    rows = np.repeat(np.arange(len(casts)), n_j)  # cast of each block row
    width = n_k[rows] + 1  # rays per block row, padding included
    total = int(width.sum())
    row_start = np.cumsum(width) - width
    # within-row position of every ray (the row's rays, then its padding ray)
    col = np.arange(total) - np.repeat(row_start, width)
    target = np.repeat(rows, width)
    first_row = np.cumsum(n_j) - n_j
    beam = np.repeat(np.array([c.j0 for c in casts], dtype=np.int64)[rows] + np.arange(rows.size) - first_row[rows],
                     width)
    e = np.empty(total)
    t = np.full(total, np.inf)
    tsb = np.full(total, np.inf)
    cos = np.zeros(total)
    occ = np.zeros(total, dtype=bool)
    start = 0
    for c in casts:
        rows_c, cols_c = c.t.shape
        stop = start + rows_c * (cols_c + 1)
        e_blk = e[start:stop].reshape(rows_c, cols_c + 1)
        e_blk[:, :cols_c] = c.elevation_rad
        e_blk[:, cols_c] = c.elevation_rad[-1]
        for out, block in ((t, c.t), (tsb, c.t_seabed), (cos, c.cos_incidence), (occ, c.occluding)):
            out[start:stop].reshape(rows_c, cols_c + 1)[:, :cols_c] = block
        start = stop
    return RayBatch(target, beam, col, e, t, tsb, cos, occ, col == n_k[target])


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
    """Find every occluded run and refine both its edges to 1 / REFINE_SPLIT of a ray step.

    Each edge's bracket [inner occluded ray, outer free ray] is searched for the first free
    candidate on the grid ``i / REFINE_SPLIT`` in two rounds: every REFINE_COARSE-th
    candidate, then the REFINE_COARSE - 1 before the first free one (the same candidate a
    scan of all REFINE_SPLIT - 1 finds whenever the bracket changes from occluded to free
    once, i.e. unless a sliver of a target thinner than 1/4 of a ray step lies in it)."""
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
    probe = _Probe(geo, casts, e_in, e_out, beam, target)
    # first free candidate on the grid i / REFINE_SPLIT (i = 1 .. REFINE_SPLIT - 1; the outer ray
    # is free) in two rounds: every REFINE_COARSE-th, then the ones before the first free of those
    m = inner.size
    rows = np.arange(m)
    coarse_i = np.arange(REFINE_COARSE, REFINE_SPLIT, REFINE_COARSE)
    e1, t1, tsb1, occ1 = probe(np.broadcast_to(coarse_i, (m, coarse_i.size)))
    f1 = np.argmin(np.concatenate([occ1, np.zeros((m, 1), bool)], axis=1), axis=1)
    free1 = REFINE_COARSE * (f1 + 1)  # first free coarse index (REFINE_SPLIT: the outer ray)
    fine_i = free1[:, None] - REFINE_COARSE + 1 + np.arange(REFINE_COARSE - 1)
    e2, t2, tsb2, occ2 = probe(fine_i)
    f2 = np.argmin(np.concatenate([occ2, np.zeros((m, 1), bool)], axis=1), axis=1)
    # the last occluded candidate: the fine one before the first free, else the coarse one
    # below the fine run (or, at index 0, the inner ray: pick < 0)
    in_fine = f2 > 0
    c_prev = np.maximum(f1 - 1, 0)
    f_prev = np.maximum(f2 - 1, 0)
    pick = np.where(in_fine, 0, f1 - 1)
    cand_e = np.where(in_fine, e2[rows, f_prev], e1[rows, c_prev])
    cand_t = np.where(in_fine, t2[rows, f_prev], t1[rows, c_prev])
    cand_tsb = np.where(in_fine, tsb2[rows, f_prev], tsb1[rows, c_prev])
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


class _Probe:
    """Casts refinement rays: candidate ``i`` of bracket ``b`` lies at elevation
    ``e_in[b] + (e_out[b] - e_in[b]) * i / REFINE_SPLIT`` in ``beam[b]``, at cast ``target[b]``."""

    def __init__(self, geo: PoseGeometry, casts: list[TargetCast], e_in: FloatArray, e_out: FloatArray,
                 beam: np.ndarray, target: np.ndarray):
        self.solids = [c.placed.solid for c in casts]
        # brackets ordered by kind of solid, so that intersect_batch slices instead of copying
        self.order = np.argsort(solid_kinds(self.solids)[target], kind="stable")
        self.back = np.argsort(self.order)
        o = self.order
        self.geo, self.e_in, self.span, self.beam, self.target = geo, e_in[o], (e_out - e_in)[o], beam[o], target[o]
        self.c_vec = np.array([c.seabed.c_vec for c in casts])
        self.height = np.array([c.seabed.height_m for c in casts])

    def __call__(self, index: np.ndarray) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray]:
        """(elevation, target hit, seabed hit, occluded) of candidates ``index`` (m, c)."""
        index = index[self.order]
        shape = index.shape
        cand = self.e_in[:, None] + self.span[:, None] * (index / REFINE_SPLIT)
        d = self.geo.directions(np.repeat(self.beam, shape[1]), cand.ravel())
        ray_target = np.repeat(self.target, shape[1])
        t, _ = intersect_batch(self.solids, ray_target, self.geo.origin_ned, d, normals=False)
        k = dot3(d, self.c_vec[ray_target])
        with np.errstate(divide="ignore"):
            tsb = np.where(k > 0, self.height[ray_target] / np.where(k > 0, k, 1.0), np.inf)
        b = self.back
        return cand[b], t.reshape(shape)[b], tsb.reshape(shape)[b], (t < tsb).reshape(shape)[b]


def no_runs() -> Runs:
    """The runs of a frame without targets."""
    i, f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return Runs(i, i, i, i, f, f, f, f, f, f, f)
