"""``shadowsurvey mosaic FRAMES... --out DIR``: the 2.5D map from recorded frames.

Frames (.npz, or .aris) must carry their pose (``north_m``, ``east_m``, ``heading_deg``,
``altitude_m``, ``tilt_deg``), or a navigation CSV gives it by time (``--nav``, columns
``t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg`` and optionally
``depth_m,pitch_deg,roll_deg``; linear interpolation, attitude of the nearest row;
:mod:`planner.commands.nav_csv`). ``--origin`` is required: frame files hold local metres
only, so the map's place on Earth must be given. The
frames are mosaicked (drift registration on unless ``--no-registration``), their shadows
measured and tracked into target heights, and the map written: ``mosaic.tif``,
``mosaic.png`` with world file, ``targets.geojson``, ``mosaic_heights.png``.

Frames may differ in range window, sample count and spacing, gain and dtype: each is placed
by its own range axis, and frames that are not uint8 display levels are measured and blended
as display levels with their seabed at the level of the recording's uint8 frames
(:func:`perception.sonar_io.display.as_display`; the segmentation works in each frame's own
spread, so their shadows measure alike).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.commands import args as args_types
from planner.commands.frame_checks import MOSAIC_SEABED_TOLERANCE_M, MapExtent, check_altitudes, check_one_scene
from planner.errors import UsageError
from planner.mission.output_folder import check_output_folder, staged_folder

if TYPE_CHECKING:
    from perception.sonar_io.frame import SonarFrame


def register(subparsers: Any) -> None:
    """Add the ``mosaic`` subcommand."""
    parser = subparsers.add_parser("mosaic", help="2.5D seabed map (mosaic + target heights) from recorded frames",
                                   description=__doc__.split("\n\n", 1)[1] if __doc__ else None)
    parser.add_argument("frames", nargs="+", help=".npz or .aris frame files")
    parser.add_argument("--out", required=True, help="output folder (an existing map needs --overwrite)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing map folder at --out")
    parser.add_argument("--nav", help="navigation CSV giving the pose by time (planner/commands/nav_csv.py)")
    parser.add_argument("--origin", metavar="LAT,LON", type=args_types.lat_lon, required=True,
                        help="WGS84 position of the frames' local north/east origin (required: frame files carry "
                             "local metres only, and a map put at 0,0 would be in the Gulf of Guinea)")
    parser.add_argument("--resolution-m", type=args_types.number(0.001, 1.0, unit="m"), default=0.01,
                        help="cell size, 0.001..1 m (default 0.01 m)")
    parser.add_argument("--no-registration", action="store_true", help="trust the navigation (no drift correction)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the map; exit 0, or 2 for bad input."""
    import numpy as np
    from tqdm import tqdm

    from perception.geodesy import LocalOrigin
    from perception.mapping.mosaic import MosaicConfig
    from perception.mapping.products import write_geotiff, write_png_with_world_file, write_targets_geojson
    from perception.mapping.registration import RegistrationConfig
    from perception.mapping.survey_map import SurveyMap
    from perception.sonar_io.display import DEFAULT_SEABED_LEVEL, as_display, seabed_display_level
    from perception.sonar_io.readers import open_recording
    from planner.commands.nav_csv import NavTable
    from planner.report.map_plot import render_map_png  # matplotlib: only when a map is drawn

    origin = LocalOrigin(*args.origin)
    out = Path(args.out)
    check_output_folder(out, kind="map", overwrite=args.overwrite)
    nav = NavTable(Path(args.nav)) if args.nav else None
    first: tuple[str, SonarFrame] | None = None
    extent = MapExtent(args.resolution_m)
    survey_map = SurveyMap(mosaic=MosaicConfig(resolution_m=args.resolution_m),
                           registration=None if args.no_registration else RegistrationConfig())
    recordings = [open_recording(p) for p in args.frames]
    total = sum(len(r) for r in recordings)
    seabed_level: float | None = None  # of the uint8 frames, once one is seen
    with tqdm(total=total, unit="frame", desc="mosaic", mininterval=1.0, disable=None) as bar:
        for path, recording in zip(args.frames, recordings, strict=True):
            for i, frame in enumerate(recording):
                label = path if len(recording) == 1 else f"{path}#{i}"
                if nav is not None:
                    frame = nav.apply(frame, label)
                first = first or (label, frame)
                check_one_scene([first[0], label], [first[1], frame], seabed_tolerance_m=MOSAIC_SEABED_TOLERANCE_M)
                for name in ("north_m", "east_m", "heading_rad", "altitude_m", "tilt_rad"):
                    if not frame.known(name):
                        raise UsageError(f"{path}: frame at t={frame.timestamp_s:.3f} s has no {name}; "
                                         "give the pose in the frames or with --nav")
                extent.add(label, frame)
                check_altitudes([label], [frame], [frame.altitude_m])
                if frame.image.dtype == np.uint8 and seabed_level is None:
                    seabed_level = seabed_display_level(frame.image)
                # Frames of other dtypes as display levels at the uint8 frames' seabed level
                # (their shadows are measured alike: the segmentation is in each frame's spread).
                survey_map.add_frame(as_display(frame, seabed_level=DEFAULT_SEABED_LEVEL if seabed_level is None
                                                else seabed_level))
                bar.update(1)
    targets = survey_map.mapped_targets()
    raster = survey_map.raster(targets)
    if raster is None:
        raise UsageError(f"{args.frames[0]}: no frame reached the seabed, nothing to map")
    with staged_folder(out, kind="map", overwrite=args.overwrite, keep_partial=False) as stage:
        write_geotiff(stage / "mosaic.tif", raster, origin)
        write_png_with_world_file(stage / "mosaic.png", raster, origin)
        write_targets_geojson(stage / "targets.geojson", targets, origin)
        render_map_png(stage / "mosaic_heights.png", raster, targets)
    solved = sum(1 for t in targets if math.isfinite(t.height_m))
    print(f"{total} frames -> {raster.intensity.shape[1]} x {raster.intensity.shape[0]} cells of "
          f"{args.resolution_m * 100:.0f} cm; {len(targets)} targets, {solved} with a height; wrote {out}")
    return 0
