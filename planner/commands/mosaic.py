"""``shadowsurvey mosaic FRAMES... --out DIR``: the 2.5D map from recorded frames.

Frames (.npz, or .aris) must carry their pose (``north_m``, ``east_m``, ``heading_deg``,
``altitude_m``, ``tilt_deg``), or a navigation CSV gives it by time (``--nav``, columns
``t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg`` and optionally
``depth_m,pitch_deg,roll_deg``; linear interpolation, attitude of the nearest row). The
frames are mosaicked (drift registration on unless ``--no-registration``), their shadows
measured and tracked into target heights, and the map written: ``mosaic.tif``,
``mosaic.png`` with world file, ``targets.geojson``, ``mosaic_heights.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from perception.geodesy import LocalOrigin
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.products import write_geotiff, write_png_with_world_file, write_targets_geojson
from perception.mapping.registration import RegistrationConfig
from perception.mapping.survey_map import SurveyMap
from perception.navigation.history import NavigationHistory
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
        t = self.columns["t_s"]
        if not np.all(np.diff(t) > 0):
            raise UsageError(f"{path}: t_s must be strictly increasing")
        # The one navigation history of the product (as on board): positions interpolated,
        # attitude and tilt of the nearest row.
        self.history = NavigationHistory(float(t[-1] - t[0]) + 1.0, max_extrapolation_s=0.0)
        c = self.columns
        nan = np.full(t.shape, math.nan)
        for k, time_s in enumerate(t):
            self.history.add_position(float(time_s), float(c["north_m"][k]), float(c["east_m"][k]))
            self.history.add_attitude(float(time_s), math.radians(c["heading_deg"][k]),
                                      math.radians(c.get("pitch_deg", nan)[k]), math.radians(c.get("roll_deg", nan)[k]))
            self.history.add_tilt(float(time_s), math.radians(c["tilt_deg"][k]))

    def apply(self, frame: SonarFrame) -> SonarFrame:
        """The frame with the pose at its timestamp."""
        t = self.columns["t_s"]
        if not t[0] <= frame.timestamp_s <= t[-1]:
            raise UsageError(f"frame at t={frame.timestamp_s:.3f} s lies outside the navigation CSV")
        nav = self.history.at(frame.timestamp_s)
        if nav is None:  # pragma: no cover - the CSV has at least two rows
            raise UsageError(f"no navigation at t={frame.timestamp_s:.3f} s")

        def lin(name: str) -> float:
            return float(np.interp(frame.timestamp_s, t, self.columns[name]))

        return frame.with_fields(north_m=nav.north_m, east_m=nav.east_m, altitude_m=lin("altitude_m"),
                                 heading_rad=nav.heading_rad, tilt_rad=nav.tilt_rad,
                                 vehicle_pitch_rad=nav.pitch_rad, vehicle_roll_rad=nav.roll_rad,
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
    survey_map = SurveyMap(mosaic=MosaicConfig(resolution_m=args.resolution_m),
                           registration=None if args.no_registration else RegistrationConfig())
    recordings = [open_recording(p) for p in args.frames]
    total = sum(len(r) for r in recordings)
    with tqdm(total=total, unit="frame", desc="mosaic", mininterval=1.0) as bar:
        for path, recording in zip(args.frames, recordings, strict=True):
            for frame in recording:
                if nav is not None:
                    frame = nav.apply(frame)
                for name in ("north_m", "east_m", "heading_rad", "altitude_m", "tilt_rad"):
                    if not frame.known(name):
                        raise UsageError(f"{path}: frame at t={frame.timestamp_s:.3f} s has no {name}; "
                                         "give the pose in the frames or with --nav")
                survey_map.add_frame(frame)
                bar.update(1)
    targets = survey_map.mapped_targets()
    out = Path(args.out)
    raster = survey_map.raster(targets)
    if raster is None:
        raise UsageError(f"{args.frames[0]}: no frame reached the seabed, nothing to map")
    write_geotiff(out / "mosaic.tif", raster, origin)
    write_png_with_world_file(out / "mosaic.png", raster, origin)
    write_targets_geojson(out / "targets.geojson", targets, origin)
    render_map_png(out / "mosaic_heights.png", raster, targets)
    solved = sum(1 for t in targets if math.isfinite(t.height_m))
    print(f"{total} frames -> {raster.intensity.shape[1]} x {raster.intensity.shape[0]} cells of "
          f"{args.resolution_m * 100:.0f} cm; {len(targets)} targets, {solved} with a height; wrote {out}")
    return 0
