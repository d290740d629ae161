"""Scoring heights against the truth of any forward model (shared by the height benchmarks and tests).

A *case* is a set of frames of one scene (two altitudes) and its truth, normalised to
:class:`TruthTarget` whatever model rendered it: the product's renderer
(:func:`case_from_renderer`) or the second, independent model of ``tests/sonar_models``
(:func:`case_from_facet`, which reads only its documented truth fields). :func:`score`
runs the height pipeline on the frames, as a user of ``shadowsurvey heights`` would, and
counts:

- found: a complete target (its whole shadow in the window and the vertical beam in every
  frame) with a reported target within 2.5 deg of azimuth that has a height;
- the relative error of that height against the truth's;
- false detections: a frame's measured shadows farther than 2.5 deg from every target of
  that frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from perception.heights.pipeline import HeightPipeline, HeightsConfig, TargetHeight
from perception.sonar_io.frame import SonarFrame
from sim_harness.sonar.truth import FrameTruth

#: A reported target matches a true one within this azimuth, rad.
AZIMUTH_MATCH_RAD = math.radians(2.5)


@dataclass(frozen=True)
class TruthTarget:
    """One target of a case, in its first frame.

    Attributes
    ----------
    target_id : str
    kind : str
    height_m : float
    azimuth_rad : float
        Its azimuth in the first frame, rad.
    shadow_start_m : float
        Slant range of its shadow's start in the first frame, m.
    complete : bool
        Whether its whole shadow lies in the window and the vertical beam in every frame.
    azimuths_rad : tuple of float
        Its azimuth in each frame (for false detections).
    """

    target_id: str
    kind: str
    height_m: float
    azimuth_rad: float
    shadow_start_m: float
    complete: bool
    azimuths_rad: tuple[float, ...]


@dataclass(frozen=True)
class Case:
    """Frames of one scene and its truth."""

    frames: tuple[SonarFrame, ...]
    targets: tuple[TruthTarget, ...]
    label: str = ""


@dataclass
class Tally:
    """Figures over cases: found, errors, false detections."""

    n_complete: int = 0
    n_found: int = 0
    rel_errors: list[float] = field(default_factory=list)
    abs_errors_m: list[float] = field(default_factory=list)
    n_false: int = 0
    n_frames: int = 0
    missed: list[str] = field(default_factory=list)
    worst: list[tuple[float, str]] = field(default_factory=list)

    def add(self, other: Tally) -> None:
        self.n_complete += other.n_complete
        self.n_found += other.n_found
        self.rel_errors.extend(other.rel_errors)
        self.abs_errors_m.extend(other.abs_errors_m)
        self.n_false += other.n_false
        self.n_frames += other.n_frames
        self.missed.extend(other.missed)
        self.worst = sorted(self.worst + other.worst, reverse=True)[:20]

    @property
    def recall(self) -> float:
        return self.n_found / self.n_complete if self.n_complete else math.nan

    @property
    def false_per_frame(self) -> float:
        return self.n_false / self.n_frames if self.n_frames else math.nan

    def percentile(self, q: float) -> float:
        return float(np.percentile(self.rel_errors, q)) if self.rel_errors else math.nan


def case_from_renderer(shots: Sequence[tuple[SonarFrame, FrameTruth]], label: str = "") -> Case:
    """A case from the product renderer's frames and truth (first frame's geometry)."""
    frames = tuple(f for f, _ in shots)
    truths = [t for _, t in shots]
    targets = []
    for t in truths[0].targets:
        per_frame = [next((u for u in tr.targets if u.target_id == t.target_id), None) for tr in truths]
        complete = all(u is not None and u.whole_shadow_in_band and u.whole_shadow_in_window for u in per_frame)
        azimuths = tuple(u.azimuth_rad if u is not None else t.azimuth_rad for u in per_frame)
        targets.append(TruthTarget(t.target_id, t.shape, t.height_m, t.azimuth_rad, t.central_shadow_start_m,
                                   complete, azimuths))
    return Case(frames, tuple(targets), label)


def case_from_facet(frames: Sequence[SonarFrame], truths: Sequence[dict], label: str = "") -> Case:
    """A case from the second model's frames and its documented truth dicts (one per frame):
    per target ``target_id``, ``kind``, ``height_m``, ``azimuth_deg``, ``r_top_m`` and
    ``shadow_ok`` (whole shadow in the window and the aperture, target in the fan)."""
    targets = []
    for t in truths[0]["targets"]:
        per_frame = [next((u for u in tr["targets"] if u["target_id"] == t["target_id"]), None) for tr in truths]
        complete = all(u is not None and bool(u["shadow_ok"]) for u in per_frame)
        azimuths = tuple(math.radians(u["azimuth_deg"] if u is not None else t["azimuth_deg"]) for u in per_frame)
        targets.append(TruthTarget(str(t["target_id"]), str(t["kind"]), float(t["height_m"]),
                                   math.radians(t["azimuth_deg"]), float(t["r_top_m"]), complete, azimuths))
    return Case(tuple(frames), tuple(targets), label)


def match(targets: Sequence[TargetHeight], truth: TruthTarget) -> TargetHeight | None:
    """The reported target nearest the truth in azimuth (ties by range), None beyond 2.5 deg."""
    near = [t for t in targets if abs(t.azimuth_rad - truth.azimuth_rad) < AZIMUTH_MATCH_RAD]
    if not near:
        return None
    return min(near, key=lambda t: (t.height_m is None, abs(t.range_m - truth.shadow_start_m)))


def score(case: Case, *, config: HeightsConfig | None = None, withhold_altitude: bool = False) -> Tally:
    """Run the pipeline on a case and count (module docstring)."""
    pipeline = HeightPipeline(config or HeightsConfig())
    tally = Tally(n_frames=len(case.frames))
    for k, frame in enumerate(case.frames):
        f = frame.with_fields(altitude_m=math.nan) if withhold_altitude else frame
        result = pipeline.add_frame(f)
        for m in result.measurements:
            if not any(abs(m.azimuth_rad - t.azimuths_rad[k]) < AZIMUTH_MATCH_RAD for t in case.targets):
                tally.n_false += 1
    reported = pipeline.targets()
    for t in case.targets:
        if not t.complete:
            continue
        tally.n_complete += 1
        found = match(reported, t)
        if found is None or found.height_m is None:
            why = "not found" if found is None else (found.reason or "no height")
            tally.missed.append(f"{case.label} {t.target_id} {t.kind} {t.height_m * 100:.1f} cm: {why}")
            continue
        tally.n_found += 1
        tally.abs_errors_m.append(found.height_m - t.height_m)
        rel = abs(found.height_m - t.height_m) / t.height_m
        tally.rel_errors.append(rel)
        tally.worst.append((rel, f"{case.label} {t.target_id} {t.kind} {t.height_m * 100:.1f} cm -> "
                                 f"{found.height_m * 100:.1f} cm ({found.shadow_start})"))
    return tally


def frames_via_files(frames: Sequence[dict], folder: str, write: object, *, known: Sequence[str]) -> list[SonarFrame]:
    """The second model's frame dicts written as frame files (its ``write_frame_npz``) and read
    back with the product's reader, as a user's files would be."""
    from pathlib import Path

    from perception.sonar_io.npz import load_frames

    out = []
    for k, fr in enumerate(frames):
        path = Path(folder) / f"frame_{k}.npz"
        write(str(path), fr, known=tuple(known))  # type: ignore[operator]
        (frame,) = load_frames(path)
        out.append(frame)
    return out
