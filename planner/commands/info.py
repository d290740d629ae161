"""``shadowsurvey info FILE``: what a sonar recording (.aris or .npz) holds."""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import sys
from typing import Any

from perception.errors import FrameFormatError
from perception.sonar_io.readers import RecordingInfo, open_recording

#: Timestamps from here on (1990) are shown as UTC dates too (.aris stores Unix time).
EPOCH_PLAUSIBLE_S = 631_152_000.0


def register(subparsers: Any) -> None:
    """Add the ``info`` subcommand."""
    parser = subparsers.add_parser(
        "info",
        help="summarise a sonar recording (.aris or .npz)",
        description=(
            "Print what a sonar recording holds: sonar, frames, beams, samples, range "
            "window, frame rate, time span and the pose fields present."
        ),
    )
    parser.add_argument("file", help="recording (.aris or .npz)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.set_defaults(func=run)


def _span(values: tuple[float, float] | None, fmt: str, unit: str) -> str:
    if values is None:
        return "-"
    return f"{values[0]:{fmt}} to {values[1]:{fmt}} {unit}"


def format_info(info: RecordingInfo) -> str:
    """The human-readable summary of :class:`RecordingInfo` (degrees at this edge)."""
    azimuth = None
    if info.beam_azimuth_rad is not None:
        azimuth = (math.degrees(info.beam_azimuth_rad[0]), math.degrees(info.beam_azimuth_rad[1]))
    lines = [
        f"file            {info.path} ({info.format})",
        f"sonar           {info.sonar}",
        f"frames          {info.n_frames}",
        f"beams           {info.n_beams if info.n_beams is not None else '-'}"
        + (f" (azimuth {_span(azimuth, '.2f', 'deg')})" if azimuth else ""),
        f"samples         {info.n_samples if info.n_samples is not None else '-'}"
        + (f" ({info.image_dtype})" if info.image_dtype else ""),
        f"window          {_span(info.range_window_m, '.4f', 'm')} (row centres)",
    ]
    if info.acquisition_window_m is not None:
        lines.append(f"window edges    {_span(info.acquisition_window_m, '.4f', 'm')}")
    if not math.isnan(info.elevation_aperture_rad):
        lines.append(f"elevation       {math.degrees(info.elevation_aperture_rad):.1f} deg")
    if not math.isnan(info.sound_speed_m_s):
        lines.append(f"sound speed     {info.sound_speed_m_s:.2f} m/s")
    rate = "-" if math.isnan(info.frame_rate_hz) else f"{info.frame_rate_hz:.3f} Hz"
    lines.append(f"frame rate      {rate}")
    duration = "" if info.time_span_s is None else f" ({info.duration_s:.3f} s)"
    if info.time_span_s is not None and EPOCH_PLAUSIBLE_S <= info.time_span_s[0] < 2**37:
        start = dt.datetime.fromtimestamp(info.time_span_s[0], tz=dt.UTC)
        duration += f", starting {start:%Y-%m-%d %H:%M:%S} UTC"
    lines.append(f"time span       {_span(info.time_span_s, '.6f', 's')}{duration}")
    pose = ", ".join(info.pose_fields) if info.pose_fields else "none"
    lines.append(f"pose fields     {pose} (from {info.frames_examined} frames)")
    if info.truncation:
        lines.append(f"truncated       {info.truncation}")
    for problem in info.problems:
        lines.append(f"corrupt         {problem}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Print the summary; 0 for a whole recording.

    A truncated or corrupt recording is described as far as it can be read (stdout), then
    refused like ``heights`` and ``convert`` refuse it: exit 2, one line on stderr naming
    the file, the frame and the field.
    """
    with open_recording(args.file) as recording:
        info = recording.describe()
    if args.json:
        json.dump(info.to_dict(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        print(format_info(info))
    sys.stdout.flush()
    if info.problems:
        more = f" (and {len(info.problems) - 1} more)" if len(info.problems) > 1 else ""
        raise FrameFormatError(f"corrupt recording: {info.problems[0]}{more}")
    if info.truncation:
        raise FrameFormatError(f"truncated recording: {info.truncation}; the {info.n_frames} complete frames "
                               f"before it are readable (shadowsurvey convert --frames 0:{info.n_frames})",
                               path=info.path)
    return 0
