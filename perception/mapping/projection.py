"""Projecting a polar frame onto the mosaic grid (:mod:`perception.mapping.mosaic`).

Each frame is projected onto the seabed plane by *inverse* mapping: every mosaic cell in
the frame's footprint is traced back to the sonar (slant range, beam azimuth, elevation
within the vertical aperture) and the polar image is sampled there with :func:`perception.imaging.remap`. So
there are no holes between beams or range samples, whatever the resolution.

The weight favours well-insonified samples: the centre of the vertical beam (a cosine
taper towards the aperture edges), the centre of the fan, mid ranges, and steeper grazing
angles. Samples outside the beam, outside the window and under an exclusion mask (shadows
from the segmentation) carry no weight, so they never darken the average.

A second polar mask marks samples that belong in the map but not in the drift
registration: the echoes of raised targets, whose place on the seabed plane depends on
the view (layover), so two passes from opposite sides disagree about them by
``2 H h / g`` (height ``h``, altitude ``H``, ground range ``g``) -- 15 cm for a 15 cm
target seen from 1 m. :attr:`ProjectedFrame.reliable` carries the cells left to register.

A dive's frames share one geometry (range samples, beam azimuths, vertical aperture), so
what the projection derives from the axes alone (whether the samples are evenly spaced,
the float32 beam table, the footprint's bounding rays: :class:`FrameAxes`) is kept in a
small cache keyed on the axes' values (:func:`axes_of`): frames that arrive as fresh
arrays, from the map process's pipe, still share it. Each cached value is what the same
expression gave per frame, so the projection's results do not change by a bit. A frame
the builder projects twice (again after registration moved it) is read once
(:class:`FrameSamples`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from perception import imaging
from perception.errors import GeometryError
from perception.geometry import ray_direction_sonar, sonar_to_ned
from perception.mapping.mosaic import MosaicConfig, ProjectedFrame, SonarPlacement
from perception.sonar_io.frame import SonarFrame

#: Geometries kept (a dive has one; a recording or a test a few).
AXES_CACHE_SIZE = 8

#: Rays per side of the grid whose seabed hits bound the footprint (:func:`footprint_bounds`).
FOOTPRINT_RAYS = 24


@dataclass(frozen=True, eq=False)
class FrameAxes:
    """What the projection needs from one geometry (read-only arrays).

    Attributes
    ----------
    range_m : ndarray, float64, (n_samples,)
        The slant ranges.
    evenly_spaced : bool
        Whether the samples are evenly spaced (every sonar here): the row is then affine
        in the range, ``(range - first_range_f32) * inv_step_f32``.
    first_range_f32, inv_step_f32 : numpy.float32
    beams_f32 : ndarray, float32, (n_beams,)
        The beam azimuths as float32 (the column is interpolated in them).
    beam_index_f32 : ndarray, float32, (n_beams,)
        0, 1, ... n_beams - 1.
    half_fan_rad : float
        The largest |beam azimuth| (of the float32 table).
    footprint_rays : ndarray, float64, (FOOTPRINT_RAYS**2, 3)
        Sonar-frame unit rays over the fan's azimuths and the vertical aperture.
    """

    range_m: np.ndarray
    evenly_spaced: bool
    first_range_f32: np.float32
    inv_step_f32: np.float32
    beams_f32: np.ndarray
    beam_index_f32: np.ndarray
    half_fan_rad: float
    footprint_rays: np.ndarray


def axes_of(frame: SonarFrame) -> FrameAxes:
    """The (cached) :class:`FrameAxes` of ``frame``'s geometry."""
    ranges = np.asarray(frame.range_m, dtype=np.float64)
    beams = np.asarray(frame.beam_azimuth_rad, dtype=np.float64)
    return _axes(ranges.tobytes(), beams.tobytes(), float(frame.elevation_aperture_rad))


def _readonly(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@lru_cache(maxsize=AXES_CACHE_SIZE)
def _axes(range_bytes: bytes, beam_bytes: bytes, aperture_rad: float) -> FrameAxes:
    ranges = _readonly(np.frombuffer(range_bytes, dtype=np.float64).copy())
    beams64 = np.frombuffer(beam_bytes, dtype=np.float64)
    beams = _readonly(np.asarray(beams64, dtype=np.float32).copy())
    step = (ranges[-1] - ranges[0]) / (ranges.size - 1)
    evenly = bool(np.allclose(np.diff(ranges), step, rtol=1e-6, atol=0.0))
    half = aperture_rad / 2.0
    az = np.linspace(beams64[0], beams64[-1], FOOTPRINT_RAYS)
    el = np.linspace(-half, half, FOOTPRINT_RAYS)
    rays = _readonly(ray_direction_sonar(az[:, None], el[None, :]).reshape(-1, 3))
    return FrameAxes(
        range_m=ranges,
        evenly_spaced=evenly,
        first_range_f32=np.float32(ranges[0]),
        inv_step_f32=np.float32(1.0 / step),
        beams_f32=beams,
        beam_index_f32=_readonly(np.arange(beams.size, dtype=np.float32)),
        half_fan_rad=max(abs(float(beams[0])), abs(float(beams[-1]))),
        footprint_rays=rays,
    )


def footprint_bounds(
    axes: FrameAxes, rot: np.ndarray, *, north_m: float, east_m: float, altitude_m: float, n_samples: int
) -> tuple[float, float, float, float] | None:
    """(north_min, north_max, east_min, east_max) of the insonified seabed, or None.

    ``rot`` takes sonar-frame vectors to local NED; the sonar is at (``north_m``,
    ``east_m``), ``altitude_m`` above the seabed plane.
    """
    dirs = axes.footprint_rays @ rot.T
    down = dirs[:, 2]
    r0, r1 = float(axes.range_m[0]), float(axes.range_m[-1])
    hits = down > 1e-9
    if not np.any(hits):
        return None
    t = altitude_m / down[hits]
    t = np.clip(t, r0, r1)
    # Rays clipped by the window still bound the footprint: the window arcs lie between.
    # A ray clipped by the window ends above the seabed, horizontally beyond the seabed
    # points at that slant range, so the clipped points still bound the footprint.
    pts = dirs[hits] * t[:, None]
    north = pts[:, 0]
    east = pts[:, 1]
    pad = 2.0 * (r1 - r0) / n_samples + 0.02
    return (
        float(north.min()) + north_m - pad,
        float(north.max()) + north_m + pad,
        float(east.min()) + east_m - pad,
        float(east.max()) + east_m + pad,
    )


def _power(x: np.ndarray, exponent: float) -> np.ndarray:
    """``x ** exponent`` with the common exponents (1, 0.5, 2) done without ``pow``."""
    if exponent == 1.0:
        return x
    if exponent == 0.5:
        return np.sqrt(x)
    if exponent == 2.0:
        return x * x
    return np.power(x, np.float32(exponent))


@dataclass(frozen=True, eq=False)
class FrameSamples:
    """A frame's polar samples as the projection reads them, made once per frame
    (:func:`frame_samples`) and projected once or twice (:func:`project_samples`: the
    builder projects a frame again after registration moved it).

    ``image_f32`` is the image as float32; ``codes`` (uint8, the image's shape, or None
    without masks) holds bit 0 = excluded, bit 1 = unreliable.
    """

    frame: SonarFrame
    axes: FrameAxes
    image_f32: np.ndarray
    codes: np.ndarray | None


def frame_samples(frame: SonarFrame, *, exclude_mask: np.ndarray | None = None,
                  unreliable_mask: np.ndarray | None = None) -> FrameSamples:
    """The :class:`FrameSamples` of ``frame`` with its masks (as :func:`project_frame`)."""
    codes: np.ndarray | None = None
    for name, mask in (("exclude_mask", exclude_mask), ("unreliable_mask", unreliable_mask)):
        if mask is not None and mask.shape != frame.image.shape:
            raise ValueError(f"{name} shape {mask.shape} != image shape {frame.image.shape}")
    if exclude_mask is not None or unreliable_mask is not None:
        codes = np.zeros(frame.image.shape, dtype=np.uint8)
        if exclude_mask is not None:
            codes |= np.asarray(exclude_mask, dtype=bool).view(np.uint8)
        if unreliable_mask is not None:
            codes |= np.asarray(unreliable_mask, dtype=bool).view(np.uint8) << np.uint8(1)
    return FrameSamples(frame, axes_of(frame), np.asarray(frame.image, dtype=np.float32), codes)


def project_frame(
    frame: SonarFrame,
    placement: SonarPlacement,
    *,
    config: MosaicConfig,
    exclude_mask: np.ndarray | None = None,
    unreliable_mask: np.ndarray | None = None,
) -> ProjectedFrame | None:
    """Project one polar frame onto the seabed grid.

    Parameters
    ----------
    frame : SonarFrame
        The ping; its image (any accepted dtype) is sampled bilinearly.
    placement : SonarPlacement
        Pose of the sonar and the seabed plane depth.
    config : MosaicConfig
        Grid and weighting.
    exclude_mask : ndarray of bool, shape (n_samples, n_beams), optional
        Polar samples to leave out of the average (e.g. shadows); True = leave out.
    unreliable_mask : ndarray of bool, shape (n_samples, n_beams), optional
        Polar samples kept in the average but not in :attr:`ProjectedFrame.reliable`
        (raised targets' echoes, placed by layover); True = not for registration.

    Returns
    -------
    ProjectedFrame or None
        None when the frame sees no seabed.
    """
    check_altitude(placement)
    samples = frame_samples(frame, exclude_mask=exclude_mask, unreliable_mask=unreliable_mask)
    return project_samples(samples, placement, config=config)


def check_altitude(placement: SonarPlacement) -> None:
    """The GeometryError :func:`project_frame` raises first, for a sonar not above the seabed."""
    if placement.altitude_m <= 0:
        raise GeometryError(f"sonar altitude must be > 0 m, got {placement.altitude_m:.3f}")


#: Cells per block the projection works on at a time (rows of the footprint's box, cut
#: to the columns the fan can reach in those rows): a band of a few dozen rows of a
#: survey's footprint. A block's dozen float32 temporaries then stay within the core's
#: cache (whatever the footprint: a 30 m window at 1 cm would otherwise take hundreds of
#: MB), and each band is cut to its own rows' reach, so the cells outside the fan's wedge
#: but inside its box are not worked out (a third of the box's cells in a survey). On
#: the harbour-field-quarter dive this took the map process from 27.5-29.2 to 26.1-27.8
#: CPU s (its frames replayed alone on a quiet core: 4.5-5.3 to 3.6-4.0 s over the first
#: 700 batches; one block per footprint before, up to some 200 000 cells), the
#: projections bit for bit the same: every step is per cell.
BLOCK_CELLS = 1 << 15


def project_samples(samples: FrameSamples, placement: SonarPlacement, *,
                    config: MosaicConfig) -> ProjectedFrame | None:
    """:func:`project_frame` of a frame's :class:`FrameSamples` (the same result)."""
    check_altitude(placement)
    frame, axes = samples.frame, samples.axes
    rot = sonar_to_ned(
        tilt_rad=placement.tilt_rad,
        pitch_rad=placement.pitch_rad,
        roll_rad=placement.roll_rad,
        heading_rad=placement.heading_rad,
    )
    bounds = footprint_bounds(axes, rot, north_m=placement.north_m, east_m=placement.east_m,
                              altitude_m=placement.altitude_m, n_samples=frame.n_samples)
    if bounds is None:
        return None
    res = config.resolution_m
    row0 = math.floor(bounds[0] / res)
    row1 = math.ceil(bounds[1] / res)
    col0 = math.floor(bounds[2] / res)
    col1 = math.ceil(bounds[3] / res)
    north = ((np.arange(row0, row1, dtype=np.float64) + 0.5) * res - placement.north_m).astype(np.float32)
    east = ((np.arange(col0, col1, dtype=np.float64) + 0.5) * res - placement.east_m).astype(np.float32)
    # Vector from sonar to each cell's seabed point, in the sonar frame: v_s = R^T v.
    rt = rot.T.astype(np.float32)
    shape = (north.size, east.size)
    intensity = np.zeros(shape, dtype=np.float32)
    weight = np.zeros(shape, dtype=np.float32)
    unreliable = None if samples.codes is None else np.zeros(shape, dtype=bool)
    lo, hi = _reachable_columns(rot, north, east, placement.altitude_m, axes, res)
    step = max(1, BLOCK_CELLS // max(1, east.size))
    for r_lo in range(0, north.size, step):
        r_hi = min(r_lo + step, north.size)
        c_lo, c_hi = int(lo[r_lo:r_hi].min()), int(hi[r_lo:r_hi].max())
        if c_hi <= c_lo:
            continue
        block = (slice(r_lo, r_hi), slice(c_lo, c_hi))
        _project_block(samples, rt, north[r_lo:r_hi], east[c_lo:c_hi], placement.altitude_m, config,
                       intensity[block], weight[block], None if unreliable is None else unreliable[block])
    reliable = weight > 0
    if not np.any(reliable):
        return None
    intensity[~reliable] = 0.0
    if unreliable is not None:
        reliable &= ~unreliable
    return ProjectedFrame(row0, col0, intensity, weight, reliable)


def _reachable_columns(rot: np.ndarray, north: np.ndarray, east: np.ndarray, altitude_m: float, axes: FrameAxes,
                       res: float) -> tuple[np.ndarray, np.ndarray]:
    """Per row of the box, the columns [lo, hi) outside which no cell can be in the fan:
    beyond the last range, or outside the beams' azimuths (widened by a milliradian and
    two cells, far more than float32 rounding moves an edge). A cell outside them would
    get no weight, so leaving it out changes nothing."""
    n = north.astype(np.float64)
    e0 = float(east[0])
    reach = float(axes.range_m[-1]) * 1.001 + 2.0 * res
    room = reach * reach - n * n - altitude_m * altitude_m
    half = np.sqrt(np.maximum(room, 0.0))
    e_lo, e_hi = np.where(room >= 0, -half, np.inf), np.where(room >= 0, half, -np.inf)
    # sonar-frame forward and starboard components along a row: x = a + b e, y = c + d e
    rt = rot.T
    a = rt[0, 0] * n + rt[0, 2] * altitude_m
    c = rt[1, 0] * n + rt[1, 2] * altitude_m
    b, d = float(rt[0, 1]), float(rt[1, 1])
    first, last = float(axes.beams_f32[0]) - 1e-3, float(axes.beams_f32[-1]) + 1e-3
    # y - tan(first) x >= 0 and tan(last) x - y >= 0 (both imply x > 0 in the fan)
    for const, slope in ((c - math.tan(first) * a, d - math.tan(first) * b),
                         (math.tan(last) * a - c, math.tan(last) * b - d)):
        if abs(slope) < 1e-12:
            e_lo = np.where(const >= 0, e_lo, np.inf)
            continue
        edge = -const / slope
        if slope > 0:
            e_lo = np.maximum(e_lo, edge)
        else:
            e_hi = np.minimum(e_hi, edge)
    with np.errstate(invalid="ignore"):
        lo = np.floor((e_lo - e0) / res) - 2
        hi = np.ceil((e_hi - e0) / res) + 3
    lo = np.clip(np.nan_to_num(lo, nan=0.0, posinf=east.size, neginf=0.0), 0, east.size).astype(np.int64)
    hi = np.clip(np.nan_to_num(hi, nan=east.size, posinf=east.size, neginf=0.0), 0, east.size).astype(np.int64)
    return lo, hi


def _project_block(samples: FrameSamples, rt: np.ndarray, north: np.ndarray, east: np.ndarray, down: float,
                   config: MosaicConfig, intensity: np.ndarray, weight: np.ndarray,
                   unreliable: np.ndarray | None) -> None:
    """The cells (``north`` x ``east`` offsets from the sonar, float32) of one block, written
    into the block's views of the frame's ``intensity``, ``weight`` and ``unreliable``.
    Every step is float32 and elementwise (the in-place forms keep each value), so a cell's
    result does not depend on the block it is worked out in."""
    frame, axes = samples.frame, samples.axes
    f32 = np.float32
    vx = rt[0, 0] * north[:, None] + (rt[0, 1] * east + f32(rt[0, 2] * down))[None, :]
    vy = rt[1, 0] * north[:, None] + (rt[1, 1] * east + f32(rt[1, 2] * down))[None, :]
    vz = rt[2, 0] * north[:, None] + (rt[2, 1] * east + f32(rt[2, 2] * down))[None, :]
    horiz = vx * vx
    horiz += vy * vy
    np.sqrt(horiz, out=horiz)
    rng = horiz * horiz
    rng += vz * vz
    np.sqrt(rng, out=rng)
    azimuth = np.arctan2(vy, vx)
    n_samples = axes.range_m.size
    if axes.evenly_spaced:
        # evenly spaced samples (every sonar here): the row is affine in the range
        # (rows beyond the window are not clipped: such a cell is outside, and what the
        # remap reads for it is never kept)
        map_row = rng - axes.first_range_f32
        map_row *= axes.inv_step_f32
    else:
        map_row = np.interp(rng.ravel(), axes.range_m, np.arange(n_samples, dtype=np.float64), left=-1,
                            right=-1).reshape(rng.shape).astype(np.float32)
    map_col = np.interp(azimuth.ravel(), axes.beams_f32, axes.beam_index_f32, left=-1, right=-1)
    map_col = map_col.reshape(rng.shape).astype(np.float32)
    block_intensity = imaging.remap(samples.image_f32, map_col, map_row, nearest=False)
    half = frame.elevation_aperture_rad / 2.0
    # |elevation| / half, from tan(elevation) = vz / horiz
    e_frac = np.maximum(horiz, f32(1e-9))
    np.divide(vz, e_frac, out=e_frac)
    np.arctan(e_frac, out=e_frac)
    np.abs(e_frac, out=e_frac)
    e_frac *= f32(1.0 / half)
    inside = (map_row >= 0) & (map_row <= n_samples - 1) & (map_col >= 0) & (e_frac <= 1.0)
    # Grazing angle on a horizontal seabed: the depression of the ray, sin = down / range.
    w = np.maximum(rng, f32(1e-6))
    np.divide(f32(down), w, out=w)  # sin of the grazing angle
    inside &= w >= math.sin(config.min_grazing_rad)
    if config.beam_taper_power:
        e_taper = np.minimum(e_frac, f32(1.0))
        e_taper *= f32(math.pi / 2)
        np.cos(e_taper, out=e_taper)
        np.maximum(e_taper, f32(1e-3), out=e_taper)
        w *= _power(e_taper, config.beam_taper_power)
    if config.fan_taper_power:
        a_taper = np.abs(azimuth)
        a_taper *= f32(1.0 / (axes.half_fan_rad * 1.05))
        np.minimum(a_taper, f32(1.0), out=a_taper)
        a_taper *= f32(math.pi / 2)
        np.cos(a_taper, out=a_taper)
        np.maximum(a_taper, f32(1e-3), out=a_taper)
        w *= _power(a_taper, config.fan_taper_power)
    if samples.codes is not None and unreliable is not None:
        # One nearest-neighbour remap of the code image: bit 0 = excluded, bit 1 = unreliable.
        cell_codes = np.asarray(imaging.remap(samples.codes, map_col, map_row, nearest=True), dtype=np.uint8)
        inside &= (cell_codes & 1) == 0
        np.greater(cell_codes & 2, 0, out=unreliable)
    np.multiply(w, inside, out=weight)
    intensity[...] = block_intensity
