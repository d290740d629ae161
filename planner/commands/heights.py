"""``shadowsurvey heights FRAME_FILE...``: target heights from sonar frame files.

As specified in ``heights-command.md``: frames (.npz or .aris) of one scene from at least
two altitudes; the altitude change from ``--delta-h`` (two frames), else the frames'
``altitude_m``, else their ``sonar_depth_m``; ``--altitude`` gives the first frame's
altitude where the files lack it. Prints a table, and with ``--json OUT`` (``-`` for
stdout) the JSON document. Exit 0 on success (also with no target), 2 on bad input
with a message naming the file and what is wrong.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from perception.atomic_file import atomic_write_text
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.readers import open_recording
from planner.commands import args as args_types
from planner.commands.frame_checks import (
    HEIGHTS_SEABED_TOLERANCE_M,
    check_altitudes,
    check_delta_h,
    check_one_scene,
)
from planner.errors import UsageError

if TYPE_CHECKING:
    from perception.heights.pipeline import TargetHeight

#: Altitude changes closer than this count as one altitude, m.
SAME_ALTITUDE_M = 1e-6


def register(subparsers: Any) -> None:
    """Add the ``heights`` subcommand."""
    parser = subparsers.add_parser(
        "heights",
        help="estimate seabed target heights from sonar frames at two altitudes",
        description=(
            "Find targets and their cast shadows in sonar frames (.npz or .aris) of one "
            "scene taken from at least two altitudes, and solve each target's height."
        ),
    )
    parser.add_argument("files", nargs="+", metavar="FRAME_FILE", help=".npz or .aris frames")
    parser.add_argument(
        "--delta-h",
        type=args_types.number(-1000.0, 1000.0, unit="m"),
        metavar="M",
        help="altitude change, m: second altitude minus first (exactly two frames)",
    )
    parser.add_argument(
        "--altitude", type=args_types.number(0.0, 1000.0, lo_open=True, unit="m"), metavar="M",
        help="first frame's altitude, m, where files lack it"
    )
    parser.add_argument(
        "--rounded-targets", action="store_true",
        help="report a target whose echo fades towards its shadow (stone, rock, tyre) at the summit "
             "of the half-ellipsoid its echo and shadow give (shadow_start \"rounded top\"), not at "
             "its grazing point; a short, tall block seen corner-on can then read high"
    )
    parser.add_argument("--json", metavar="OUT", help="write the JSON document to OUT ('-' = stdout)")
    parser.set_defaults(func=run)


@dataclass(frozen=True)
class LabelledFrame:
    """A frame's header with the name it goes by in the output (``file`` or ``file#i``).

    ``frame`` holds the pose and geometry but not the image (a zero-memory stand-in), so
    long recordings are not held in memory; :func:`frames_of` reads the images again.
    """

    label: str
    path: str
    index: int
    frame: SonarFrame


def _header(frame: SonarFrame) -> SonarFrame:
    """The frame with its image replaced by a read-only zero view (no memory)."""
    return frame.with_fields(image=np.broadcast_to(np.zeros((), dtype=np.uint8), frame.image.shape))


def load_all(paths: Sequence[str]) -> list[LabelledFrame]:
    """Every frame header of every file, in order; files with several frames give ``file#i``."""
    out: list[LabelledFrame] = []
    for path in paths:
        if not Path(path).is_file():
            raise UsageError(f"{path}: no such file")
        with open_recording(path) as recording:
            n = len(recording)
            if n == 0:
                raise UsageError(f"{path}: holds no frames")
            for i, frame in enumerate(recording):
                label = path if n == 1 else f"{path}#{i}"
                out.append(LabelledFrame(label, path, i, _header(frame)))
    return out


def frames_of(items: Sequence[LabelledFrame]) -> Iterator[SonarFrame]:
    """The full frames of ``items``, in order, one recording open at a time."""
    k = 0
    while k < len(items):
        path = items[k].path
        with open_recording(path) as recording:
            while k < len(items) and items[k].path == path:
                yield recording[items[k].index]
                k += 1


def resolve_altitudes(
    frames: Sequence[LabelledFrame], *, delta_h_m: float | None, altitude_m: float | None
) -> tuple[list[float], list[float]]:
    """Each frame's (altitude, altitude change from the first frame), m; NaN = unknown.

    Raises
    ------
    UsageError
        For ``--delta-h`` with other than two frames, frames without any altitude
        information, or frames all at one altitude; the message names the file.
    """
    n = len(frames)
    first_altitude = math.nan if altitude_m is None else float(altitude_m)
    if altitude_m is not None and not (math.isfinite(first_altitude) and first_altitude > 0):
        raise UsageError(f"--altitude must be a finite positive number of metres, got {altitude_m}")
    if delta_h_m is not None:
        if n != 2:
            raise UsageError(
                f"--delta-h needs exactly two frames, got {n} ({', '.join(f.label for f in frames)})"
            )
        if not math.isfinite(delta_h_m):
            raise UsageError(f"--delta-h must be finite, got {delta_h_m}")
        check_delta_h([f.label for f in frames], [f.frame for f in frames], delta_h_m, altitude_m)
        deltas = [0.0, float(delta_h_m)]
        altitudes = [first_altitude + d for d in deltas]
    elif all(f.frame.known("altitude_m") for f in frames):
        altitudes = [f.frame.altitude_m for f in frames]
        deltas = [a - altitudes[0] for a in altitudes]
    elif all(f.frame.known("sonar_depth_m") for f in frames):
        deltas = [frames[0].frame.sonar_depth_m - f.frame.sonar_depth_m for f in frames]
        altitudes = [first_altitude + d for d in deltas]
    else:
        neither = [
            f for f in frames if not (f.frame.known("altitude_m") or f.frame.known("sonar_depth_m"))
        ]
        lacking = neither[0] if neither else next(
            f for f in frames if not f.frame.known("sonar_depth_m")
        )
        raise UsageError(
            f"{lacking.label}: no altitude information (the frame lacks altitude_m and "
            "sonar_depth_m, or the files mix them); give --delta-h for two frames"
        )
    if n < 2 or float(np.ptp(deltas)) < SAME_ALTITUDE_M:
        raise UsageError(
            f"{frames[0].label}: all {n} frame(s) are at one altitude; heights need frames "
            "from at least two altitudes"
        )
    return altitudes, deltas


def _number(value: float | None, digits: int) -> float | None:
    if value is None or not math.isfinite(value):
        return None
    return round(float(value), digits)


def _with_labels(text: str, labels: Sequence[str]) -> str:
    """``text`` with each "frame i" of the pipeline's reasons named by its file label."""
    return re.sub(r"\bframe (\d+)", lambda m: labels[int(m.group(1))] if int(m.group(1)) < len(labels) else m.group(0),
                  text)


def target_record(target: TargetHeight, labels: Sequence[str] = ()) -> dict[str, Any]:
    """One target of the JSON document (required fields first, extras after).

    ``azimuth_deg`` and ``range_m`` are always numbers (heights-command.md); a target
    without a height has a ``reason`` naming the frames (by ``labels``) and what each lacked.
    """
    record: dict[str, Any] = {
        "azimuth_deg": round(float(math.degrees(target.azimuth_rad)), 3),
        "range_m": round(float(target.range_m), 5),
        "shadow_end_m": _number(target.shadow_end_m, 5),
        "height_m": _number(target.height_m, 5),
        "height_std_m": _number(target.height_std_m, 5),
        "frames_used": target.frames_used,
        "frames_seen": target.frames_seen,
        "first_frame": target.first_frame_index,
        "ref_altitude_m": _number(target.ref_altitude_m, 4),
        "shadow_start": target.shadow_start,
    }
    if target.frame_reasons:
        record["frame_reasons"] = [
            {"frame": labels[i] if i < len(labels) else i, "reason": _with_labels(why, labels)}
            for i, why in target.frame_reasons
        ]
    if target.height_m is None:
        record["reason"] = _with_labels(target.reason or "no height", labels)
    return record


def heights_document(
    frames: Sequence[LabelledFrame], deltas: Sequence[float], targets: Sequence[TargetHeight]
) -> dict[str, Any]:
    """The JSON document of ``heights-command.md``."""
    return {
        "frames": [f.label for f in frames],
        "delta_h_m": [round(float(d), 6) for d in deltas],
        "targets": [target_record(t, [f.label for f in frames]) for t in targets],
    }


def format_table(document: dict[str, Any]) -> str:
    """The human-readable table of a heights document."""
    lines = [
        f"{len(document['frames'])} frames, altitude changes "
        + ", ".join(f"{d:+.3f}" for d in document["delta_h_m"])
        + " m",
        f"{'#':>3} {'azimuth deg':>11} {'range m':>9} {'shadow end m':>12} "
        f"{'height cm':>10} {'std cm':>7} {'frames':>6}  note",
    ]

    def cell(value: float | None, scale: float, fmt: str, width: int) -> str:
        return f"{'-':>{width}}" if value is None else f"{value * scale:{width}{fmt}}"

    for i, t in enumerate(document["targets"]):
        lines.append(
            f"{i:>3} {cell(t['azimuth_deg'], 1, '.2f', 11)} {cell(t['range_m'], 1, '.4f', 9)} "
            f"{cell(t['shadow_end_m'], 1, '.4f', 12)} {cell(t['height_m'], 100, '.2f', 10)} "
            f"{cell(t['height_std_m'], 100, '.2f', 7)} {t['frames_used']:>6}  {t.get('reason', '')}"
        )
    if not document["targets"]:
        lines.append("no targets found")
    return "\n".join(lines)


def _write_json(out: str, document: dict[str, Any]) -> None:
    text = json.dumps(document, indent=2) + "\n"
    if out == "-":
        sys.stdout.write(text)
        return
    atomic_write_text(Path(out), text)


def compute(
    paths: Sequence[str], *, delta_h_m: float | None = None, altitude_m: float | None = None,
    rounded_targets: bool = False,
) -> dict[str, Any]:
    """Load, check and process the frames; returns the JSON document (``rounded_targets``:
    ``HeightsConfig.rounded_near_echo``)."""
    from perception.heights.pipeline import HeightPipeline, HeightsConfig  # the solvers: only when computing

    frames = load_all(paths)
    check_one_scene([f.label for f in frames], [f.frame for f in frames],
                    seabed_tolerance_m=HEIGHTS_SEABED_TOLERANCE_M)
    altitudes, deltas = resolve_altitudes(frames, delta_h_m=delta_h_m, altitude_m=altitude_m)
    check_altitudes([f.label for f in frames], [f.frame for f in frames], altitudes)
    pipeline = HeightPipeline(HeightsConfig(rounded_near_echo=rounded_targets))
    for frame, altitude, delta in zip(frames_of(frames), altitudes, deltas, strict=True):
        pipeline.add_frame(frame, altitude_m=altitude, delta_h_m=delta)
    reference = pipeline.shadows_reference_altitude() if not math.isfinite(altitudes[0]) else None
    if reference is not None and not reference[0] > 0.0:
        where = "--delta-h" if delta_h_m is not None else "the frames' sonar_depth_m"
        raise UsageError(f"{where}: the altitude changes ({', '.join(f'{d:+.3f}' for d in deltas)} m) put "
                         f"{frames[0].label} at {reference[0]:.2f} m above the seabed, below it: the sign is wrong "
                         "(the change is each altitude minus the first) or the frames are not of one scene")
    return heights_document(frames, deltas, pipeline.targets())


def run(args: argparse.Namespace) -> int:
    """Run the command; 0 on success (bad input raises and the CLI exits 2)."""
    document = compute(args.files, delta_h_m=args.delta_h, altitude_m=args.altitude,
                       rounded_targets=args.rounded_targets)
    table = format_table(document)
    if args.json == "-":
        print(table, file=sys.stderr)
    else:
        print(table)
    if args.json:
        _write_json(args.json, document)
    return 0
