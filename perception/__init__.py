"""shadowsurvey perception: on-board sonar processing, pure computation.

Sub-packages, one idea each:

- :mod:`perception.sonar_io`: the sonar frame, ``.npz`` frame files, ARIS recordings, beam tables;
- :mod:`perception.shadows`: segmentation, pairing highlights with shadows, shadow edges;
- :mod:`perception.heights`: height solvers (Eq. 2 and the N-frame form) and the frame-to-target pipeline;
- :mod:`perception.tracking`: targets across frames, altitudes, passes and views;
- :mod:`perception.navigation`: pressure depth, sonar altitude, the altitude filter (dH);
- :mod:`perception.mapping`: georeference, mosaic, registration, heights layer, map products;
- :mod:`perception.geometry`: sonar-to-seabed geometry shared by all of them.

The names below are the package's public API; they are imported on first use, so that
importing one data type (``perception.sonar_io.frame``) does not load the whole chain.
"""

from __future__ import annotations

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "SonarFrame": "perception.sonar_io",
    "open_recording": "perception.sonar_io",
    "load_frames": "perception.sonar_io",
    "save_frame": "perception.sonar_io",
    "save_frames": "perception.sonar_io",
    "segment": "perception.shadows",
    "pair_regions": "perception.shadows",
    "measure_pairs": "perception.shadows",
    "HeightPipeline": "perception.heights",
    "HeightsConfig": "perception.heights",
    "TargetHeight": "perception.heights",
    "solve_height": "perception.heights",
    "TargetTracker": "perception.tracking",
    "AltitudeFilter": "perception.navigation",
    "AltitudeFilterConfig": "perception.navigation",
    "TiledMosaic": "perception.mapping",
    "MosaicBuilder": "perception.mapping",
    "LocalOrigin": "perception.mapping",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
