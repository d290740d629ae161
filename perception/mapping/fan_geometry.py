"""The geometry of a fan (Cartesian, top-down) sonar image: pixel grid, apex and extent
(see :mod:`perception.mapping.fan` for the conventions)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import GeometryError
from perception.sonar_io.frame import SonarFrame

FloatArray = NDArray[np.float64]

#: Cached map sets (one per geometry and interpolation).
MAP_CACHE_SIZE = 8


#: Relative widening of the fan's edges in :meth:`FanGeometry.inside` (rounding slack).
EDGE_TOLERANCE = 1e-12


def axis_values(values: ArrayLike, name: str) -> np.ndarray:
    array = np.array(values, dtype=np.float64)
    if array.ndim != 1 or array.size < 2:
        raise GeometryError(f"{name} must be 1-D with >= 2 entries, got shape {array.shape}")
    if not np.all(np.isfinite(array)) or not np.all(np.diff(array) > 0):
        raise GeometryError(f"{name} must be finite and strictly increasing")
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class FanGeometry:
    """The pixel grid of a fan image for one polar geometry.

    Build it with :func:`fan_geometry` (pixel size or output width) or
    :meth:`from_frame`. Equal geometries compare and hash equal, so the remap maps are
    shared between frames of one geometry.

    Attributes
    ----------
    range_m : ndarray, shape (n_samples,)
        Slant range of each polar row, m, strictly increasing (read-only copy).
    beam_azimuth_rad : ndarray, shape (n_beams,)
        Azimuth of each polar column, rad, positive to starboard, strictly increasing,
        within (-pi/2, pi/2) (read-only copy).
    pixel_size_m : float
        Side of a square fan pixel, m.
    include_origin : bool
        Whether the image extends down to the sonar (range zero inside the image).
    n_rows, n_cols : int
        Fan image shape.
    origin_row, origin_col : float
        Pixel coordinates of the sonar (range zero), usually outside the image.
    """

    range_m: np.ndarray = field(repr=False)
    beam_azimuth_rad: np.ndarray = field(repr=False)
    pixel_size_m: float
    include_origin: bool = False
    n_rows: int = field(init=False)
    n_cols: int = field(init=False)
    origin_row: float = field(init=False)
    origin_col: float = field(init=False)
    _key: tuple[Any, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        rng = axis_values(self.range_m, "range_m")
        az = axis_values(self.beam_azimuth_rad, "beam_azimuth_rad")
        if rng[0] < 0:
            raise GeometryError(f"range_m must be >= 0, first is {rng[0]}")
        if np.any(np.abs(az) >= math.pi / 2):
            raise GeometryError("beam azimuths must lie within (-pi/2, pi/2) rad")
        px = float(self.pixel_size_m)
        if not (math.isfinite(px) and px > 0):
            raise GeometryError(f"pixel_size_m must be finite and > 0, got {self.pixel_size_m!r}")
        x_min, x_max, y_min, y_max = fan_extent(rng, az, include_origin=self.include_origin)
        n_cols = max(1, math.ceil((y_max - y_min) / px - 1e-9))
        n_rows = max(1, math.ceil((x_max - x_min) / px - 1e-9))
        if n_rows * n_cols > 64_000_000 or max(n_rows, n_cols) > 32_000:
            raise GeometryError(
                f"fan image of {n_rows} x {n_cols} pixels is too large; use a larger pixel_size_m than {px} m"
            )
        set_ = object.__setattr__
        set_(self, "range_m", rng)
        set_(self, "beam_azimuth_rad", az)
        set_(self, "pixel_size_m", px)
        set_(self, "include_origin", bool(self.include_origin))
        set_(self, "n_rows", n_rows)
        set_(self, "n_cols", n_cols)
        set_(self, "origin_row", float(x_max / px - 0.5))
        set_(self, "origin_col", float(-y_min / px - 0.5))
        set_(self, "_key", (rng.tobytes(), az.tobytes(), px, self.include_origin))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FanGeometry):
            return NotImplemented
        return self._key == other._key

    def __hash__(self) -> int:
        return hash(self._key)

    @classmethod
    def from_frame(
        cls,
        frame: SonarFrame,
        *,
        pixel_size_m: float | None = None,
        width_px: int | None = None,
        include_origin: bool = False,
    ) -> FanGeometry:
        """The fan geometry of a sonar frame's range samples and beam azimuths."""
        return fan_geometry(
            frame.range_m,
            frame.beam_azimuth_rad,
            pixel_size_m=pixel_size_m,
            width_px=width_px,
            include_origin=include_origin,
        )

    @property
    def shape(self) -> tuple[int, int]:
        """Fan image shape (n_rows, n_cols)."""
        return self.n_rows, self.n_cols

    @property
    def polar_shape(self) -> tuple[int, int]:
        """Polar image shape (n_samples, n_beams) this geometry converts."""
        return int(self.range_m.size), int(self.beam_azimuth_rad.size)

    def pixel_to_xy_m(self, row: ArrayLike, col: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Fan pixel coordinates -> (forward, starboard) position from the sonar, m."""
        r = np.asarray(row, dtype=np.float64)
        c = np.asarray(col, dtype=np.float64)
        return (self.origin_row - r) * self.pixel_size_m, (c - self.origin_col) * self.pixel_size_m

    def xy_m_to_pixel(self, x_m: ArrayLike, y_m: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """(forward, starboard) position from the sonar, m -> fan pixel (row, col)."""
        x = np.asarray(x_m, dtype=np.float64)
        y = np.asarray(y_m, dtype=np.float64)
        return self.origin_row - x / self.pixel_size_m, self.origin_col + y / self.pixel_size_m

    def pixel_to_polar(self, row: ArrayLike, col: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Fan pixel coordinates -> (slant range from range zero m, azimuth rad).

        Defined everywhere (also outside the fan); see :meth:`inside` for the fan itself.
        """
        x, y = self.pixel_to_xy_m(row, col)
        return np.hypot(x, y), np.arctan2(y, x)

    def polar_to_pixel(self, range_m: ArrayLike, azimuth_rad: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """(slant range m, azimuth rad) -> fan pixel coordinates (row, col), floats."""
        r = np.asarray(range_m, dtype=np.float64)
        a = np.asarray(azimuth_rad, dtype=np.float64)
        return self.xy_m_to_pixel(r * np.cos(a), r * np.sin(a))

    def inside(self, range_m: ArrayLike, azimuth_rad: ArrayLike) -> NDArray[np.bool_]:
        """True where (range, azimuth) lies inside the fan (sample and beam centre span).

        The edges are widened by ``EDGE_TOLERANCE`` (relative) so that rounding in a
        round trip does not move an edge sample or beam outside.
        """
        r = np.asarray(range_m, dtype=np.float64)
        a = np.asarray(azimuth_rad, dtype=np.float64)
        rng, az = self.range_m, self.beam_azimuth_rad
        tol_r = EDGE_TOLERANCE * float(rng[-1])
        tol_a = EDGE_TOLERANCE * math.pi
        return (r >= rng[0] - tol_r) & (r <= rng[-1] + tol_r) & (a >= az[0] - tol_a) & (a <= az[-1] + tol_a)

    def pixel_to_sample_beam(self, row: ArrayLike, col: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Fan pixel -> fractional (sample, beam) index of the polar image; NaN outside."""
        r, a = self.pixel_to_polar(row, col)
        return self.polar_to_sample_beam(r, a)

    def polar_to_sample_beam(self, range_m: ArrayLike, azimuth_rad: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """(range m, azimuth rad) -> fractional (sample, beam) index; NaN outside the fan.

        Interpolates the (possibly non-uniform) range and azimuth tables.
        """
        r = np.asarray(range_m, dtype=np.float64)
        a = np.asarray(azimuth_rad, dtype=np.float64)
        ok = self.inside(r, a)
        sample = np.interp(r, self.range_m, np.arange(self.range_m.size, dtype=np.float64))
        beam = np.interp(a, self.beam_azimuth_rad, np.arange(self.beam_azimuth_rad.size, dtype=np.float64))
        return np.where(ok, sample, np.nan), np.where(ok, beam, np.nan)

    def sample_beam_to_pixel(self, sample: ArrayLike, beam: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Fractional (sample, beam) index of the polar image -> fan pixel (row, col).

        NaN for indices outside ``[0, n - 1]``.
        """
        s = np.asarray(sample, dtype=np.float64)
        b = np.asarray(beam, dtype=np.float64)
        n_s, n_b = self.polar_shape
        ok = (s >= 0) & (s <= n_s - 1) & (b >= 0) & (b <= n_b - 1)
        r = np.interp(s, np.arange(n_s, dtype=np.float64), self.range_m)
        a = np.interp(b, np.arange(n_b, dtype=np.float64), self.beam_azimuth_rad)
        row, col = self.polar_to_pixel(r, a)
        return np.where(ok, row, np.nan), np.where(ok, col, np.nan)

    def inside_mask(self) -> NDArray[np.bool_]:
        """Boolean image, shape (n_rows, n_cols): True for pixels inside the fan."""
        return ~np.isnan(float_maps(self)[0])


def fan_geometry(
    range_m: ArrayLike,
    beam_azimuth_rad: ArrayLike,
    *,
    pixel_size_m: float | None = None,
    width_px: int | None = None,
    include_origin: bool = False,
) -> FanGeometry:
    """A fan geometry from the polar axes and either a pixel size or an output width.

    Parameters
    ----------
    range_m : array_like, shape (n_samples,)
        Slant range of each polar row from range zero, m, strictly increasing.
    beam_azimuth_rad : array_like, shape (n_beams,)
        Beam azimuths, rad, positive to starboard, strictly increasing (any spacing).
    pixel_size_m : float, optional
        Fan pixel side, m.
    width_px : int, optional
        Fan image width in pixels; the pixel size then spans the fan's width exactly.
    include_origin : bool
        Extend the image down to the sonar so the apex lies inside it.

    Raises
    ------
    GeometryError
        Unless exactly one of ``pixel_size_m`` and ``width_px`` is given, or for bad axes.
    """
    if (pixel_size_m is None) == (width_px is None):
        raise GeometryError("give exactly one of pixel_size_m and width_px")
    if pixel_size_m is not None:
        size_m = float(pixel_size_m)
    elif width_px is not None:
        if int(width_px) != width_px or width_px < 1:
            raise GeometryError(f"width_px must be a positive integer, got {width_px!r}")
        rng = axis_values(range_m, "range_m")
        az = axis_values(beam_azimuth_rad, "beam_azimuth_rad")
        _, _, y_min, y_max = fan_extent(rng, az, include_origin=include_origin)
        size_m = (y_max - y_min) / int(width_px)
    else:
        raise GeometryError("give exactly one of pixel_size_m and width_px")
    return FanGeometry(
        np.asarray(range_m, dtype=np.float64),
        np.asarray(beam_azimuth_rad, dtype=np.float64),
        size_m,
        include_origin,
    )


def fan_extent(
    range_m: np.ndarray, azimuth_rad: np.ndarray, *, include_origin: bool
) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) of the fan region, m (x forward, y starboard)."""
    r0, r1 = float(range_m[0]), float(range_m[-1])
    a0, a1 = float(azimuth_rad[0]), float(azimuth_rad[-1])
    radii = np.array([r0, r0, r1, r1])
    angles = np.array([a0, a1, a0, a1])
    xs = list(radii * np.cos(angles))
    ys = list(radii * np.sin(angles))
    if a0 <= 0 <= a1:
        xs.append(r1)
    if include_origin:
        xs.append(0.0)
        ys.append(0.0)
    return min(xs), max(xs), min(ys), max(ys)


@lru_cache(maxsize=MAP_CACHE_SIZE)
def float_maps(geometry: FanGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Fractional (sample, beam) index of every fan pixel, float32, NaN outside the fan."""
    rows = np.arange(geometry.n_rows, dtype=np.float64)[:, None]
    cols = np.arange(geometry.n_cols, dtype=np.float64)[None, :]
    sample, beam = geometry.pixel_to_sample_beam(rows, cols)
    sample_f = sample.astype(np.float32)
    beam_f = beam.astype(np.float32)
    sample_f.flags.writeable = False
    beam_f.flags.writeable = False
    return sample_f, beam_f
