"""``shadowsurvey mosaic FRAMES... --out DIR``: the 2.5D map from recorded frames.

Frames (.npz, or .aris) must carry their pose (``north_m``, ``east_m``, ``heading_deg``,
``altitude_m``, ``tilt_deg``), or a navigation CSV gives it by time (``--nav``, columns
``t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg`` and optionally
``depth_m,pitch_deg,roll_deg``; linear interpolation, attitude of the nearest row). The
frames are mosaicked (drift registration on unless ``--no-registration``), their shadows
measured and tracked into target heights, and the map written: ``mosaic.tif``,
``mosaic.png`` with world file, ``targets.geojson``, ``mosaic_heights.png``.

Frames may differ in range window, sample count and spacing, gain and dtype: each is placed
by its own range axis, heights are measured on the frames as they are, and frames that are
not uint8 display levels are blended as display levels with their seabed at the level of
the recording's uint8 frames (:func:`perception.sonar_io.display.as_display`).
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from perception.heights.pipeline import HeightPipeline, HeightsConfig
from perception.mapping.builder import MosaicBuilder, masks_from_shadows
from perception.mapping.georef import LocalOrigin
from perception.mapping.heights_layer import MappedTarget
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.products import map_raster, write_geotiff, write_png_with_world_file, write_targets_geojson
from perception.mapping.registration import RegistrationConfig
from perception.sonar_io.display import DEFAULT_SEABED_LEVEL, as_display, seabed_display_level
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.readers import open_recording
from planner.errors import UsageError
from planner.report.map_plot import render_map_png

NAV_COLUMNS = ("t_s", "north_m", "east_m", "heading_deg", "altitude_m", "tilt_deg")


def register(subparsers: Any) -> None:
    """Add the ``mosaic`` subcommand."""
    parser = subparsers.add_parser("mosaic", help="2.5D seabed map (mosaic + target heights) from recorded frames",
                                   description=__doc__.split("\n\n", 1)[1] if __doc__ else None)
    parser.add_argument("frames", nargs="+", help=".npz or .aris frame files")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--nav", help="navigation CSV giving the pose by time")
    parser.add_argument("--origin", metavar="LAT,LON", default="0,0",
                        help="WGS84 origin of the frames' local north/east (default 0,0)")
    parser.add_argument("--resolution-m", type=float, default=0.01, help="cell size (default 0.01 m)")
    parser.add_argument("--no-registration", action="store_true", help="trust the navigation (no drift correction)")
    parser.set_defaults(func=run)


class NavTable:
    """Pose by time from a navigation CSV (see the module docstring)."""

    def __init__(self, path: Path):
        with path.open(newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            missing = [c for c in NAV_COLUMNS if c not in (reader.fieldnames or [])]
            if missing:
                raise UsageError(f"{path}: navigation CSV lacks columns {', '.join(missing)}")
            rows = list(reader)
        if len(rows) < 2:
            raise UsageError(f"{path}: navigation CSV needs at least two rows")
        try:
            self.columns = {name: np.array([float(r[name]) if r.get(name) not in (None, "") else math.nan
                                            for r in rows]) for name in (*NAV_COLUMNS, "depth_m", "pitch_deg",
                                                                         "roll_deg") if name in rows[0]}
        except ValueError as exc:
            raise UsageError(f"{path}: not a number in the navigation CSV ({exc})") from exc
        if not np.all(np.diff(self.columns["t_s"]) > 0):
            raise UsageError(f"{path}: t_s must be strictly increasing")

    def apply(self, frame: SonarFrame) -> SonarFrame:
        """The frame with the pose at its timestamp."""
        t = self.columns["t_s"]
        if not t[0] <= frame.timestamp_s <= t[-1]:
            raise UsageError(f"frame at t={frame.timestamp_s:.3f} s lies outside the navigation CSV")
        i = int(np.argmin(np.abs(t - frame.timestamp_s)))

        def lin(name: str) -> float:
            return float(np.interp(frame.timestamp_s, t, self.columns[name]))

        def near_rad(name: str) -> float:
            return math.radians(self.columns[name][i]) if name in self.columns else math.nan

        return frame.with_fields(north_m=lin("north_m"), east_m=lin("east_m"), altitude_m=lin("altitude_m"),
                                 heading_rad=near_rad("heading_deg"), tilt_rad=near_rad("tilt_deg"),
                                 vehicle_pitch_rad=near_rad("pitch_deg"), vehicle_roll_rad=near_rad("roll_deg"),
                                 sonar_depth_m=lin("depth_m") if "depth_m" in self.columns else frame.sonar_depth_m)


def _origin(text: str) -> LocalOrigin:
    try:
        lat, lon = (float(v) for v in text.split(","))
    except ValueError as exc:
        raise UsageError(f"--origin must be LAT,LON in degrees, got {text!r}") from exc
    return LocalOrigin(lat, lon)


def run(args: argparse.Namespace) -> int:
    """Build the map; exit 0, or 2 for bad input."""
    origin = _origin(args.origin)
    nav = NavTable(Path(args.nav)) if args.nav else None
    builder = MosaicBuilder(MosaicConfig(resolution_m=args.resolution_m),
                            None if args.no_registration else RegistrationConfig())
    heights = HeightPipeline(HeightsConfig(shared_altitude=False))
    recordings = [open_recording(p) for p in args.frames]
    total = sum(len(r) for r in recordings)
    seabed_level: float | None = None  # of the uint8 frames, once one is seen
    with tqdm(total=total, unit="frame", desc="mosaic", mininterval=1.0) as bar:
        for path, recording in zip(args.frames, recordings, strict=True):
            for frame in recording:
                if nav is not None:
                    frame = nav.apply(frame)
                for name in ("north_m", "east_m", "heading_rad", "altitude_m", "tilt_rad"):
                    if not frame.known(name):
                        raise UsageError(f"{path}: frame at t={frame.timestamp_s:.3f} s has no {name}; "
                                         "give the pose in the frames or with --nav")
                result = heights.add_frame(frame)
                if frame.image.dtype == np.uint8 and seabed_level is None:
                    seabed_level = seabed_display_level(frame.image)
                shown = as_display(frame, seabed_level=DEFAULT_SEABED_LEVEL if seabed_level is None else seabed_level)
                shadow = unreliable = None
                if result.measurements:
                    # Measured shadows stay out of the blend, target echoes out of registration.
                    masks = masks_from_shadows(result.measurements, range_m=frame.range_m, n_beams=frame.n_beams,
                                               beam_azimuth_rad=frame.beam_azimuth_rad, image=shown.image)
                    shadow, unreliable = masks.shadow, masks.target
                builder.add_frame(shown, exclude_mask=shadow, unreliable_mask=unreliable)
                bar.update(1)
    targets = [MappedTarget(t.target_id, t.north_m, t.east_m,
                            math.nan if t.height_m is None else t.height_m,
                            math.nan if t.height_std_m is None else t.height_std_m, t.frames_used)
               for t in heights.targets() if math.isfinite(t.north_m)]
    out = Path(args.out)
    raster = map_raster(builder.mosaic, targets)
    write_geotiff(out / "mosaic.tif", raster, origin)
    write_png_with_world_file(out / "mosaic.png", raster, origin)
    write_targets_geojson(out / "targets.geojson", targets, origin)
    render_map_png(out / "mosaic_heights.png", raster, targets)
    solved = sum(1 for t in targets if math.isfinite(t.height_m))
    print(f"{total} frames -> {raster.intensity.shape[1]} x {raster.intensity.shape[0]} cells of "
          f"{args.resolution_m * 100:.0f} cm; {len(targets)} targets, {solved} with a height; wrote {out}")
    return 0
