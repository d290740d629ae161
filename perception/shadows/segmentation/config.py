"""Settings of the segmentation (:func:`perception.shadows.segmentation.segment.segment`), validated once."""

from __future__ import annotations

from dataclasses import dataclass

METHODS = ("speckle", "classical")


@dataclass(frozen=True)
class SegmentationConfig:
    """Settings of :func:`segment`.

    Attributes
    ----------
    method : str
        ``"speckle"`` (default) or ``"classical"`` (the paper's adaptive threshold).
    smooth_samples, smooth_beams : int
        Box smoothing size along range (samples) and azimuth (beams), odd, >= 1.
    detection_rows : int
        The speckle method looks for regions on every ``d``-th row,
        ``d = max(1, n_samples // detection_rows)``; 0 searches every row.
    background_block_samples : int
        Rows averaged per block before the per-row median over beams.
    shadow_db : float
        A pixel is shadow when its smoothed level is this far below its row's seabed, dB.
        8 dB: at 6 dB a shadow's region also takes in the dark patches of a textured
        seabed next to it (3 dB texture), which merges neighbouring targets' shadows and
        carries shadows to the window's end.
    shadow_core_db, min_shadow_core_px : float, int
        A shadow region is kept only when at least ``min_shadow_core_px`` of its pixels
        (full-resolution pixels, counted on the detection grid) lie ``shadow_core_db``
        below their row's seabed (0 px: no such test). A cast shadow holds no echo, only
        the noise floor, 20-30 dB below the seabed; a dark patch of a textured seabed is
        a few dB below it (a 3 dB texture seldom reaches 12 dB below it even where speckle
        adds to it), and merely passes the ``shadow_db`` test.
    highlight_db : float
        A pixel is highlight when its smoothed level is this far above its row's seabed, dB.
    highlight_core_db, min_highlight_core_px : float, int
        A highlight region is kept only when at least ``min_highlight_core_px`` of its
        pixels (full-resolution, counted on the grid) lie ``highlight_core_db`` above their
        row's seabed (0 px: no such test). A target's echo stands 15-30 dB above the
        seabed; a bright patch of a textured seabed a few dB.
    band_drop_db : float
        A row is insonified seabed when its seabed level is within this of the frame's
        seabed level (90th percentile of the row levels), dB.
    uint8_db_range : float or None
        dB spanned by uint8 levels 0-255 (80 for ARIS); None: uint8 is linear power.
    open_size, close_size : int
        Sizes (pixels of the detection grid) of the square structuring elements of the
        clean-up; 0 disables.
    min_shadow_area_px, min_highlight_area_px : int
        Smaller components (full-resolution pixels) are dropped.
    classical_block_size : int
        Neighbourhood (odd) of the classical adaptive threshold.
    classical_offset : float
        Offset of the classical threshold in grey levels of the 8-bit image.
    """

    method: str = "speckle"
    smooth_samples: int = 5
    smooth_beams: int = 3
    detection_rows: int = 250
    background_block_samples: int = 8
    shadow_db: float = 8.0
    shadow_core_db: float = 15.0
    min_shadow_core_px: int = 24
    highlight_db: float = 6.0
    highlight_core_db: float = 12.0
    min_highlight_core_px: int = 16
    band_drop_db: float = 10.0
    uint8_db_range: float | None = 80.0
    open_size: int = 0
    close_size: int = 0
    min_shadow_area_px: int = 12
    min_highlight_area_px: int = 6
    classical_block_size: int = 51
    classical_offset: float = 12.0

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        for name in ("smooth_samples", "smooth_beams", "classical_block_size"):
            value = getattr(self, name)
            if value < 1 or value % 2 == 0:
                raise ValueError(f"{name} must be an odd integer >= 1, got {value}")
        if self.detection_rows < 0:
            raise ValueError(f"detection_rows must be >= 0 (0: every row), got {self.detection_rows}")
        if self.background_block_samples < 1:
            raise ValueError("background_block_samples must be >= 1")
        for name in ("shadow_db", "highlight_db", "band_drop_db"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 dB, got {getattr(self, name)}")
        if not self.shadow_core_db >= self.shadow_db:
            raise ValueError(
                f"shadow_core_db must be >= shadow_db ({self.shadow_db} dB), got {self.shadow_core_db}"
            )
        if not self.highlight_core_db >= self.highlight_db:
            raise ValueError(
                f"highlight_core_db must be >= highlight_db ({self.highlight_db} dB), got {self.highlight_core_db}"
            )
        for name in ("min_shadow_core_px", "min_highlight_core_px"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.uint8_db_range is not None and not self.uint8_db_range > 0:
            raise ValueError(f"uint8_db_range must be > 0 dB or None, got {self.uint8_db_range}")
        if self.open_size < 0 or self.close_size < 0:
            raise ValueError("open_size and close_size must be >= 0")

    def row_step(self, n_samples: int) -> int:
        """Rows of the full image per row of the detection grid (1 for ``"classical"``)."""
        if self.method != "speckle" or self.detection_rows == 0:
            return 1
        return max(1, n_samples // self.detection_rows)
