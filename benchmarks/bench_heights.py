"""Heights from rendered frames: segmentation IoU, height accuracy, recall, speed.

(Over 400 lines: one benchmark section per scenario, each a few dozen lines writing its
rows of ``benchmarks/README.md``; the model-family sweep is :mod:`benchmarks.bench_heights_models`.)

All frames come from ``sim_harness``'s sonar renderer (ARIS 3000, 128 beams, speckle on)
with its ground truth; perception sees only the frames.

- Paper tank (built-in scene ``paper-tank``, Table I targets), 0.5 m and 0.6 m altitude
  (dH = 0.1 m): heights with the altitude known, with the altitude withheld (only dH from
  the depth gauge, the paper's setting), and the paper's classical adaptive threshold +
  whole-pixel edges + Eq. 2 on the same frames; next to the paper's Table III errors.
- Stones (rounded targets) at the same geometry: the bias of the moving shadow-casting
  point and whether the reported standard deviation covers it.
- Random scenes: 1-3 boxes/cylinders 2-30 cm high, altitude 0.4-2.5 m, dH 0.05-0.3 m.
- Shadow and highlight IoU against the label images, ours and the classical baseline.
- Speed of segmentation + pairing + measurement on a 128 x 2000 frame.

Run: ``python -m benchmarks.bench_heights [--pings N] [--scenes N]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from perception.heights.pipeline import HeightPipeline, HeightsConfig, TargetHeight, detect_shadows
from perception.heights.solver import eq2_paper
from perception.shadows.pairing.pair import pair_regions
from perception.shadows.segmentation.segment import SegmentationConfig, mask_iou, segment
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import save_frame
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import load_scene
from sim_harness.sonar.truth import FrameTruth, Label, TargetTruth
from sim_harness.sonar.viewpoint import choose_tilt_rad
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import Seabed, TargetSpec, World

TABLES = Path(__file__).resolve().parent.parent / "tests" / "data" / "paper_tables.json"
PAPER_ALTITUDES_M = (0.5, 0.6)
AZIMUTH_MATCH_RAD = math.radians(2.5)


@dataclass(frozen=True)
class Shot:
    frame: SonarFrame
    truth: FrameTruth


def _config_for(scene_sonar: dict[str, float], **changes: float) -> SonarConfig:
    keys = {"window_start_m", "window_length_m", "samples_per_beam", "sound_speed_m_s"}
    base = SonarConfig(**{k: v for k, v in scene_sonar.items() if k in keys})  # type: ignore[arg-type]
    return replace(base, **changes)  # type: ignore[arg-type]


def render_pair(
    world: World,
    config: SonarConfig,
    altitudes_m: Sequence[float],
    *,
    pings: int,
    north_m: float = 0.0,
    east_m: float = 0.0,
    t0_s: float = 1000.0,
) -> list[Shot]:
    """``pings`` frames at each altitude (same tilt, chosen at the mean altitude)."""
    renderer = SonarRenderer(world, config)
    tilt = choose_tilt_rad(
        world, north_m=north_m, east_m=east_m, altitude_m=float(np.mean(altitudes_m)),
        heading_rad=0.0, pitch_rad=0.0, config=config,
    )
    shots = []
    k = 0
    for altitude in altitudes_m:
        depth = world.seabed_depth_m(north_m, east_m) - altitude
        for _ in range(pings):
            frame, truth = renderer.render(SonarPose(north_m, east_m, depth, tilt_rad=tilt), t0_s + 0.1 * k)
            shots.append(Shot(frame, truth))
            k += 1
    return shots


def run_pipeline(shots: Sequence[Shot], *, withhold_altitude: bool) -> list[TargetHeight]:
    """Heights from the frames (altitude withheld: only the depth gauge's changes)."""
    pipeline = HeightPipeline(HeightsConfig())
    for shot in shots:
        frame = shot.frame
        if withhold_altitude:
            frame = frame.with_fields(altitude_m=math.nan)
        pipeline.add_frame(frame)
    return pipeline.targets()


def match(targets: Sequence[TargetHeight], truth: TargetTruth) -> TargetHeight | None:
    """The reported target nearest the truth in azimuth (None beyond 2.5 deg)."""
    candidates = [t for t in targets if abs(t.azimuth_rad - truth.azimuth_rad) < AZIMUTH_MATCH_RAD]
    if not candidates:
        return None
    if math.isfinite(truth.central_shadow_start_m):
        return min(candidates, key=lambda t: abs(t.range_m - truth.central_shadow_start_m)
                   if math.isfinite(t.range_m) else math.inf)
    return min(candidates, key=lambda t: abs(t.azimuth_rad - truth.azimuth_rad))


def classical_eq2(first: Shot, second: Shot) -> dict[str, float]:
    """The paper's baseline: adaptive threshold, whole-pixel edges, Eq. 2 (by target id)."""
    cfg = SegmentationConfig(method="classical")
    found: list[dict[float, tuple[float, float]]] = []
    for shot in (first, second):
        seg = segment(shot.frame.image, config=cfg)
        per_azimuth: dict[float, tuple[float, float]] = {}
        for pair in pair_regions(seg):
            col = sorted(pair.columns)[len(pair.columns) // 2]
            rows = np.flatnonzero(seg.shadow_labels[:, col] == pair.shadow.label)
            r = shot.frame.range_m
            start, end = float(r[rows[0]]), float(r[rows[-1]])
            per_azimuth[float(shot.frame.beam_azimuth_rad[col])] = (start, end - start)
        found.append(per_azimuth)
    delta_h = first.truth.altitude_m - second.truth.altitude_m
    out: dict[str, float] = {}
    for truth in first.truth.targets:
        picks = []
        for per_azimuth in found:
            near = [a for a in per_azimuth if abs(a - truth.azimuth_rad) < AZIMUTH_MATCH_RAD]
            if not near:
                break
            picks.append(per_azimuth[min(near, key=lambda a: abs(a - truth.azimuth_rad))])
        if len(picks) == 2:
            (r1, l1), (r2, l2) = picks
            try:
                out[truth.target_id] = abs(eq2_paper(r1, l1, r2, l2, delta_h))
            except ValueError:
                continue
    return out


def _cm(value: float | None) -> str:
    return "-" if value is None else f"{value * 100:+.3f}"


def paper_tank(pings: int, trials: int = 4) -> tuple[list[str], list[Shot]]:
    """The Table I targets in the paper tank: the accuracy table, over independent trials.

    ``trials * pings`` pings are rendered at each altitude; trial k uses its own pings, so
    the trials' speckle is independent. Cells: mean signed error over the trials and, in
    brackets, the largest |error| of the trials; summary: mean |error| over all targets and
    trials, and the largest |error|.
    """
    scene = load_scene("paper-tank")
    config = _config_for(scene.sonar, seed=11)
    n = pings * trials
    shots = render_pair(scene.world, config, PAPER_ALTITUDES_M, pings=n)
    low, high = shots[:n], shots[n:]
    truths = {t.target_id: t for t in shots[0].truth.targets}
    ids = sorted(truths)

    def trial_sets(per_altitude: int) -> list[list[Shot]]:
        return [
            low[k * per_altitude : (k + 1) * per_altitude] + high[k * per_altitude : (k + 1) * per_altitude]
            for k in range(n // per_altitude)
        ]

    methods = [
        ("known", 1, False), ("known", pings, False),
        ("withheld (dH only)", 1, True), ("withheld (dH only)", pings, True),
    ]
    lines = [
        "Heights of the five Table I targets (scene `paper-tank`, ARIS 3000 128 beams, 1000 "
        f"samples over 0.7-3.0 m, altitudes {PAPER_ALTITUDES_M[0]} and {PAPER_ALTITUDES_M[1]} m, "
        "speckle on). Error = estimate - truth, cm. Each of our rows is over independent "
        "trials (own pings, own speckle): cell = mean error [largest |error|]; `covered` = "
        "share of |error| <= 2 x the reported sigma.",
        "",
        "| method | trials | " + " | ".join(f"T{i} ({truths[i].height_m * 100:.1f} cm)" for i in ids)
        + " | mean abs err cm | max abs err cm | covered |",
        "| --- | --- |" + " --- |" * (len(ids) + 3),
    ]
    for name, per_altitude, withhold in methods:
        sets = trial_sets(per_altitude)
        errors: dict[str, list[float]] = {i: [] for i in ids}
        covered = total = 0
        for shots_k in sets:
            targets = run_pipeline(shots_k, withhold_altitude=withhold)
            for i in ids:
                t = match(targets, truths[i])
                if t is None or t.height_m is None or t.height_std_m is None:
                    continue
                err = t.height_m - truths[i].height_m
                errors[i].append(err)
                covered += abs(err) <= 2 * t.height_std_m
                total += 1
        cells = [
            f"{statistics.mean(e) * 100:+.3f} [{max(abs(v) for v in e) * 100:.3f}]"
            + ("" if len(e) == len(sets) else f" ({len(sets) - len(e)} missed)")
            if e else "missed"
            for e in (errors[i] for i in ids)
        ]
        flat = [abs(v) for e in errors.values() for v in e]
        summary = f"{statistics.mean(flat) * 100:.3f} | {max(flat) * 100:.3f}" if flat else "- | -"
        lines.append(
            f"| ours, altitude {name}, {per_altitude} ping(s)/altitude | {len(sets)} | "
            + " | ".join(cells) + f" | {summary} | {covered}/{total} |"
        )
    baseline = classical_eq2(low[0], high[0])
    cells, flat = [], []
    for i in ids:
        if i in baseline:
            err = baseline[i] - truths[i].height_m
            flat.append(abs(err))
            cells.append(f"{err * 100:+.3f}")
        else:
            cells.append("missed")
    summary = f"{statistics.mean(flat) * 100:.3f} | {max(flat) * 100:.3f}" if flat else "- | -"
    lines.append(
        "| paper's adaptive threshold + Eq. 2, 1 ping/altitude | 1 | " + " | ".join(cells)
        + f" | {summary} | - |"
    )
    lines.extend(_paper_rows(len(ids)))
    return lines, [low[0], high[0], *low[1:pings], *high[1:pings]]


def _paper_rows(n: int) -> list[str]:
    if not TABLES.is_file():
        return []
    rows = json.loads(TABLES.read_text())["table_III_rows"]
    out = []
    for kind, label in (("tank-cartesian", "tank, Cartesian"), ("tank-polar", "tank, polar"),
                        ("simulated", "simulated")):
        errs = [r["err_cm"] for r in rows if r["kind"] == kind]
        cells = [f"{-e:+.3f}" for e in errs][:n]
        mean = statistics.mean(abs(e) for e in errs)
        out.append(f"| paper's Table III, {label} | 1 | " + " | ".join(cells)
                   + f" | {mean:.3f} | {max(abs(e) for e in errs):.3f} | - |")
    return out


def stones(pings: int) -> list[str]:
    """Rounded targets: the viewpoint-dependent shadow-casting point."""
    specs = tuple(
        TargetSpec(f"S{i}", "stone", 1.2 + 0.1 * (i % 2), -0.24 + 0.12 * i, length, width, height,
                   material="rock")
        for i, (length, width, height) in enumerate(
            [(0.10, 0.08, 0.04), (0.12, 0.10, 0.06), (0.08, 0.08, 0.03), (0.15, 0.10, 0.08),
             (0.10, 0.07, 0.05)]
        )
    )
    world = World(seabed=Seabed(depth_m=0.85), targets=specs)
    shots = render_pair(world, SonarConfig(seed=5), PAPER_ALTITUDES_M, pings=pings)
    lines = [
        "",
        f"Stones (half-ellipsoids, 3-8 cm high), altitudes {PAPER_ALTITUDES_M} m, {pings} "
        "pings/altitude. Error = estimate - truth, cm; covered = |error| <= 2 x reported sigma.",
        "",
        "| altitude | mean error cm | mean abs error cm | max abs error cm | covered by 2 sigma |",
        "| --- | --- | --- | --- | --- |",
    ]
    for withhold in (False, True):
        targets = run_pipeline(shots, withhold_altitude=withhold)
        errs, covered = [], 0
        for truth in shots[0].truth.targets:
            t = match(targets, truth)
            if t is None or t.height_m is None or t.height_std_m is None:
                continue
            err = t.height_m - truth.height_m
            errs.append(err)
            covered += abs(err) <= 2 * t.height_std_m
        if errs:
            lines.append(
                f"| {'withheld (dH only)' if withhold else 'known'} | {statistics.mean(errs) * 100:+.3f} | "
                f"{statistics.mean(abs(e) for e in errs) * 100:.3f} | {max(abs(e) for e in errs) * 100:.3f} | "
                f"{covered}/{len(errs)} |"
            )
    return lines


def random_scene(rng: np.random.Generator, index: int) -> tuple[World, SonarConfig, tuple[float, float]]:
    """1-3 boxes or cylinders ahead of a sonar at a random altitude pair.

    Heights 2-30 cm but at most 0.35 x the altitude; footprints 3-10 % of the range.
    """
    altitude = float(rng.uniform(0.4, 2.5))
    delta_h = float(rng.uniform(0.05, 0.3))
    n = int(rng.integers(1, 4))
    azimuths = rng.permutation(np.linspace(-10.0, 10.0, 5))[:n]
    specs = []
    for k, az_deg in enumerate(azimuths):
        # The sonar stays well above the target (h <= 0.35 H) and a target spans at most
        # ~6 deg of the 30 deg fan.
        height = float(rng.uniform(0.02, min(0.30, 0.35 * altitude)))
        ground = altitude / math.tan(math.radians(float(rng.uniform(19.0, 24.0))))
        size = float(rng.uniform(0.3, 1.0)) * 0.1 * ground
        az = math.radians(float(az_deg))
        shape = "box" if rng.random() < 0.7 else "cylinder"
        specs.append(TargetSpec(f"R{index}_{k}", shape, ground * math.cos(az), ground * math.sin(az),
                                size, size * float(rng.uniform(0.5, 1.0)), height,
                                yaw_rad=float(rng.uniform(-0.5, 0.5))))
    world = World(seabed=Seabed(depth_m=altitude + delta_h + 1.0), targets=tuple(specs))
    near = altitude / math.sin(math.radians(32.0))
    far = (altitude + delta_h) / math.sin(math.radians(12.0))
    config = SonarConfig(window_start_m=0.9 * near, window_length_m=min(far, 1.35 * near + 2.0) - 0.9 * near,
                         samples_per_beam=2000, seed=index)
    return world, config, (altitude, altitude + delta_h)


@dataclass(frozen=True)
class RandomFigures:
    """Detection and accuracy over one set of random scenes."""

    rel_errors: tuple[float, ...]
    n_truth: int
    n_found: int
    n_false: int
    n_frames: int
    n_false_empty: int = 0
    n_frames_empty: int = 0


def _textured(world: World, index: int, texture_db: float) -> World:
    """``world`` on a seabed with a persistent texture (``texture_db``, 10 cm patches)."""
    texture = SeabedTexture(std_db=texture_db, correlation_m=0.1, seed=100 + index)
    return replace(world, seabed=replace(world.seabed, texture=texture))


def _false_detections(shot: Shot) -> int:
    """Detections farther than 2.5 deg in azimuth from every target of the frame."""
    found = detect_shadows(shot.frame.image, range_m=shot.frame.range_m,
                           beam_azimuth_rad=shot.frame.beam_azimuth_rad)
    return sum(not any(abs(m.azimuth_rad - t.azimuth_rad) < AZIMUTH_MATCH_RAD for t in shot.truth.targets)
               for m in found)


def random_figures(count: int, *, texture_db: float = 0.0) -> tuple[RandomFigures, list[Shot]]:
    """Recall, false positives and relative errors over ``count`` random scenes.

    With ``texture_db`` > 0 the seabed carries the renderer's persistent texture (std
    ``texture_db`` dB, 10 cm patches), and the same frames are also rendered without
    their targets, for the false detections of a textured seabed alone.
    """
    rng = np.random.default_rng(20261123)
    rel_errors: list[float] = []
    n_truth = n_found = n_false = n_frames = n_false_empty = n_frames_empty = 0
    all_shots: list[Shot] = []
    for index in range(count):
        world, config, altitudes = random_scene(rng, index)
        if texture_db > 0:
            world = _textured(world, index, texture_db)
            for shot in render_pair(replace(world, targets=()), config, altitudes, pings=1):
                n_frames_empty += 1
                n_false_empty += _false_detections(shot)
        shots = render_pair(world, config, altitudes, pings=1)
        all_shots.extend(shots)
        n_frames += len(shots)
        targets = run_pipeline(shots, withhold_altitude=False)
        complete = [
            t for t in shots[0].truth.targets
            if t.whole_shadow_in_band and t.whole_shadow_in_window
            and any(u.target_id == t.target_id and u.whole_shadow_in_band and u.whole_shadow_in_window
                    for u in shots[1].truth.targets)
        ]
        for truth in complete:
            n_truth += 1
            t = match(targets, truth)
            if t is not None and t.height_m is not None:
                n_found += 1
                rel_errors.append(abs(t.height_m - truth.height_m) / truth.height_m)
        n_false += sum(_false_detections(shot) for shot in shots)
    figures = RandomFigures(tuple(rel_errors), n_truth, n_found, n_false, n_frames, n_false_empty, n_frames_empty)
    return figures, all_shots


def random_scenes(count: int, *, texture_db: float = 3.0) -> tuple[list[str], list[Shot]]:
    """The random-scene table: a bare seabed and one with a ``texture_db`` texture."""
    plain, all_shots = random_figures(count)
    textured, _ = random_figures(count, texture_db=texture_db)

    def cells(f: RandomFigures) -> tuple[str, str, str, str]:
        rel = np.array(f.rel_errors)
        return (
            f"{np.median(rel) * 100:.2f} %" if rel.size else "-",
            f"{np.percentile(rel, 95) * 100:.2f} %" if rel.size else "-",
            f"{f.n_found}/{f.n_truth} = {f.n_found / max(f.n_truth, 1):.3f}",
            f"{f.n_false}/{f.n_frames} = {f.n_false / max(f.n_frames, 1):.3f}",
        )

    a, b = cells(plain), cells(textured)
    lines = [
        "",
        f"Random scenes: {count} scenes, 1-3 boxes/cylinders 2-30 cm high (<= 0.35 x altitude), "
        "footprint 3-10 % of the range, altitude 0.4-2.5 m, "
        "dH 0.05-0.3 m, one ping per altitude, altitude known, 2000 samples per beam; "
        f"the same scenes on a textured seabed (persistent texture {texture_db:g} dB, 10 cm patches, "
        "as the `open-seabed` scene), and those textured frames without their targets.",
        "",
        f"| measure | bare seabed | textured seabed ({texture_db:g} dB) | goal |",
        "| --- | --- | --- | --- |",
        f"| median relative height error | {a[0]} | {b[0]} | <= 3 % |",
        f"| 95th percentile relative error | {a[1]} | {b[1]} | <= 10 % |",
        f"| detection recall (whole shadows in both frames) | {a[2]} | {b[2]} | >= 0.97 |",
        f"| false positives per frame | {a[3]} | {b[3]} | <= 0.05 |",
        f"| false positives per frame, textured frames without targets | - | "
        f"{textured.n_false_empty}/{textured.n_frames_empty} = "
        f"{textured.n_false_empty / max(textured.n_frames_empty, 1):.3f} | <= 0.05 |",
    ]
    return lines, all_shots


def open_seabed(count: int = 30) -> list[str]:
    """False detections in frames of the shipped ``open-seabed`` scene (3 dB texture).

    ``count`` frames along the scene's survey area (0.5 m apart north, five lanes 1.5 m
    apart east, altitudes 1.0-1.75 m), with and without the scene's twelve targets.
    """
    scene = load_scene("open-seabed")
    config = _config_for(scene.sonar, seed=3)
    counts = []
    for world in (scene.world, replace(scene.world, targets=())):
        renderer = SonarRenderer(world, config)
        n_false = 0
        for k in range(count):
            north = scene.viewpoint.north_m + 0.5 * k
            east = scene.viewpoint.east_m + (k % 5 - 2) * 1.5
            altitude = 1.0 + 0.25 * (k % 4)
            tilt = choose_tilt_rad(world, north_m=north, east_m=east, altitude_m=altitude, heading_rad=0.0,
                                   pitch_rad=0.0, config=config)
            depth = world.seabed_depth_m(north, east) - altitude
            frame, truth = renderer.render(SonarPose(north, east, depth, tilt_rad=tilt), 10.0 + 0.1 * k)
            n_false += _false_detections(Shot(frame, truth))
        counts.append(n_false)
    return [
        "",
        f"Shipped scene `open-seabed` (texture 3 dB, 10 cm patches), {count} frames of "
        f"{config.samples_per_beam} samples along its area: false positives {counts[0]}/{count} = "
        f"{counts[0] / count:.3f} per frame with its targets, {counts[1]}/{count} = {counts[1] / count:.3f} "
        "without them (goal <= 0.05).",
    ]


def iou_table(paper: Sequence[Shot], rand: Sequence[Shot]) -> list[str]:
    """Shadow and highlight IoU against the renderer's labels, ours vs classical."""
    lines = [
        "",
        "Segmentation against the renderer's label images (mean IoU over frames):",
        "",
        "| frames | method | shadow IoU | highlight IoU |",
        "| --- | --- | --- | --- |",
    ]
    for name, shots in (("paper tank", paper), ("random scenes", rand)):
        for method in ("speckle", "classical"):
            cfg = SegmentationConfig(method=method)
            shadow, highlight = [], []
            for shot in shots:
                seg = segment(shot.frame.image, config=cfg)
                shadow.append(mask_iou(seg.shadow_mask, shot.truth.labels == Label.SHADOW))
                highlight.append(mask_iou(seg.highlight_mask, shot.truth.labels == Label.HIGHLIGHT))
            label = "ours (speckle-aware)" if method == "speckle" else "paper's adaptive threshold"
            lines.append(f"| {name} ({len(shots)}) | {label} | {np.mean(shadow):.3f} | {np.mean(highlight):.3f} |")
    return lines


def _reference_workload() -> None:
    """A fixed numpy + Python workload (about 1 ms), timed between the frames so that the
    host's own speed changes show beside the pipeline's."""
    values = np.arange(4096, dtype=np.float64)[::-1].copy()
    for _ in range(8):
        np.sort(values)
    total = 0
    for i in range(3000):
        total += i * i


def speed(repeats: int = 400) -> list[str]:
    """Segmentation + pairing + measurement of one 128 x 2000 frame.

    Reported: median, 25th percentile and best wall time, median CPU time, the load
    average, and the median and best of a fixed reference workload timed in turn with the
    frames (on a shared virtual machine the host's speed changes from minute to minute: a
    run whose reference is slower than usual, or spreads as far above its best as the
    pipeline does, was slowed by the host, not the code); also the same with every row
    segmented (``detection_rows=0``).
    """
    scene = load_scene("paper-tank")
    config = _config_for(scene.sonar, samples_per_beam=2000, seed=2)
    (shot,) = render_pair(scene.world, config, (0.5,), pings=1)
    frame = shot.frame
    lines = [""]
    for name, cfg in (("detection grid (default)", HeightsConfig()),):
        for _ in range(20):
            detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad, config=cfg)
            _reference_workload()
        wall, cpu, ref = [], [], []
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            found = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad,
                                   config=cfg)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            t1 = time.perf_counter()
            _reference_workload()
            ref.append(time.perf_counter() - t1)
        load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
        w, r = np.array(wall) * 1e3, np.array(ref) * 1e3
        lines.append(
            f"Speed, {name}: paper tank frame of {frame.n_beams} beams x {frame.n_samples} samples "
            f"({len(found)} targets), {repeats} runs: median {np.median(w):.2f} ms wall "
            f"(25th percentile {np.percentile(w, 25):.2f} ms, best {np.min(w):.2f} ms), median "
            f"{np.median(cpu) * 1e3:.2f} ms CPU (goal <= 1.5 ms on one core); reference workload median "
            f"{np.median(r):.2f} ms, best {np.min(r):.2f} ms (ratio {np.median(r) / np.min(r):.2f}: the host's "
            f"spread; pipeline {np.median(w) / np.min(w):.2f}); "
            f"load average {load}. Machine: {platform.machine()}, Python {platform.python_version()}."
        )
        lines.append("")
    return lines[:-1]


def run(pings: int = 4, scenes: int = 100) -> str:
    """The Markdown section."""
    lines = ["## heights", ""]
    paper_lines, paper_shots = paper_tank(pings)
    lines.extend(paper_lines)
    lines.extend(stones(pings))
    random_lines, random_shots = random_scenes(scenes)
    lines.extend(random_lines)
    lines.extend(open_seabed())
    lines.extend(iou_table(paper_shots, random_shots))
    lines.extend(speed())
    lines.append("")
    lines.append(f"Repeat: `python -m benchmarks.bench_heights --pings {pings} --scenes {scenes}`.")
    return "\n".join(line for line in lines if line is not None)


def write_paper_examples(folder: Path) -> list[Path]:
    """Render the two example frames shipped for ``shadowsurvey heights`` (paper tank).

    One ping at 0.50 m and one at 0.60 m altitude, same tilt, compressed uint8 ``.npz``
    with the depth gauge and altimeter readings the renderer reports.
    """
    scene = load_scene("paper-tank")
    config = _config_for(scene.sonar, seed=7)
    shots = render_pair(scene.world, config, PAPER_ALTITUDES_M, pings=1)
    paths = []
    for shot in shots:
        path = folder / f"paper_tank_{shot.truth.altitude_m:.2f}m.npz"
        save_frame(path, shot.frame, compressed=True)
        paths.append(path)
    return paths


def main() -> None:
    """Print the Markdown section of figures."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_heights")
    parser.add_argument(
        "--write-examples", metavar="DIR", type=Path,
        help="only write the two paper-tank example frames into DIR",
    )
    parser.add_argument("--pings", type=int, default=4, help="pings per altitude (paper tank, stones)")
    parser.add_argument("--scenes", type=int, default=100, help="random scenes")
    parser.add_argument("--speed-only", action="store_true",
                        help="only the speed figures (pin to one core: taskset -c 1)")
    args = parser.parse_args()
    if args.write_examples is not None:
        for path in write_paper_examples(args.write_examples):
            print(path)
        return
    if args.speed_only:
        print("\n".join(speed()))
        return
    print(run(pings=args.pings, scenes=args.scenes))


if __name__ == "__main__":
    main()
