"""The ``shadowsurvey render`` command: frames, truth, previews and .aris output."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from perception.sonar_io.aris.reader import ArisRecording
from perception.sonar_io.npz import load_frames
from planner.cli import main


def test_render_paper_tank_at_two_altitudes(tmp_path: Path) -> None:
    out = tmp_path / "tank"
    code = main(["render", "paper-tank", "--altitude", "0.5", "0.6", "--out", str(out)])
    assert code == 0
    doc = json.loads((out / "truth.json").read_text())
    assert doc["scene"] == "paper-tank" and len(doc["frames"]) == 2
    for record, altitude in zip(doc["frames"], (0.5, 0.6), strict=True):
        (frame,) = load_frames(out / record["frame"])
        assert frame.altitude_m == pytest.approx(altitude)
        assert frame.sonar_depth_m == pytest.approx(0.85 - altitude)
        assert frame.image.shape == (1000, 128)
        labels = np.load(out / record["labels"])["labels"]
        assert labels.shape == frame.image.shape
        assert (out / record["frame"].replace(".npz", ".png")).stat().st_size > 10_000
        targets = {t["target_id"]: t for t in record["targets"]}
        assert set(targets) == {"1", "2", "3", "4", "5"}
        for t in targets.values():
            assert t["whole_shadow_in_band"] and t["whole_shadow_in_window"]
            # similar triangles on the flat tank floor give the true height back
            h = altitude * (t["shadow_end_m"] - t["shadow_start_m"]) / t["shadow_end_m"]
            assert h == pytest.approx(t["height_m"], rel=1e-6)
    # the higher frame sees each shadow shorter
    low, high = ({t["target_id"]: t for t in f["targets"]} for f in doc["frames"])
    for key in low:
        assert (high[key]["shadow_end_m"] - high[key]["shadow_start_m"]) < (
            low[key]["shadow_end_m"] - low[key]["shadow_start_m"])


def test_heights_measures_the_rendered_paper_tank(tmp_path: Path) -> None:
    """The dry run of the paper's experiment: two altitudes 0.1 m apart, heights from shadows."""
    out = tmp_path / "tank"
    assert main(["render", "paper-tank", "--altitude", "0.5", "0.6", "--out", str(out), "--no-preview"]) == 0
    doc = json.loads((out / "truth.json").read_text())
    frames = [str(out / f["frame"]) for f in doc["frames"]]
    assert main(["heights", *frames, "--json", str(tmp_path / "heights.json")]) == 0
    measured = json.loads((tmp_path / "heights.json").read_text())["targets"]
    for truth in doc["frames"][0]["targets"]:
        near = [m for m in measured if abs(m["azimuth_deg"] - truth["azimuth_deg"]) < 1.5]
        assert near, f"target {truth['target_id']} not found by heights"
        assert near[0]["height_m"] == pytest.approx(truth["height_m"], abs=0.003)
        assert near[0]["range_m"] == pytest.approx(truth["shadow_start_m"], abs=0.01)


def test_render_sweep_with_tilt_and_aris(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    aris = tmp_path / "sweep.aris"
    code = main([
        "render", "open-seabed", "--altitude", "1.5", "--tilt-deg", "20", "--line", "1", "14", "1", "16",
        "--count", "3", "--heading-deg", "0", "10", "--samples", "500", "--no-preview",
        "--out", str(out), "--aris", str(aris), "--speckle-looks", "1",
    ])
    assert code == 0
    doc = json.loads((out / "truth.json").read_text())
    assert len(doc["frames"]) == 6
    east = sorted({round(f["pose"]["east_m"], 6) for f in doc["frames"]})
    assert east == [14.0, 15.0, 16.0]
    assert all(f["pose"]["tilt_deg"] == pytest.approx(20.0) for f in doc["frames"])
    assert not list(out.glob("*.png"))
    with ArisRecording(aris) as rec:
        assert len(rec) == 6
        first = rec[0]
        (npz,) = load_frames(out / doc["frames"][0]["frame"])
        np.testing.assert_array_equal(first.image, npz.image)
        np.testing.assert_allclose(first.range_m, npz.range_m, atol=1e-6)
        assert math.degrees(first.tilt_rad) == pytest.approx(20.0, abs=0.01)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["render", "no-such-scene", "--altitude", "1"], "not a built-in scene"),
        (["render", "paper-tank", "--altitude", "2.0"], "above the water surface"),
        (["render", "paper-tank", "--altitude", "0.5", "--window-length-m", "-1"], "--window-length-m"),
        (["render", "paper-tank", "--altitude", "0.5", "--line", "0", "0", "1", "0", "--count", "1"], "--count"),
    ],
)
def test_bad_input_exits_2_with_a_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    assert main([*argv, "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err
