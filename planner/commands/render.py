"""``shadowsurvey render``: simulated sonar frames of a scene, with their ground truth.

```
shadowsurvey render SCENE --altitude M [M ...] [--tilt-deg D] [--out DIR]
                    [--north-m N] [--east-m E] [--line N0 E0 N1 E1 --count K]
                    [--heading-deg H [H ...]] [--window-start-m S] [--window-length-m L]
                    [--samples N] [--speckle-looks L] [--noise-floor-db DB|none]
                    [--seed S] [--aris FILE] [--no-preview]
```

SCENE is a scene file (.toml/.json) or a built-in name (``paper-tank``, ``open-seabed``).
One frame per (position, heading, altitude), positions from the scene's viewpoint unless
``--north-m/--east-m`` or ``--line`` give them; frames are stamped 1 / frame rate apart from
t = 0. Without ``--tilt-deg`` the tilt is chosen per frame so that the targets in view
and their shadows sit in the vertical beam (:func:`sim_harness.sonar.viewpoint.choose_tilt_rad`).
Writes into DIR (default ``render-<scene>``):
``<scene>_<i>_alt<M>m.npz`` (frame-format.md, with ``altitude_m`` and ``sonar_depth_m``),
``<same>.truth.npz`` (label and owner images), ``<same>.png`` (preview: polar and fan side by
side) and ``truth.json`` (per frame: file, pose, per-target shadow truth).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from perception.atomic_file import atomic_write, atomic_write_bytes
from perception.errors import FrameFormatError
from perception.mapping.fan import frame_to_fan
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import save_frame
from planner.commands import args as args_types
from planner.errors import UsageError
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import builtin_scenes, load_scene
from sim_harness.sonar.truth import FrameTruth
from sim_harness.sonar.viewpoint import scene_pose
from sim_harness.world.errors import PoseError, SonarConfigError, WorldError

#: Height of the preview PNG, pixels (polar image left, fan image right).
PREVIEW_HEIGHT_PX = 800


def _noise_floor(text: str) -> float | None:
    if text.lower() == "none":
        return None
    return args_types.finite(text)


def register(subparsers: Any) -> None:
    """Add the ``render`` subcommand."""
    p = subparsers.add_parser(
        "render",
        help="render simulated sonar frames of a scene with ground truth",
        description=__doc__.split("```")[0].strip() if __doc__ else None,
    )
    p.add_argument("scene", metavar="SCENE", help=f"scene file or built-in name ({', '.join(builtin_scenes())})")
    p.add_argument("--altitude", type=args_types.positive, nargs="+", required=True, metavar="M",
                   help="sonar altitude(s) above the seabed, m")
    p.add_argument("--tilt-deg", type=args_types.number(-90.0, 90.0, unit="deg"), default=None,
                   help="mount tilt (down), deg; default: chosen")
    p.add_argument("--out", type=Path, default=None, help="output folder (default render-<scene>)")
    p.add_argument("--north-m", type=args_types.finite, default=None, help="sonar north, m (default: viewpoint)")
    p.add_argument("--east-m", type=args_types.finite, default=None, help="sonar east, m (default: viewpoint)")
    p.add_argument("--line", type=args_types.finite, nargs=4, metavar=("N0", "E0", "N1", "E1"), default=None,
                   help="sweep positions along a line (with --count)")
    p.add_argument("--count", type=args_types.integer(2, 100000), default=2, help="positions on --line (>= 2)")
    p.add_argument("--heading-deg", type=args_types.heading_deg, nargs="+", default=None, help="heading(s), deg")
    p.add_argument("--window-start-m", type=args_types.nonnegative, default=None,
                   help="range window start, m (scene/ARIS default)")
    p.add_argument("--window-length-m", type=args_types.positive, default=None, help="range window length, m")
    p.add_argument("--samples", type=args_types.integer(2, 100000), default=None, help="samples per beam")
    p.add_argument("--speckle-looks", type=args_types.nonnegative, default=None, help="speckle looks (0 = none)")
    p.add_argument("--noise-floor-db", type=_noise_floor, default="12", help="noise floor, dB, or 'none'")
    p.add_argument("--seed", type=args_types.integer(0, 2**32 - 1), default=0)
    p.add_argument("--aris", type=Path, default=None, help="also write all frames as one .aris file")
    p.add_argument("--no-preview", action="store_true", help="skip the PNG previews")
    p.set_defaults(func=run)


def _config(args: argparse.Namespace, scene_sonar: dict[str, float]) -> SonarConfig:
    changes: dict[str, Any] = dict(scene_sonar)
    for arg, key in (("window_start_m", "window_start_m"), ("window_length_m", "window_length_m"),
                     ("samples", "samples_per_beam"), ("speckle_looks", "speckle_looks")):
        value = getattr(args, arg)
        if value is not None:
            changes[key] = value
    changes["noise_floor_db"] = args.noise_floor_db
    changes["seed"] = args.seed
    if "samples_per_beam" in changes:
        changes["samples_per_beam"] = int(changes["samples_per_beam"])
    config = SonarConfig(**changes)
    if args.aris is not None:
        from perception.sonar_io.aris.reader import aris_grid

        _, _, grid = aris_grid(config.window_start_m, config.window_end_m,
                               config.samples_per_beam, config.sound_speed_m_s)
        config = config.with_range_grid(grid)
    return config


def _positions(args: argparse.Namespace) -> list[tuple[float | None, float | None]]:
    if args.line is None:
        return [(args.north_m, args.east_m)]
    if args.count < 2:
        raise UsageError(f"--count must be >= 2 with --line, got {args.count}")
    n0, e0, n1, e1 = args.line
    return [(n0 + (n1 - n0) * f, e0 + (e1 - e0) * f) for f in np.linspace(0.0, 1.0, args.count)]


def preview_image(frame: SonarFrame) -> np.ndarray:
    """Polar (near range at the bottom) and fan images side by side, uint8 BGR."""
    polar = np.flipud(np.asarray(frame.image))
    polar = cv2.resize(polar, (4 * frame.n_beams, PREVIEW_HEIGHT_PX), interpolation=cv2.INTER_AREA)
    fan, _ = frame_to_fan(frame, width_px=PREVIEW_HEIGHT_PX)
    scale = PREVIEW_HEIGHT_PX / fan.shape[0]
    fan = cv2.resize(fan, (max(1, round(fan.shape[1] * scale)), PREVIEW_HEIGHT_PX), interpolation=cv2.INTER_AREA)
    gap = np.zeros((PREVIEW_HEIGHT_PX, 16), dtype=np.uint8)
    both = np.hstack([polar, gap, fan])
    return cv2.applyColorMap(both, cv2.COLORMAP_BONE)


def _write_png(path: Path, image: np.ndarray) -> None:
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise OSError(f"{path}: PNG encoding failed")
    atomic_write_bytes(path, data.tobytes())


def run(args: argparse.Namespace) -> int:
    """Render the frames; returns the exit code (2, naming the scene, when it cannot be rendered)."""
    try:
        return _render(args)
    except (PoseError, SonarConfigError, WorldError, FrameFormatError) as exc:
        raise UsageError(f"{args.scene}: cannot render this scene with these options: {exc}") from exc


def _render(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene)
    config = _config(args, scene.sonar)
    renderer = SonarRenderer(scene.world, config)
    out = args.out if args.out is not None else Path(f"render-{scene.name}")
    out.mkdir(parents=True, exist_ok=True)
    headings = [None] if args.heading_deg is None else [math.radians(h) for h in args.heading_deg]
    tilt = None if args.tilt_deg is None else math.radians(args.tilt_deg)
    records: list[dict[str, Any]] = []
    frames: list[SonarFrame] = []
    index = 0
    for north, east in _positions(args):
        for heading in headings:
            for altitude in args.altitude:
                pose: SonarPose = scene_pose(scene, altitude, config, north_m=north, east_m=east,
                                             heading_rad=heading, tilt_rad=tilt)
                timestamp = index / config.frame_rate_hz
                frame, truth = renderer.render(pose, timestamp, altitude_m=altitude)
                stem = f"{scene.name}_{index:03d}_alt{altitude:.2f}m"
                save_frame(out / f"{stem}.npz", frame)
                _save_truth_images(out / f"{stem}.truth.npz", truth)
                if not args.no_preview:
                    _write_png(out / f"{stem}.png", preview_image(frame))
                record = {"frame": f"{stem}.npz", "labels": f"{stem}.truth.npz", **truth.to_json_dict()}
                records.append(record)
                frames.append(frame)
                seen = ", ".join(
                    f"{t.target_id}: {t.central_shadow_start_m:.3f}-{t.central_shadow_end_m:.3f} m"
                    f"{'' if t.whole_shadow_in_band and t.whole_shadow_in_window else ' (partial)'}"
                    for t in truth.targets
                )
                print(f"{stem}.npz  altitude {altitude:.3f} m  tilt {math.degrees(pose.tilt_rad):.1f} deg"
                      f"  depth {pose.depth_m:.3f} m  shadows: {seen or 'none'}")
                index += 1
    document = {
        "scene": scene.name,
        "scene_source": scene.source,
        "sonar": _config_json(config),
        "frames": records,
    }
    atomic_write_bytes(out / "truth.json", json.dumps(document, indent=1).encode("utf-8"))
    if args.aris is not None:
        from perception.sonar_io.aris.reader import write_aris

        write_aris(args.aris, frames, sound_speed_m_s=config.sound_speed_m_s)
        print(f"wrote {args.aris}")
    print(f"wrote {index} frame(s) and truth.json to {out}")
    return 0


def _save_truth_images(path: Path, truth: FrameTruth) -> None:
    atomic_write(path, lambda handle: np.savez_compressed(handle, labels=truth.labels, owner=truth.owner))


def _config_json(config: SonarConfig) -> dict[str, Any]:
    return {
        "n_beams": config.n_beams,
        "samples_per_beam": config.samples_per_beam,
        "window_start_m": config.window_start_m,
        "window_length_m": config.window_length_m,
        "elevation_aperture_deg": math.degrees(config.elevation_aperture_rad),
        "sound_speed_m_s": config.sound_speed_m_s,
        "speckle_looks": config.speckle_looks,
        "noise_floor_db": config.noise_floor_db,
        "seed": config.seed,
    }
