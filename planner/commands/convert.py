"""``shadowsurvey convert IN OUT.npz [--frames START:STOP]``: recording to stacked .npz.

Writes the stacked form of ``frame-format.md`` (leading frame axis; shared ``range_m`` and
``beam_azimuth_deg`` stay 1-D), atomically, so any numpy user can read ARIS data.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from planner.errors import UsageError


def register(subparsers: Any) -> None:
    """Add the ``convert`` subcommand."""
    parser = subparsers.add_parser(
        "convert",
        help="convert a sonar recording (.aris or .npz) to one stacked .npz frame file",
        description=(
            "Convert a recording to the stacked .npz frame form (frame-format.md). "
            "--frames takes a Python slice of frame indices, e.g. 10:20, :100, 0:100:10; write "
            "a negative start as --frames=-5:."
        ),
    )
    parser.add_argument("input", help="recording to read (.aris or .npz)")
    parser.add_argument("output", help="stacked frame file to write (.npz)")
    parser.add_argument("--frames", metavar="START:STOP[:STEP]", help="frames to convert (Python slice)")
    parser.add_argument("--uncompressed", action="store_true", help="write with numpy.savez, not savez_compressed")
    parser.set_defaults(func=run)


def parse_frame_slice(text: str) -> slice:
    """Parse ``START:STOP[:STEP]`` (each part optional, integers, Python semantics).

    Raises
    ------
    UsageError
        For anything else, or a zero step.
    """
    parts = text.split(":")
    if len(parts) not in (2, 3):
        raise UsageError(f"--frames {text!r}: expected START:STOP or START:STOP:STEP")
    values: list[int | None] = []
    for part in parts:
        part = part.strip()
        if part == "":
            values.append(None)
            continue
        try:
            values.append(int(part))
        except ValueError:
            raise UsageError(f"--frames {text!r}: {part!r} is not an integer") from None
    if len(values) == 3 and values[2] == 0:
        raise UsageError(f"--frames {text!r}: step must not be zero")
    return slice(*values)


def run(args: argparse.Namespace) -> int:
    """Convert; 0 on success (bad input raises and the CLI exits 2)."""
    from perception.sonar_io.npz import save_frames
    from perception.sonar_io.readers import open_recording

    source = Path(args.input)
    target = Path(args.output)
    if target.suffix.lower() != ".npz":
        raise UsageError(f"{target}: output must be a .npz file")
    if target.exists() and source.exists() and target.resolve() == source.resolve():
        raise UsageError(f"{target}: output would overwrite the input")
    selection = parse_frame_slice(args.frames) if args.frames else slice(None)
    with open_recording(source) as recording:
        n = len(recording)
        indices = range(n)[selection]
        if args.frames is None and recording.truncation:
            raise UsageError(
                f"{source}: truncated recording ({recording.truncation}); the {n} complete "
                f"frames before it are readable: convert them with --frames 0:{n}"
            )
        if len(indices) == 0:
            raise UsageError(f"{source}: --frames {args.frames or ':'} selects none of its {n} frames")
        save_frames(target, (recording[i] for i in indices), compressed=not args.uncompressed)
    print(f"wrote {len(indices)} frames to {target}", file=sys.stderr)
    return 0
