"""Heights with only the altitude CHANGE known (the paper's setting), before and after.

Frames from ``sim_harness``'s renderer (ARIS 3000, 128 beams, speckle on), the same as
:mod:`benchmarks.bench_heights` (whose helpers are reused): the five Table I targets in
the paper tank at 0.5 and 0.6 m altitude, and five stones (half-ellipsoids) at the same
geometry. The frames' ``altitude_m`` is withheld, so the pipeline knows only the depth
gauge's change dH; "before" is the shadows-only shared reference altitude, "after" adds
the seabed onset's altitude (``HeightsConfig.seabed_onset_altitude``) and the
rounded-target model. The altitude-known rows are printed to show they do not change.

Also the random scenes of :mod:`benchmarks.bench_heights` with the altitude withheld.

Run: ``python -m benchmarks.bench_heights_dh [--pings N] [--trials N] [--scenes N]``.
"""

from __future__ import annotations

import argparse
import math
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from benchmarks.bench_heights import PAPER_ALTITUDES_M, Shot, _config_for, match, random_scene, render_pair
from perception.heights.pipeline import HeightPipeline, HeightsConfig, TargetHeight
from sim_harness.sonar.renderer import SonarConfig
from sim_harness.sonar.scene import load_scene
from sim_harness.sonar.truth import TargetTruth
from sim_harness.world.world import Seabed, TargetSpec, World

BEFORE = HeightsConfig(seabed_onset_altitude=False, rounded_targets=False, edge_bias_samples=0.0)
AFTER = HeightsConfig()
SUMMIT = HeightsConfig(rounded_summit=True)


@dataclass(frozen=True)
class Score:
    """Errors (estimate - truth, m) and 2-sigma coverage over targets and trials."""

    errors: dict[str, list[float]]
    sigmas: list[float]
    covered: int
    total: int
    missed: int

    @property
    def flat(self) -> list[float]:
        return [v for e in self.errors.values() for v in e]


def heights(shots: Sequence[Shot], config: HeightsConfig, *, withhold_altitude: bool) -> list[TargetHeight]:
    """The pipeline's targets for ``shots`` (altitude withheld: depth-gauge changes only)."""
    pipeline = HeightPipeline(config)
    for shot in shots:
        frame = shot.frame.with_fields(altitude_m=math.nan) if withhold_altitude else shot.frame
        pipeline.add_frame(frame)
    return pipeline.targets()


def score(
    trial_sets: Sequence[Sequence[Shot]],
    truths: Sequence[TargetTruth],
    config: HeightsConfig,
    *,
    withhold_altitude: bool,
) -> Score:
    errors: dict[str, list[float]] = {t.target_id: [] for t in truths}
    sigmas: list[float] = []
    covered = total = missed = 0
    for shots in trial_sets:
        targets = heights(shots, config, withhold_altitude=withhold_altitude)
        for truth in truths:
            t = match(targets, truth)
            if t is None or t.height_m is None or t.height_std_m is None:
                missed += 1
                continue
            err = t.height_m - truth.height_m
            errors[truth.target_id].append(err)
            sigmas.append(t.height_std_m)
            covered += abs(err) <= 2 * t.height_std_m
            total += 1
    return Score(errors, sigmas, covered, total, missed)


def _row(label: str, n_trials: int, s: Score, ids: Sequence[str]) -> str:
    cells = [
        f"{statistics.mean(s.errors[i]) * 100:+.3f} [{max(abs(v) for v in s.errors[i]) * 100:.3f}]"
        if s.errors[i]
        else "missed"
        for i in ids
    ]
    flat = [abs(v) for v in s.flat]
    summary = f"{statistics.mean(flat) * 100:.3f} | {max(flat) * 100:.3f}" if flat else "- | -"
    miss = f" ({s.missed} missed)" if s.missed else ""
    sigma = f"{statistics.mean(s.sigmas) * 100:.3f}" if s.sigmas else "-"
    return f"| {label} | {n_trials} | " + " | ".join(cells) + f" | {summary} | {sigma} | {s.covered}/{s.total}{miss} |"


def _trials(low: Sequence[Shot], high: Sequence[Shot], per_altitude: int) -> list[list[Shot]]:
    n = len(low) // per_altitude
    return [
        [*low[k * per_altitude : (k + 1) * per_altitude], *high[k * per_altitude : (k + 1) * per_altitude]]
        for k in range(n)
    ]


def _table(
    title: str,
    low: Sequence[Shot],
    high: Sequence[Shot],
    pings: int,
    name: Callable[[TargetTruth], str],
    *,
    summit: bool = False,
) -> list[str]:
    truths = sorted(low[0].truth.targets, key=lambda t: t.target_id)
    ids = [t.target_id for t in truths]
    lines = [
        title,
        "",
        "| method | trials | "
        + " | ".join(name(t) for t in truths)
        + " | mean abs err cm | max abs err cm | mean sigma cm | covered |",
        "| --- | --- |" + " --- |" * (len(ids) + 4),
    ]
    for per_altitude in (1, pings):
        sets = _trials(low, high, per_altitude)
        for label, config, withhold in (
            ("altitude known, before", BEFORE, False),
            ("altitude known, after", AFTER, False),
            ("dH only, before (shadows alone)", BEFORE, True),
            ("dH only, after (+ seabed onset, edge offset, rounded tops)", AFTER, True),
            *((("dH only, summit model (`rounded_summit`)", SUMMIT, True),) if summit else ()),
        ):
            s = score(sets, truths, config, withhold_altitude=withhold)
            lines.append(_row(f"{label}, {per_altitude} ping(s)/altitude", len(sets), s, ids))
    return lines


def paper_tank(pings: int, trials: int) -> list[str]:
    """The Table I targets, dH only, before and after."""
    scene = load_scene("paper-tank")
    n = pings * trials
    shots = render_pair(scene.world, _config_for(scene.sonar, seed=11), PAPER_ALTITUDES_M, pings=n)
    return _table(
        "Table I targets, scene `paper-tank`, altitudes 0.5 / 0.6 m, speckle on, frames' "
        "altitude withheld unless `altitude known`. Error = estimate - truth, cm; cell = "
        "mean error [largest |error|] over independent trials; covered = |error| <= 2 x "
        "reported sigma.",
        shots[:n],
        shots[n:],
        pings,
        lambda t: f"{t.target_id} ({t.height_m * 100:.1f} cm)",
    )


def stone_world() -> World:
    """Five half-ellipsoid stones 3-8 cm high (as in :func:`benchmarks.bench_heights.stones`)."""
    specs = tuple(
        TargetSpec(f"S{i}", "stone", 1.2 + 0.1 * (i % 2), -0.24 + 0.12 * i, length, width, height, material="rock")
        for i, (length, width, height) in enumerate(
            [(0.10, 0.08, 0.04), (0.12, 0.10, 0.06), (0.08, 0.08, 0.03), (0.15, 0.10, 0.08), (0.10, 0.07, 0.05)]
        )
    )
    return World(seabed=Seabed(depth_m=0.85), targets=specs)


def stones(pings: int, trials: int) -> list[str]:
    """Rounded targets, before and after."""
    n = pings * trials
    shots = render_pair(stone_world(), SonarConfig(seed=5), PAPER_ALTITUDES_M, pings=n)
    return _table(
        "Stones (half-ellipsoids 3-8 cm high, lengths 8-15 cm), same geometry.",
        shots[:n],
        shots[n:],
        pings,
        lambda t: f"{t.target_id} ({t.height_m * 100:.1f} cm)",
        summit=True,
    )


def random_dh(count: int) -> list[str]:
    """The random scenes of :mod:`benchmarks.bench_heights` with the altitude withheld."""
    rng = np.random.default_rng(20261123)  # the same scenes as bench_heights
    errors: dict[str, list[float]] = {"before": [], "after": []}
    covered = {"before": 0, "after": 0}
    for index in range(count):
        world, config, altitudes = random_scene(rng, index)
        shots = render_pair(world, config, altitudes, pings=1)
        for name, cfg in (("before", BEFORE), ("after", AFTER)):
            targets = heights(shots, cfg, withhold_altitude=True)
            for truth in shots[0].truth.targets:
                t = match(targets, truth)
                if t is None or t.height_m is None or t.height_std_m is None:
                    continue
                errors[name].append(abs(t.height_m - truth.height_m) / truth.height_m)
                covered[name] += abs(t.height_m - truth.height_m) <= 2 * t.height_std_m
    lines = [
        f"Random scenes of `bench_heights` ({count} scenes, 1-3 boxes/cylinders 2-30 cm, altitude "
        "0.4-2.5 m, dH 0.05-0.3 m, one ping per altitude), altitude WITHHELD:",
        "",
        "| method | targets | median rel. error | 95th percentile | covered by 2 sigma |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name in ("before", "after"):
        e = np.array(errors[name])
        if e.size:
            lines.append(
                f"| dH only, {name} | {e.size} | {np.median(e) * 100:.2f} % | "
                f"{np.percentile(e, 95) * 100:.2f} % | {covered[name]}/{e.size} |"
            )
    return lines


def run(pings: int = 4, trials: int = 4, scenes: int = 100) -> str:
    """The Markdown section."""
    lines = ["## heights, dH only (altitude withheld)", ""]
    lines.extend(paper_tank(pings, trials))
    lines.append("")
    lines.extend(stones(pings, trials))
    lines.append("")
    if scenes > 0:
        lines.extend(random_dh(scenes))
        lines.append("")
    lines.append(
        f"Repeat: `python -m benchmarks.bench_heights_dh --pings {pings} --trials {trials} --scenes {scenes}`."
    )
    return "\n".join(lines)


def main() -> None:
    """Print the Markdown section of figures."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_heights_dh")
    parser.add_argument("--pings", type=int, default=4, help="pings per altitude in the multi-ping rows")
    parser.add_argument("--trials", type=int, default=4, help="independent trials of --pings pings")
    parser.add_argument("--scenes", type=int, default=100, help="random scenes (0: none)")
    args = parser.parse_args()
    print(run(pings=args.pings, trials=args.trials, scenes=args.scenes))


if __name__ == "__main__":
    main()
