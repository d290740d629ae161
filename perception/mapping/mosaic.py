"""Incremental, tiled seabed mosaic from forward-looking sonar frames: the grid, the
placement of a frame on it, and the blend.

Frames come onto the grid through :mod:`perception.mapping.projection` (inverse mapping,
weights, masks) as :class:`ProjectedFrame`; cells are blended by a weighted mean.
:attr:`ProjectedFrame.reliable` carries the cells drift registration may use (not raised
targets' echoes, which move with the view).

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

from perception.errors import GeometryError
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
        self.add_sums(projected.row0, projected.col0, projected.weight, projected.intensity * projected.weight)

    def add_sums(self, row0: int, col0: int, weight: np.ndarray, weighted_intensity: np.ndarray) -> None:
        """Blend in a frame given as its weights and weight x intensity (float32, one
        shape), element ``[0, 0]`` at global cell (``row0``, ``col0``): :meth:`add`
        without forming the product again."""
        t = self.config.tile_cells
        for key, tr, tc, pr, pc in self._tiles_over(row0, col0, int(weight.shape[0]), int(weight.shape[1])):
            if key not in self._sum_w:
                self._sum_w[key] = np.zeros((t, t), dtype=np.float32)
                self._sum_wi[key] = np.zeros((t, t), dtype=np.float32)
            self._sum_w[key][tr, tc] += weight[pr, pc]
            self._sum_wi[key][tr, tc] += weighted_intensity[pr, pc]
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
