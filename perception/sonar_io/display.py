"""Frames of any dtype as ARIS display levels, so that frames of one scene can be blended.

An ARIS frame is uint8 display levels, 0-80 dB over 0-255; other frames (uint16, float32:
linear echo, see :mod:`perception.sonar_io.frame`) have their own scale and gain. For a map
blending frames of several sources, each non-uint8 frame becomes display levels: its dB
(:func:`perception.shadows.segmentation.levels.as_levels`) on the ARIS scale, shifted so
that its seabed level (the upper quartile of its levels: the brightest quarter of a frame is
insonified seabed) lands on a given display level -- that of the uint8 frames of the same
recording, so their brightness matches. uint8 frames are kept as they are.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from perception.shadows.segmentation.levels import as_levels
from perception.sonar_io.frame import SonarFrame

#: dB spanned by display levels 0-255 (ARIS).
DISPLAY_DB_RANGE = 80.0
#: Percentile of a frame's levels taken for its seabed level.
SEABED_PERCENTILE = 75.0
#: Display level of the seabed when no uint8 frame sets it.
DEFAULT_SEABED_LEVEL = 128.0


def seabed_display_level(image: NDArray[np.generic]) -> float:
    """The seabed level (:data:`SEABED_PERCENTILE` of a strided subsample) of a uint8 image."""
    return float(np.percentile(np.asarray(image)[::4, ::2], SEABED_PERCENTILE))


def as_display(frame: SonarFrame, *, seabed_level: float = DEFAULT_SEABED_LEVEL) -> SonarFrame:
    """The frame with a uint8 display image (module docstring); uint8 frames unchanged.

    Parameters
    ----------
    frame : SonarFrame
    seabed_level : float
        Display level (0-255) the frame's seabed level is put at.

    Returns
    -------
    SonarFrame
        ``frame`` itself when its image is uint8, else a copy with the display image.
    """
    if frame.image.dtype == np.uint8:
        return frame
    levels, db_per_level = as_levels(frame.image)
    db = np.asarray(levels, dtype=np.float32) * np.float32(db_per_level)
    seabed_db = float(np.percentile(db[::4, ::2], SEABED_PERCENTILE))
    scale = np.float32(255.0 / DISPLAY_DB_RANGE)
    display = np.clip(np.rint((db - np.float32(seabed_db)) * scale + np.float32(seabed_level)), 0, 255)
    return frame.with_fields(image=display.astype(np.uint8))
