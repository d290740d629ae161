"""Settings of the segmentation (:func:`perception.shadows.segmentation.segment.segment`), validated once.

Lengths are in metres of slant range (converted to samples per frame from its own range
axis, so frames with different windows and sample spacings are segmented alike); levels
are in units of the frame's own seabed spread ``sigma`` (the robust standard deviation of
the detection grid's seabed levels about their row's level), so that a frame's gain, TVG,
dtype and speckle statistics do not move the thresholds: a linear image whose values are
amplitudes instead of powers halves every dB contrast and its ``sigma`` alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

METHODS = ("speckle", "classical")


@dataclass(frozen=True)
class SegmentationConfig:
    """Settings of :func:`segment`.

    Attributes
    ----------
    method : str
        ``"speckle"`` (default) or ``"classical"`` (the paper's adaptive threshold).
    grid_step_m : float
        Range step of the detection grid, m: each grid row is the mean level of a block of
        ``d = round(grid_step_m / sample spacing)`` rows (at least 1).
    max_grid_rows : int
        The grid has at most this many rows (``d`` grows for long windows of fine samples;
        it bounds the cost per frame).
    smooth_beams : int
        Beams averaged (centred, odd) into each grid pixel.
    background_block_m : float
        Grid rows are averaged over blocks of this range before the upper quartile over
        beams that gives each row's seabed level, m.
    shadow_sigmas, shadow_core_sigmas, min_shadow_core_m : float
        A grid pixel is shadow when it lies ``shadow_sigmas`` spreads below its row's
        seabed level (inside the band); a shadow region is kept only when its core -- pixels
        ``shadow_core_sigmas`` spreads below -- covers at least ``min_shadow_core_m`` of
        range summed over its beams (a cast shadow holds the noise floor, far below the
        seabed; a dark patch of speckle or seabed texture hardly reaches the core level).
    shadow_weak_sigmas : float
        Along each beam a shadow runs on through pixels this many spreads below the seabed
        (hysteresis), so that a side-lobe streak of a bright target crossing it does not
        cut it in two.
    highlight_sigmas, highlight_core_sigmas, min_highlight_core_m : float
        The same for highlights (target echoes above the seabed).
    band_sigmas : float
        A row holds insonified seabed (the band) when its seabed level stands this many
        spreads above the darkest rows' level (the noise floor when the window holds
        water column or the dark beyond the aperture).
    min_shadow_length_m, min_shadow_beams : float, int
        Smaller shadow regions (range extent, beams) are dropped.
    min_highlight_length_m : float
        Highlights shorter than this (range extent) are dropped.
    uint8_db_range : float or None
        dB spanned by uint8 levels 0-255 (80 for ARIS); None: uint8 is linear power.
        (Only the names of the dB figures in results depend on it: thresholds are in spreads.)
    classical_block_size, classical_offset : int, float
        Neighbourhood (odd) and offset (grey levels of the 8-bit image) of the classical
        adaptive threshold.
    """

    method: str = "speckle"
    grid_step_m: float = 0.005
    max_grid_rows: int = 320
    smooth_beams: int = 3
    background_block_m: float = 0.02
    shadow_sigmas: float = 3.0
    shadow_core_sigmas: float = 5.0
    shadow_weak_sigmas: float = 1.0
    min_shadow_core_m: float = 0.06
    highlight_sigmas: float = 3.0
    highlight_core_sigmas: float = 5.0
    min_highlight_core_m: float = 0.02
    band_sigmas: float = 3.0
    min_shadow_length_m: float = 0.012
    min_shadow_beams: int = 2
    min_highlight_length_m: float = 0.006
    uint8_db_range: float | None = 80.0
    classical_block_size: int = 51
    classical_offset: float = 12.0

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        for name in ("smooth_beams", "classical_block_size"):
            value = getattr(self, name)
            if value < 1 or value % 2 == 0:
                raise ValueError(f"{name} must be an odd integer >= 1, got {value}")
        if self.max_grid_rows < 8:
            raise ValueError(f"max_grid_rows must be >= 8, got {self.max_grid_rows}")
        for name in ("grid_step_m", "background_block_m", "shadow_sigmas", "highlight_sigmas", "band_sigmas"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not 0 <= self.shadow_weak_sigmas <= self.shadow_sigmas:
            raise ValueError(f"shadow_weak_sigmas must be in [0, shadow_sigmas], got {self.shadow_weak_sigmas}")
        if not self.shadow_core_sigmas >= self.shadow_sigmas:
            raise ValueError(f"shadow_core_sigmas must be >= shadow_sigmas ({self.shadow_sigmas}), "
                             f"got {self.shadow_core_sigmas}")
        if not self.highlight_core_sigmas >= self.highlight_sigmas:
            raise ValueError(f"highlight_core_sigmas must be >= highlight_sigmas ({self.highlight_sigmas}), "
                             f"got {self.highlight_core_sigmas}")
        for name in ("min_shadow_core_m", "min_highlight_core_m", "min_shadow_length_m", "min_highlight_length_m"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {getattr(self, name)}")
        if self.min_shadow_beams < 1:
            raise ValueError(f"min_shadow_beams must be >= 1, got {self.min_shadow_beams}")
        if self.uint8_db_range is not None and not self.uint8_db_range > 0:
            raise ValueError(f"uint8_db_range must be > 0 dB or None, got {self.uint8_db_range}")

    def row_step(self, n_samples: int, sample_m: float) -> int:
        """Full-resolution rows per row of the detection grid (1 for ``"classical"``).

        Parameters
        ----------
        n_samples : int
            Rows of the image.
        sample_m : float
            Range spacing of its samples, m.
        """
        if self.method != "speckle":
            return 1
        d = max(1, int(round(self.grid_step_m / sample_m))) if sample_m > 0 else 1
        return max(d, -(-n_samples // self.max_grid_rows))
