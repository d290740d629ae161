"""Heights on frames of the second, independently written forward model
(``tests/sonar_models/facet_sonar.py``: coherent point and facet scatterers), read from its
frame files as a user's would be. Seeds of their own (the benchmark and the tuning use others)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from perception.heights.pipeline import HeightPipeline
from perception.sonar_io.npz import load_frames
from tests.sonar_models import facet_sonar as fs

SEED = 4242


def _frames(frame_dicts, folder: Path):
    out = []
    for k, fr in enumerate(frame_dicts):
        path = folder / f"frame_{k}.npz"
        fs.write_frame_npz(str(path), fr, known=tuple(fs.OPTIONAL_KEYS))
        (frame,) = load_frames(path)
        out.append(frame)
    return out


def _heights(frames, truth_targets):
    pipeline = HeightPipeline()
    for frame in frames:
        pipeline.add_frame(frame)
    reported = pipeline.targets()
    out = []
    for t in truth_targets:
        near = [r for r in reported if abs(math.degrees(r.azimuth_rad) - t["azimuth_deg"]) < 2.5]
        best = min(near, key=lambda r: (r.height_m is None, abs(r.range_m - t["r_top_m"]))) if near else None
        out.append((t, best))
    return out, reported


@pytest.mark.parametrize(("index", "orientation_deg"), [(0, 45.0), (2, 90.0)])
def test_paper_targets_of_the_second_model(tmp_path: Path, index: int, orientation_deg: float) -> None:
    s = fs.paper_targets(orientation_deg=orientation_deg)[index]
    frame_dicts, truths = fs.render_plan(s["plan"], s["settings"], rng=SEED + index)
    frames = _frames(frame_dicts, tmp_path)
    (pair,), _ = _heights(frames, truths[0]["targets"])
    truth, found = pair
    assert found is not None and found.height_m is not None, found.reason if found else "not found"
    assert found.height_m == pytest.approx(truth["height_m"], abs=max(0.003, 0.1 * truth["height_m"]))
    assert isinstance(found.azimuth_rad, float) and isinstance(found.range_m, float)


def test_random_pairs_of_other_windows_gains_and_dtypes(tmp_path: Path) -> None:
    errors = []
    for i in range(2):
        rng = np.random.default_rng([SEED, i])
        pair = fs.sample_pair(rng, vary_window=True, vary_gain=True, vary_dtype=True, kinds=("box",))
        folder = tmp_path / f"pair{i}"
        folder.mkdir()
        frames = _frames(pair["frames"], folder)
        per_frame = pair["truth"]
        complete = [t for t in per_frame[0]["targets"]
                    if all(any(u["target_id"] == t["target_id"] and u["shadow_ok"] for u in tr["targets"])
                           for tr in per_frame)]
        found, _ = _heights(frames, complete)
        for truth, target in found:
            assert target is not None and target.height_m is not None, (i, truth["target_id"], target)
            errors.append(abs(target.height_m - truth["height_m"]) / truth["height_m"])
    assert errors and float(np.median(errors)) < 0.05 and max(errors) < 0.15
