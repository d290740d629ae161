"""A persistent seabed reflectivity texture, fixed in world (north, east) coordinates.

Real seabeds carry a reflectivity pattern that stays put from ping to ping (sand ripples,
shell patches, mud): it is what lets successive frames be registered to each other. The
texture is a multiplicative gain on the seabed's backscatter, log-normal:

    gain(n, e) = 10 ** (db(n, e) / 10) / m,       db = std_db * g(n, e),

with ``g`` a zero-mean, unit-variance Gaussian field whose autocorrelation is
``exp(-(d / correlation_m)^2)`` (``d`` horizontal distance; so ``correlation_m`` is the 1/e
distance), and ``m`` the mean of ``10 ** (db / 10)`` over the tile, so that the texture
leaves the seabed's mean backscatter unchanged. ``g`` is drawn once from ``seed`` on a
periodic square tile of ``tile_cells`` x ``tile_cells`` nodes, ``CELLS_PER_CORRELATION``
nodes per correlation length (white noise shaped by a Gaussian spectrum with an FFT), and
sampled bilinearly with wrap-around: cheap, unbounded, repeating every ``tile_m``. Node
``(i, j)`` of the tile sits at north ``i * cell_m``, east ``j * cell_m`` (modulo ``tile_m``).

Bilinear sampling between nodes smooths the field a little: the standard deviation of
``db`` at arbitrary points is ~1-2 % below ``std_db`` (exact at the nodes).

Per-ping speckle is drawn on top of this by the renderer; the texture itself never changes.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim_harness.world.errors import WorldError

#: Tile nodes per correlation length.
CELLS_PER_CORRELATION = 4
#: Largest texture standard deviation accepted, dB.
MAX_TEXTURE_DB = 20.0
#: Accepted correlation lengths, m.
CORRELATION_RANGE_M = (0.002, 10.0)
#: Block shape (rows, columns) in which :meth:`SeabedTexture.gain` samples many points.
_BLOCK_ROWS, _BLOCK_COLS = 4096, 1024


@dataclass(frozen=True)
class SeabedTexture:
    """Seeded log-normal reflectivity texture (see the module docstring).

    Attributes
    ----------
    std_db : float
        Standard deviation of the texture in dB, in (0, MAX_TEXTURE_DB].
    correlation_m : float
        Correlation length (1/e distance of the dB field's autocorrelation), m.
    seed : int
        Seed of the tile: the same seed gives the same seabed.
    tile_cells : int
        Nodes along each side of the periodic tile, a power of two >= 16.
    """

    std_db: float
    correlation_m: float
    seed: int = 0
    tile_cells: int = 1024
    _tile: NDArray[np.float32] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        std = float(self.std_db)
        if not (math.isfinite(std) and 0.0 < std <= MAX_TEXTURE_DB):
            raise WorldError(f"must be in (0, {MAX_TEXTURE_DB:g}] dB, got {self.std_db!r}", key="seabed.texture_db")
        lo, hi = CORRELATION_RANGE_M
        corr = float(self.correlation_m)
        if not (math.isfinite(corr) and lo <= corr <= hi):
            raise WorldError(f"must be in [{lo:g}, {hi:g}] m, got {self.correlation_m!r}",
                             key="seabed.texture_scale_m")
        n = int(self.tile_cells)
        if n != self.tile_cells or n < 16 or n & (n - 1):
            raise WorldError(f"must be a power of two >= 16, got {self.tile_cells!r}", key="seabed.texture_tile_cells")
        if int(self.seed) != self.seed or self.seed < 0:
            raise WorldError(f"must be an integer >= 0, got {self.seed!r}", key="seabed.texture_seed")
        object.__setattr__(self, "_tile", _make_tile(std, n, int(self.seed)))

    @property
    def cell_m(self) -> float:
        """Spacing of the tile's nodes, m."""
        return self.correlation_m / CELLS_PER_CORRELATION

    @property
    def tile_m(self) -> float:
        """Period of the texture along north and east, m."""
        return self.cell_m * self.tile_cells

    def gain(self, north_m: ArrayLike, east_m: ArrayLike) -> NDArray[np.float32]:
        """Linear reflectivity gain at ground points (broadcast), mean 1 over the tile, float32.

        Parameters
        ----------
        north_m, east_m : array_like
            Local NED north and east of the points, m (any shape, broadcast together).
        """
        n, e = np.broadcast_arrays(np.asarray(north_m, dtype=np.float64), np.asarray(east_m, dtype=np.float64))
        shape = n.shape
        size = self.tile_cells
        rows = np.mod(n.ravel() / self.cell_m, size).astype(np.float32)
        cols = np.mod(e.ravel() / self.cell_m, size).astype(np.float32)
        out = np.empty(rows.size, dtype=np.float32)
        # OpenCV's remap takes images under 32767 x 32767: sample in blocks of _BLOCK rows
        width = _BLOCK_COLS
        for start in range(0, rows.size, _BLOCK_COLS * _BLOCK_ROWS):
            stop = min(start + _BLOCK_COLS * _BLOCK_ROWS, rows.size)
            m = -(-(stop - start) // width)
            r = np.zeros(m * width, dtype=np.float32)
            c = np.zeros(m * width, dtype=np.float32)
            r[:stop - start], c[:stop - start] = rows[start:stop], cols[start:stop]
            out[start:stop] = self.sample_cells(r.reshape(m, width), c.reshape(m, width)).ravel()[:stop - start]
        return out.reshape(shape)

    def db(self, north_m: ArrayLike, east_m: ArrayLike) -> NDArray[np.float64]:
        """The texture in dB at ground points (``10 log10(gain)``), broadcast."""
        return np.asarray(10.0 * np.log10(self.gain(north_m, east_m).astype(np.float64)))

    def sample_cells(self, rows: NDArray[np.float32], cols: NDArray[np.float32], *,
                     overwrite: bool = False) -> NDArray[np.float32]:
        """Gain at tile coordinates (fast path for the renderer), float32, shape of ``rows``.

        Parameters
        ----------
        rows, cols : ndarray of float32, shape (m, k)
            North and east of the points in tile cells (``metres / cell_m``), any offset
            (|values| up to ~1e6 keep float32's sub-cell precision): they are wrapped into
            the tile here.
        overwrite : bool
            Whether ``rows`` and ``cols`` (C-contiguous float32) may be overwritten (saves
            two copies).
        """
        size = np.float32(self.tile_cells)
        inv = np.float32(1.0 / self.tile_cells)
        wrapped = []
        for x in (rows, cols):
            x = np.asarray(x, dtype=np.float32)
            if not (overwrite and x.flags.c_contiguous):
                x = np.array(x, dtype=np.float32, order="C")
            w = x * inv  # x - size * floor(x / size), in place: in [0, size]
            np.floor(w, out=w)
            w *= size
            np.subtract(x, w, out=x)
            wrapped.append(x)
        r, c = wrapped
        # the tile carries two extra wrapped rows and columns, so every bilinear neighbour
        # of a point in [0, size] is inside it (OpenCV's fast in-range path)
        return np.asarray(cv2.remap(self._tile, c, r, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE))


@functools.lru_cache(maxsize=8)
def _make_tile(std_db: float, n: int, seed: int) -> NDArray[np.float32]:
    """The gain tile, shape (n + 2, n + 2), float32, read-only: the last two rows/columns
    repeat the first (cached: worlds built from one scene share it)."""
    rng = np.random.default_rng([seed, 0x7E47])
    white = rng.standard_normal((n, n))
    # Gaussian spectrum: autocorrelation exp(-(d/L)^2) <-> power exp(-(k L)^2 / 4), k in
    # rad per unit; here lengths are in cells, L = CELLS_PER_CORRELATION
    k_rows = 2.0 * math.pi * np.fft.fftfreq(n)[:, None]
    k_cols = 2.0 * math.pi * np.fft.rfftfreq(n)[None, :]
    length = float(CELLS_PER_CORRELATION)
    amplitude = np.exp(-(k_rows**2 + k_cols**2) * length**2 / 8.0)
    g = np.fft.irfft2(np.fft.rfft2(white) * amplitude, s=(n, n))
    g -= g.mean()
    g /= g.std()
    gain = 10.0 ** (std_db * g / 10.0)
    gain /= gain.mean()
    tile = np.pad(gain, ((0, 2), (0, 2)), mode="wrap").astype(np.float32)
    tile.flags.writeable = False
    return tile
