"""Heights on forward models the perception was not tuned on: the renderer's family and a second model.

Every figure comes from seeded scenes whose seeds differ from those the perception was
developed on (``TUNING_SEEDS`` below are never used here).

- **Renderer family** (``sim_harness.sonar.family``): the named members (one physical
  choice changed each) and random draws of all choices; random scenes of 1-3 boxes and
  vertical cylinders 2-30 cm high at 0-90 deg to the beams, with the window, sample count,
  gain (and, for the "varied dtypes" rows, the output form) changing between the two
  altitudes (``sim_harness.sonar.random_scenes``).
- **Second model** (``tests/sonar_models/facet_sonar.py``, written independently, used as
  a black box through its documented API): its random pairs of boxes and cylinders
  (``kinds = box, pipe, post``; window, gain and dtype vary between frames), and of all its
  kinds (domes, spheres and rocks as well).
- Conditions: the altitude in the frames; the altitude withheld (only dH from the depth
  gauge); and +-2 deg of true pitch and roll that the frames do not report (they say 0).
- **The paper's five Table I targets** at 0-90 deg to the beams, 0.5 then 0.6 m, on both
  models; with the paper's classical adaptive threshold (``SegmentationConfig(method=
  "classical")``) as the named baseline through the same pipeline.
- **Real data**: the 6 frames of the real ARIS recording (no targets known).

Run: ``python -m benchmarks.bench_heights_models [--scenes N] [--facet-pairs N] [--quick]``.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from benchmarks.heights_scoring import Case, Tally, case_from_facet, case_from_renderer, frames_via_files, score
from perception.heights.pipeline import HeightsConfig, detect_shadows
from perception.shadows.pairing.pair import PairingConfig
from perception.shadows.segmentation.config import SegmentationConfig
from perception.sonar_io.readers import open_recording
from sim_harness.sonar.family import FamilyMember, draw_member, presets
from sim_harness.sonar.random_scenes import draw_scene, paper_scene, render_scene
from tests.sonar_models import facet_sonar as fs

#: Seeds the perception was developed on (never used for the figures): renderer scenes of
#: random members (7: altitude known, 8: attitude, 9: dtypes varying) and of the named
#: members (50 + member index), the Table I targets (seeds 100 + 7 orientation + index),
#: and the second model's tuning pairs (7001, 7002).
TUNING_SEEDS = {"renderer scenes": (7, 8, 9, *range(50, 68)), "renderer Table I": (100,),
                "second model pairs": (7001, 7002)}
#: Seeds of the figures.
SEED_RENDERER = 20261201
SEED_FACET = 9001
ORIENTATIONS_DEG = (0, 15, 30, 45, 60, 75, 90)
ARIS_SAMPLE = Path(__file__).resolve().parent.parent / "tests" / "data" / "aris" / "sample.aris"
#: The paper's method through the same pipeline: its adaptive threshold, and Algorithm 1's
#: pairs of a highlight and a shadow (no shadow without a highlight).
BASELINE = HeightsConfig(segmentation=SegmentationConfig(method="classical"),
                         pairing=PairingConfig(shadow_only=False))
CONDITIONS = ("known", "dH only", "+-2 deg attitude")
#: The opt-in summit of a target whose echo fades (``heights --rounded-targets``).
ROUNDED = HeightsConfig(rounded_near_echo=True)
BOXES_AND_CYLINDERS = ("box", "pipe", "post")


def _fmt(value: float, unit: str = "%", scale: float = 100.0) -> str:
    return "-" if not math.isfinite(value) else f"{value * scale:.2f}{' ' + unit if unit != '%' else ' %'}"


def renderer_cases(member: FamilyMember | None, n: int, seed: int, *, condition: str, vary_output: bool = False,
                   shapes: Sequence[str] = ("box", "cylinder")) -> list[Case]:
    """``n`` random scenes rendered through ``member`` (None: a random draw per scene)."""
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(n):
        scene = draw_scene(rng, shapes=shapes, vary_output=vary_output,
                           attitude_error_deg=2.0 if condition == CONDITIONS[2] else 0.0)
        m = member if member is not None else draw_member(rng)
        shots = render_scene(scene, m, seed=seed + 1000 + i)
        cases.append(case_from_renderer(shots, f"{m.name} #{i}"))
    return cases


def facet_cases(n: int, seed: int, *, condition: str, kinds: Sequence[str] = BOXES_AND_CYLINDERS,
                progress: Callable[[str], None] | None = None) -> list[Case]:
    """``n`` random pairs of the second model (its ``sample_pair``), read back through files."""
    cases = []
    attitude = condition == CONDITIONS[2]
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(n):
            rng = np.random.default_rng([seed, i, len(kinds), int(attitude)])
            options: dict[str, object] = {"kinds": tuple(kinds)}
            if attitude:
                options["true_attitude_sigma_deg"] = 1.2
            pair = fs.sample_pair(rng, vary_window=True, vary_gain=True, vary_dtype=True,
                                  report_attitude="zero" if attitude else "true", **options)
            if attitude and not all(abs(t["true_pose"]["pitch_deg"]) <= 2.0 and abs(t["true_pose"]["roll_deg"]) <= 2.0
                                    for t in pair["truth"]):
                continue  # +-2 deg: attitudes drawn beyond it are left out
            folder = os.path.join(tmp, f"pair{i}")
            os.makedirs(folder)
            frames = frames_via_files(pair["frames"], folder, fs.write_frame_npz, known=fs.OPTIONAL_KEYS)
            cases.append(case_from_facet(frames, pair["truth"], f"facet #{i}"))
            if progress is not None:
                progress(f"facet pair {i}")
    return cases


def paper_cases_renderer(orientation_deg: float, seed: int) -> list[Case]:
    """The five Table I targets, one scene each, at ``orientation_deg`` (historical renderer)."""
    member = presets()[0]
    return [case_from_renderer(render_scene(paper_scene(k, orientation_deg), member, seed=seed + k),
                               f"T{k + 1} {orientation_deg:g} deg") for k in range(5)]


def paper_cases_facet(orientation_deg: float, seed: int) -> list[Case]:
    """The five Table I targets of the second model (its ``paper_targets``) at ``orientation_deg``."""
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, s in enumerate(fs.paper_targets(orientation_deg=float(orientation_deg))):
            frames_d, truths = fs.render_plan(s["plan"], s["settings"], rng=seed + 100 * int(orientation_deg) + k)
            folder = os.path.join(tmp, f"t{k}")
            os.makedirs(folder)
            frames = frames_via_files(frames_d, folder, fs.write_frame_npz, known=fs.OPTIONAL_KEYS)
            case = case_from_facet(frames, truths, f"T{k + 1} {orientation_deg:g} deg")
            cases.append(case)
    return cases


def tally(cases: Sequence[Case], *, config: HeightsConfig | None = None, withhold_altitude: bool = False) -> Tally:
    """The figures over ``cases``."""
    total = Tally()
    for case in cases:
        total.add(score(case, config=config, withhold_altitude=withhold_altitude))
    return total


def _row(name: str, n_cases: int, known: Tally, dh: Tally | None, att: Tally | None) -> str:
    cells = [
        name, str(n_cases), f"{known.n_found}/{known.n_complete} = {known.recall:.3f}",
        f"{known.n_false}/{known.n_frames} = {known.false_per_frame:.3f}",
        _fmt(known.percentile(50)), _fmt(known.percentile(95)),
        _fmt(dh.percentile(50)) if dh is not None else "-",
        _fmt(att.percentile(50)) if att is not None else "-",
        f"{att.n_found}/{att.n_complete}" if att is not None else "-",
    ]
    return "| " + " | ".join(cells) + " |"


HEADER = [
    "| model | scenes | recall (altitude known) | false detections per frame | median rel. error | "
    "95th percentile | median, dH only | median, +-2 deg attitude | found, +-2 deg attitude |",
    "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
]
GOALS = ("| goal | | >= 0.97 | <= 0.05 | <= 3 % | <= 10 % | <= 5 % | <= 6 % | |")


def family_section(n: int, *, quick: bool) -> tuple[list[str], dict[str, Tally]]:
    """The renderer family's table: one row per named member, random draws, varied dtypes."""
    lines = ["### Renderer family (sim_harness), per member", "", *HEADER]
    overall = {c: Tally() for c in CONDITIONS}
    members: list[tuple[str, FamilyMember | None, bool]] = [(m.name, m, False) for m in presets()]
    members.append(("random draws of every choice", None, False))
    members.append(("random draws, dtype changing between the altitudes", None, True))
    if quick:
        members = members[:3] + members[-2:]
    for k, (name, member, vary_output) in enumerate(members):
        seed = SEED_RENDERER + 100 * k
        known_cases = renderer_cases(member, n, seed, condition=CONDITIONS[0], vary_output=vary_output)
        att_cases = renderer_cases(member, n, seed + 50, condition=CONDITIONS[2], vary_output=vary_output)
        known = tally(known_cases)
        dh = tally(known_cases, withhold_altitude=True)
        att = tally(att_cases)
        for cond, t in zip(CONDITIONS, (known, dh, att), strict=True):
            overall[cond].add(t)
        lines.append(_row(name, n, known, dh, att))
    lines.append(_row("**all members**", n * len(members), overall[CONDITIONS[0]], overall[CONDITIONS[1]],
                      overall[CONDITIONS[2]]))
    lines.append(GOALS)
    # The baseline on the random draws of every choice (the same scenes as that row).
    k = len(members) - 2
    base_cases = renderer_cases(None, n, SEED_RENDERER + 100 * k, condition=CONDITIONS[0])
    base = tally(base_cases, config=BASELINE)
    lines.append("")
    lines.append(
        f"Baseline (the paper's adaptive threshold, `method=\"classical\"`, same pipeline) on the random draws of "
        f"every choice: recall {base.n_found}/{base.n_complete} = {base.recall:.3f}, false detections per frame "
        f"{base.false_per_frame:.3f}, median {_fmt(base.percentile(50))}, 95th percentile {_fmt(base.percentile(95))}."
    )
    return lines, overall


def facet_section(n: int, *, progress: Callable[[str], None] | None) -> tuple[list[str], dict[str, Tally]]:
    """The second model's table: boxes and cylinders, and all its kinds."""
    lines = ["", "### Second model (tests/sonar_models/facet_sonar.py), separately", "", *HEADER]
    out: dict[str, Tally] = {}
    rows_rounded: list[str] = []
    for name, kinds, count in (("boxes and cylinders (box, pipe, post)", BOXES_AND_CYLINDERS, n),
                               ("all its kinds (+ dome, sphere, rock)", tuple(fs.TARGET_KINDS), max(4, n // 2))):
        known_cases = facet_cases(count, SEED_FACET, condition=CONDITIONS[0], kinds=kinds, progress=progress)
        att_cases = facet_cases(count, SEED_FACET + 1, condition=CONDITIONS[2], kinds=kinds, progress=progress)
        known = tally(known_cases)
        dh = tally(known_cases, withhold_altitude=True)
        att = tally(att_cases)
        if kinds == BOXES_AND_CYLINDERS:
            out = {CONDITIONS[0]: known, CONDITIONS[1]: dh, CONDITIONS[2]: att}
            base = tally(known_cases, config=BASELINE)
        lines.append(_row(name, len(known_cases), known, dh, att))
        rows_rounded.append(_row(f"{name}, `--rounded-targets`", len(known_cases), tally(known_cases, config=ROUNDED),
                                 tally(known_cases, config=ROUNDED, withhold_altitude=True),
                                 tally(att_cases, config=ROUNDED)))
    lines.extend(rows_rounded)
    lines.append(GOALS)
    lines.append("")
    lines.append(
        f"Baseline (the paper's adaptive threshold, `method=\"classical\"`, same pipeline) on the boxes and "
        f"cylinders: recall {base.n_found}/{base.n_complete} = {base.recall:.3f}, false detections per frame "
        f"{base.false_per_frame:.3f}, median {_fmt(base.percentile(50))}, 95th percentile {_fmt(base.percentile(95))}."
    )
    return lines, out


def paper_section(*, progress: Callable[[str], None] | None) -> list[str]:
    """The paper's five at every orientation: mean |error| per orientation, ours and the baseline."""
    lines = [
        "", "### The paper's five Table I targets, 0.5 then 0.6 m, at each orientation to the beams", "",
        "Mean |error| over the five targets, cm (missed: no height). Baseline: the paper's adaptive threshold.",
        "",
        "| orientation | ours, renderer | baseline, renderer | ours, second model | baseline, second model "
        "| ours `--rounded-targets`, renderer | ours `--rounded-targets`, second model |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    totals: dict[str, list[float]] = {k: [] for k in ("or", "br", "of", "bf", "rr", "rf")}
    missed = {k: 0 for k in totals}
    for o in ORIENTATIONS_DEG:
        ours_cases = paper_cases_renderer(o, SEED_RENDERER + 7 * o)
        facet = paper_cases_facet(o, SEED_FACET + o)
        cells = []
        for key, cases, cfg in (("or", ours_cases, None), ("br", ours_cases, BASELINE), ("of", facet, None),
                                ("bf", facet, BASELINE), ("rr", ours_cases, ROUNDED), ("rf", facet, ROUNDED)):
            t = tally(cases, config=cfg)
            errs = [abs(e) * 100 for e in t.abs_errors_m]
            totals[key].extend(errs)
            missed[key] += t.n_complete - t.n_found
            miss = t.n_complete - t.n_found
            cells.append((f"{np.mean(errs):.3f}" if errs else "-") + (f" ({miss} missed)" if miss else ""))
        lines.append(f"| {o} deg | " + " | ".join(cells) + " |")
        if progress is not None:
            progress(f"paper targets at {o} deg")
    cells = [(f"**{np.mean(v):.3f}**" if v else "-") + (f" ({missed[k]} missed)" if missed[k] else "")
             for k, v in totals.items()]
    lines.append("| all (goal <= 0.10 cm) | " + " | ".join(cells) + " |")
    return lines


def aris_section() -> list[str]:
    """Detections on the real ARIS recording (no targets known: every detection is false)."""
    counts = []
    with open_recording(ARIS_SAMPLE) as recording:
        for frame in recording:
            counts.append(len(detect_shadows(frame.image, range_m=frame.range_m,
                                             beam_azimuth_rad=frame.beam_azimuth_rad)))
    return ["", "### Real ARIS recording (tests/data/aris/sample.aris, ARIS 1200 telephoto, 48 beams, "
            "no targets known)",
            "", f"Detections per frame: {counts} (mean {np.mean(counts):.2f} false per frame); no frame has a height "
            "(no altitude information: `heights` refuses with exit 2, the pipeline reports no height)."]


def run(scenes: int, facet_pairs: int, *, quick: bool = False, progress: Callable[[str], None] | None = None) -> str:
    """The Markdown section."""
    t0 = time.perf_counter()
    lines = ["## heights on forward models it was not tuned on", ""]
    family, _ = family_section(scenes, quick=quick)
    lines.extend(family)
    facet, _ = facet_section(facet_pairs, progress=progress)
    lines.extend(facet)
    lines.extend(paper_section(progress=progress))
    lines.extend(aris_section())
    lines.append("")
    lines.append(f"Took {time.perf_counter() - t0:.0f} s on {platform.machine()}, Python {platform.python_version()}; "
                 f"load average {', '.join(f'{v:.2f}' for v in os.getloadavg())}.")
    lines.append(f"Repeat: `python -m benchmarks.bench_heights_models --scenes {scenes} --facet-pairs {facet_pairs}`.")
    return "\n".join(lines)


def main() -> None:
    """Print the Markdown section of figures."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_heights_models")
    parser.add_argument("--scenes", type=int, default=12, help="random scenes per renderer family member")
    parser.add_argument("--facet-pairs", type=int, default=40, help="random pairs of the second model")
    parser.add_argument("--quick", action="store_true", help="a few members only")
    args = parser.parse_args()
    print(run(args.scenes, args.facet_pairs, quick=args.quick))


if __name__ == "__main__":
    main()
