"""Incremental, tiled seabed mosaic from forward-looking sonar frames.

Each frame is projected onto the seabed plane by *inverse* mapping: every mosaic cell in
the frame's footprint is traced back to the sonar (slant range, beam azimuth, elevation
within the vertical aperture) and the polar image is sampled there with :func:`perception.imaging.remap`. So
there are no holes between beams or range samples, whatever the resolution.

Cells are blended by a weighted mean. The weight favours well-insonified samples: the
centre of the vertical beam (a cosine taper towards the aperture edges), the centre of the
fan, mid ranges, and steeper grazing angles. Samples outside the beam, outside the window
and under an exclusion mask (shadows from the segmentation) carry no weight, so they
never darken the average.

A second polar mask marks samples that belong in the map but not in the drift
registration: the echoes of raised targets, whose place on the seabed plane depends on
the view (layover), so two passes from opposite sides disagree about them by
``2 H h / g`` (height ``h``, altitude ``H``, ground range ``g``) -- 15 cm for a 15 cm
target seen from 1 m. :attr:`ProjectedFrame.reliable` carries the cells left to register.

The mosaic grid is anchored to the survey's local NED origin: cell ``(i, j)`` of tile
``(ti, tj)`` covers north ``[(ti*T + i) * res, (ti*T + i + 1) * res)`` and likewise east,
with ``T`` the tile size in cells. Tiles are created where frames fall; adding a frame
touches only the tiles under its footprint, so its cost does not grow with the mosaic.
Rows increase NORTH inside tiles; exports flip them so that north is up.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from perception import imaging
from perception.errors import GeometryError
from perception.geometry import ray_direction_sonar, sonar_to_ned
from perception.sonar_io.frame import SonarFrame


@dataclass(frozen=True)
class MosaicConfig:
    """Settings of a mosaic.

    Attributes
    ----------
    resolution_m : float
        Cell size, m.
    tile_cells : int
        Tile edge in cells.
    beam_taper_power : float
        Weight ``cos(pi/2 * e / (aperture/2)) ** power`` over the elevation ``e`` inside the
        vertical aperture (0 = flat).
    fan_taper_power : float
        The same across the fan in azimuth.
    min_grazing_rad : float
        Samples whose grazing angle on the seabed is below this carry no weight.
    """

    resolution_m: float = 0.01
    tile_cells: int = 256
    beam_taper_power: float = 1.0
    fan_taper_power: float = 0.5
    min_grazing_rad: float = math.radians(3.0)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution_m) and self.resolution_m > 0):
            raise ValueError(f"resolution_m must be > 0, got {self.resolution_m!r}")
        if self.tile_cells < 16:
            raise ValueError(f"tile_cells must be >= 16, got {self.tile_cells!r}")


@dataclass(frozen=True)
class SonarPlacement:
    """Where a frame was taken, in local NED, with the seabed below.

    ``seabed_depth_m`` is the depth of the (horizontal) seabed plane, so the sonar's
    altitude is ``seabed_depth_m - sonar_depth_m``.
    """

    north_m: float
    east_m: float
    sonar_depth_m: float
    seabed_depth_m: float
    heading_rad: float
    pitch_rad: float
    roll_rad: float
    tilt_rad: float

    @property
    def altitude_m(self) -> float:
        """Sonar height above the seabed plane, m."""
        return self.seabed_depth_m - self.sonar_depth_m

    def shifted(self, d_north_m: float, d_east_m: float) -> SonarPlacement:
        """The same placement moved horizontally."""
        return SonarPlacement(
            self.north_m + d_north_m,
            self.east_m + d_east_m,
            self.sonar_depth_m,
            self.seabed_depth_m,
            self.heading_rad,
            self.pitch_rad,
            self.roll_rad,
            self.tilt_rad,
        )


def placement_from_frame(frame: SonarFrame, *, altitude_m: float | None = None) -> SonarPlacement:
    """The placement a frame's own metadata gives (altitude may be overridden by the filter).

    Raises
    ------
    GeometryError
        When position, heading, tilt or altitude are unknown. Pitch and roll default to 0.
    """
    alt = frame.altitude_m if altitude_m is None else float(altitude_m)
    missing = [
        name
        for name, value in (
            ("north_m", frame.north_m),
            ("east_m", frame.east_m),
            ("heading_deg", frame.heading_rad),
            ("tilt_deg", frame.tilt_rad),
            ("altitude_m", alt),
        )
        if math.isnan(value)
    ]
    if missing:
        raise GeometryError(f"frame at t={frame.timestamp_s:.3f} s lacks {', '.join(missing)} for mosaicking")
    depth = 0.0 if math.isnan(frame.sonar_depth_m) else frame.sonar_depth_m
    pitch = 0.0 if math.isnan(frame.vehicle_pitch_rad) else frame.vehicle_pitch_rad
    roll = 0.0 if math.isnan(frame.vehicle_roll_rad) else frame.vehicle_roll_rad
    return SonarPlacement(
        frame.north_m, frame.east_m, depth, depth + alt, frame.heading_rad, pitch, roll, frame.tilt_rad
    )


@dataclass(frozen=True)
class ProjectedFrame:
    """A frame projected onto the mosaic grid.

    ``row0``/``col0`` are the global cell indices (north, east) of element ``[0, 0]``;
    ``intensity`` and ``weight`` have shape (n_north, n_east), rows increasing north.
    ``reliable`` (bool, same shape) marks the weighted cells that show the seabed itself
    (not a raised target's echo): the ones drift registration may use.
    """

    row0: int
    col0: int
    intensity: np.ndarray
    weight: np.ndarray
    reliable: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(n_north, n_east) cells."""
        return (int(self.intensity.shape[0]), int(self.intensity.shape[1]))


def _footprint_bounds(
    frame: SonarFrame, placement: SonarPlacement, rot: np.ndarray
) -> tuple[float, float, float, float] | None:
    """(north_min, north_max, east_min, east_max) of the insonified seabed, or None."""
    half = frame.elevation_aperture_rad / 2.0
    az = np.linspace(frame.beam_azimuth_rad[0], frame.beam_azimuth_rad[-1], 24)
    el = np.linspace(-half, half, 24)
    dirs = ray_direction_sonar(az[:, None], el[None, :]).reshape(-1, 3) @ rot.T
    alt = placement.altitude_m
    down = dirs[:, 2]
    r0, r1 = frame.window_m
    hits = down > 1e-9
    if not np.any(hits):
        return None
    t = alt / down[hits]
    t = np.clip(t, r0, r1)
    # Rays clipped by the window still bound the footprint: the window arcs lie between.
    # A ray clipped by the window ends above the seabed, horizontally beyond the seabed
    # points at that slant range, so the clipped points still bound the footprint.
    pts = dirs[hits] * t[:, None]
    north = pts[:, 0]
    east = pts[:, 1]
    pad = 2.0 * (r1 - r0) / frame.n_samples + 0.02
    return (
        float(north.min()) + placement.north_m - pad,
        float(north.max()) + placement.north_m + pad,
        float(east.min()) + placement.east_m - pad,
        float(east.max()) + placement.east_m + pad,
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
    if placement.altitude_m <= 0:
        raise GeometryError(f"sonar altitude must be > 0 m, got {placement.altitude_m:.3f}")
    for name, mask in (("exclude_mask", exclude_mask), ("unreliable_mask", unreliable_mask)):
        if mask is not None and mask.shape != frame.image.shape:
            raise ValueError(f"{name} shape {mask.shape} != image shape {frame.image.shape}")
    rot = sonar_to_ned(
        tilt_rad=placement.tilt_rad,
        pitch_rad=placement.pitch_rad,
        roll_rad=placement.roll_rad,
        heading_rad=placement.heading_rad,
    )
    bounds = _footprint_bounds(frame, placement, rot)
    if bounds is None:
        return None
    res = config.resolution_m
    row0 = math.floor(bounds[0] / res)
    row1 = math.ceil(bounds[1] / res)
    col0 = math.floor(bounds[2] / res)
    col1 = math.ceil(bounds[3] / res)
    north = ((np.arange(row0, row1, dtype=np.float64) + 0.5) * res - placement.north_m).astype(np.float32)
    east = ((np.arange(col0, col1, dtype=np.float64) + 0.5) * res - placement.east_m).astype(np.float32)
    down = placement.altitude_m
    # Vector from sonar to each cell's seabed point, in the sonar frame: v_s = R^T v.
    rt = rot.T.astype(np.float32)
    f32 = np.float32
    vx = rt[0, 0] * north[:, None] + (rt[0, 1] * east + f32(rt[0, 2] * down))[None, :]
    vy = rt[1, 0] * north[:, None] + (rt[1, 1] * east + f32(rt[1, 2] * down))[None, :]
    vz = rt[2, 0] * north[:, None] + (rt[2, 1] * east + f32(rt[2, 2] * down))[None, :]
    horiz = np.sqrt(vx * vx + vy * vy)
    rng = np.sqrt(horiz * horiz + vz * vz)
    azimuth = np.arctan2(vy, vx)
    ranges = np.asarray(frame.range_m, dtype=np.float64)
    beams = np.asarray(frame.beam_azimuth_rad, dtype=np.float32)
    step = (ranges[-1] - ranges[0]) / (ranges.size - 1)
    if np.allclose(np.diff(ranges), step, rtol=1e-6, atol=0.0):
        # evenly spaced samples (every sonar here): the row is affine in the range
        map_row = (rng - f32(ranges[0])) * f32(1.0 / step)
        map_row[(map_row < 0) | (map_row > ranges.size - 1)] = -1.0
    else:
        map_row = np.interp(rng.ravel(), ranges, np.arange(ranges.size, dtype=np.float64), left=-1,
                            right=-1).reshape(rng.shape).astype(np.float32)
    map_col = np.interp(azimuth.ravel(), beams, np.arange(beams.size, dtype=np.float32), left=-1, right=-1)
    map_col = map_col.reshape(rng.shape).astype(np.float32)
    image = np.asarray(frame.image, dtype=np.float32)
    intensity = imaging.remap(image, map_col, map_row, nearest=False)
    half = frame.elevation_aperture_rad / 2.0
    half_fan = max(abs(float(beams[0])), abs(float(beams[-1])))
    # |elevation| / half, from tan(elevation) = vz / horiz
    e_frac = np.abs(np.arctan(vz / np.maximum(horiz, f32(1e-9)))) * f32(1.0 / half)
    inside = (map_row >= 0) & (map_col >= 0) & (e_frac <= 1.0)
    # Grazing angle on a horizontal seabed: the depression of the ray, sin = down / range.
    sin_grazing = f32(down) / np.maximum(rng, f32(1e-6))
    inside &= sin_grazing >= math.sin(config.min_grazing_rad)
    weight = np.zeros(rng.shape, dtype=np.float32)
    w = sin_grazing
    if config.beam_taper_power:
        e_taper = np.maximum(np.cos(np.minimum(e_frac, f32(1.0)) * f32(math.pi / 2)), f32(1e-3))
        w = w * _power(e_taper, config.beam_taper_power)
    if config.fan_taper_power:
        a_frac = np.minimum(np.abs(azimuth) * f32(1.0 / (half_fan * 1.05)), f32(1.0))
        a_taper = np.maximum(np.cos(a_frac * f32(math.pi / 2)), f32(1e-3))
        w = w * _power(a_taper, config.fan_taper_power)
    weight[inside] = w[inside]
    unreliable: np.ndarray | None = None
    if exclude_mask is not None or unreliable_mask is not None:
        # One nearest-neighbour remap of a code image: bit 0 = excluded, bit 1 = unreliable.
        codes = np.zeros(frame.image.shape, dtype=np.uint8)
        if exclude_mask is not None:
            codes[exclude_mask] = 1
        if unreliable_mask is not None:
            codes[unreliable_mask] |= 2
        cell_codes = np.asarray(imaging.remap(codes, map_col, map_row, nearest=True), dtype=np.uint8)
        weight[(cell_codes & 1) > 0] = 0.0
        unreliable = (cell_codes & 2) > 0
    intensity[weight == 0] = 0.0
    if not np.any(weight > 0):
        return None
    reliable = weight > 0
    if unreliable is not None:
        reliable &= ~unreliable
    return ProjectedFrame(row0, col0, intensity, weight, reliable)


class TiledMosaic:
    """A weighted-mean mosaic kept in fixed-size tiles.

    Use :meth:`add` for each projected frame; :meth:`raster` or :meth:`window` to read it.
    """

    def __init__(self, config: MosaicConfig | None = None):
        self.config = config or MosaicConfig()
        self._sum_wi: dict[tuple[int, int], np.ndarray] = {}
        self._sum_w: dict[tuple[int, int], np.ndarray] = {}
        self.frames_added = 0

    @property
    def tile_count(self) -> int:
        """Number of tiles holding data."""
        return len(self._sum_w)

    def _tiles_over(self, row0: int, col0: int, n_rows: int, n_cols: int) -> Iterator[
        tuple[tuple[int, int], slice, slice, slice, slice]
    ]:
        t = self.config.tile_cells
        for ti in range(row0 // t, (row0 + n_rows - 1) // t + 1):
            for tj in range(col0 // t, (col0 + n_cols - 1) // t + 1):
                r_lo = max(row0, ti * t)
                r_hi = min(row0 + n_rows, (ti + 1) * t)
                c_lo = max(col0, tj * t)
                c_hi = min(col0 + n_cols, (tj + 1) * t)
                yield (
                    (ti, tj),
                    slice(r_lo - ti * t, r_hi - ti * t),
                    slice(c_lo - tj * t, c_hi - tj * t),
                    slice(r_lo - row0, r_hi - row0),
                    slice(c_lo - col0, c_hi - col0),
                )

    def add(self, projected: ProjectedFrame) -> None:
        """Blend a projected frame in (cost proportional to its footprint only)."""
        t = self.config.tile_cells
        wi = projected.intensity * projected.weight
        for key, tr, tc, pr, pc in self._tiles_over(projected.row0, projected.col0, *projected.shape):
            if key not in self._sum_w:
                self._sum_w[key] = np.zeros((t, t), dtype=np.float32)
                self._sum_wi[key] = np.zeros((t, t), dtype=np.float32)
            self._sum_w[key][tr, tc] += projected.weight[pr, pc]
            self._sum_wi[key][tr, tc] += wi[pr, pc]
        self.frames_added += 1

    def window(self, row0: int, col0: int, n_rows: int, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
        """(mean intensity, total weight) over a block of cells, rows increasing north.

        Cells never covered have mean 0 and weight 0.
        """
        mean = np.zeros((n_rows, n_cols), dtype=np.float32)
        weight = np.zeros((n_rows, n_cols), dtype=np.float32)
        for key, tr, tc, pr, pc in self._tiles_over(row0, col0, n_rows, n_cols):
            if key in self._sum_w:
                weight[pr, pc] = self._sum_w[key][tr, tc]
                mean[pr, pc] = self._sum_wi[key][tr, tc]
        np.divide(mean, weight, out=mean, where=weight > 0)
        return mean, weight

    def extent_cells(self) -> tuple[int, int, int, int]:
        """(row0, col0, n_rows, n_cols) of the tiles holding data.

        Raises
        ------
        ValueError
            When the mosaic is empty.
        """
        if not self._sum_w:
            raise ValueError("the mosaic is empty: no frame has been added")
        t = self.config.tile_cells
        rows = [k[0] for k in self._sum_w]
        cols = [k[1] for k in self._sum_w]
        return min(rows) * t, min(cols) * t, (max(rows) - min(rows) + 1) * t, (max(cols) - min(cols) + 1) * t

    def raster(self) -> tuple[np.ndarray, np.ndarray, int, int]:
        """The whole mosaic: (mean, weight, row0, col0), rows increasing north."""
        row0, col0, n_rows, n_cols = self.extent_cells()
        mean, weight = self.window(row0, col0, n_rows, n_cols)
        return mean, weight, row0, col0
