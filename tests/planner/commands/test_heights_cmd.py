"""The ``shadowsurvey heights`` command: output as specified, bad input exits 2."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from perception.sonar_io.aris.writer import aris_grid, write_aris
from perception.sonar_io.npz import save_frame, save_frames
from planner.cli import main
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.world.world import Seabed, TargetSpec, World
from tests.perception.shadows.shadow_synth import Box, SynthConfig, render

BOXES = (Box(1.2, 0.0, 0.10, 0.05, 0.039), Box(1.2, 0.25, 0.05, 0.04, 0.047))
REQUIRED = {"azimuth_deg", "range_m", "shadow_end_m", "height_m", "height_std_m", "frames_used"}


def _write(tmp_path: Path, rng: np.random.Generator, name: str, altitude: float, **fields) -> str:
    frame, _, _ = render(SynthConfig(boxes=BOXES, altitude_m=altitude, tilt_deg=25.0), rng=rng)
    path = tmp_path / name
    save_frame(path, frame.with_fields(**fields) if fields else frame)
    return str(path)


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(["heights", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_json_document_as_specified(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    # The paper's setting: depths only, so the altitude change comes from sonar_depth_m.
    a = _write(tmp_path, rng, "a.npz", 0.5, altitude_m=math.nan, sonar_depth_m=4.5)
    b = _write(tmp_path, rng, "b.npz", 0.6, altitude_m=math.nan, sonar_depth_m=4.4)
    out_path = tmp_path / "out" / "heights.json"
    code, out, err = _run([a, b, "--json", str(out_path)], capsys)
    assert code == 0, err
    doc = json.loads(out_path.read_text())
    assert doc["frames"] == [a, b]
    assert doc["delta_h_m"] == pytest.approx([0.0, 0.1])
    assert len(doc["targets"]) == 2
    for target in doc["targets"]:
        assert REQUIRED <= set(target)
        assert target["frames_used"] == 2
        assert target["range_m"] < target["shadow_end_m"]
    heights = sorted(t["height_m"] for t in doc["targets"])
    assert heights == pytest.approx([0.039, 0.047], abs=0.006)
    assert "height cm" in out  # the table


def test_known_altitudes_and_json_to_stdout(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    a = _write(tmp_path, rng, "a.npz", 0.5)
    b = _write(tmp_path, rng, "b.npz", 0.6)
    code, out, err = _run([a, b, "--json", "-"], capsys)
    assert code == 0
    doc = json.loads(out)  # stdout holds only the JSON; the table went to stderr
    assert "height cm" in err
    by_azimuth = sorted(doc["targets"], key=lambda t: t["azimuth_deg"])
    assert by_azimuth[0]["azimuth_deg"] == pytest.approx(0.0, abs=0.5)
    assert [t["height_m"] for t in by_azimuth] == pytest.approx([0.039, 0.047], abs=0.0015)


def test_delta_h_and_altitude_options(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    a = _write(tmp_path, rng, "a.npz", 0.5, altitude_m=math.nan)
    b = _write(tmp_path, rng, "b.npz", 0.6, altitude_m=math.nan)
    code, out, err = _run([a, b, "--delta-h", "0.1", "--altitude", "0.5", "--json", "-"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["delta_h_m"] == [0.0, 0.1]
    heights = sorted(t["height_m"] for t in doc["targets"])
    assert heights == pytest.approx([0.039, 0.047], abs=0.0015)


def test_target_in_one_frame_has_null_height_and_reason(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    a = _write(tmp_path, rng, "a.npz", 0.5)
    frame, _, _ = render(SynthConfig(boxes=BOXES[:1], altitude_m=0.6, tilt_deg=25.0), rng=rng)
    save_frame(tmp_path / "b.npz", frame)
    code, out, _ = _run([a, str(tmp_path / "b.npz"), "--json", "-"], capsys)
    assert code == 0
    targets = json.loads(out)["targets"]
    lonely = [t for t in targets if t["height_m"] is None]
    assert len(lonely) == 1
    (t,) = lonely
    assert t["height_std_m"] is None
    # Placed all the same, and the reason names the frame that lacks it and why.
    assert isinstance(t["azimuth_deg"], float) and isinstance(t["range_m"], float)
    assert "seen in 1" in t["reason"] and "b.npz: not found there" in t["reason"]
    for target in targets:
        assert isinstance(target["azimuth_deg"], float) and isinstance(target["range_m"], float)


def test_no_targets_is_success_with_an_empty_list(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    frames = [render(SynthConfig(altitude_m=h, tilt_deg=25.0), rng=rng)[0] for h in (0.5, 0.6)]
    save_frames(tmp_path / "set.npz", frames)
    code, out, _ = _run([str(tmp_path / "set.npz"), "--json", "-"], capsys)
    assert code == 0
    doc = json.loads(out)
    assert doc["targets"] == [] and doc["frames"] == [f"{tmp_path / 'set.npz'}#{i}" for i in (0, 1)]


def test_bad_input_exits_2_naming_the_file(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    a = _write(tmp_path, rng, "a.npz", 0.5)
    b = _write(tmp_path, rng, "b.npz", 0.6)
    missing = str(tmp_path / "missing.npz")
    code, _, err = _run([a, missing], capsys)
    assert code == 2 and missing in err and "no such file" in err

    same = _write(tmp_path, rng, "same.npz", 0.5)
    code, _, err = _run([a, same], capsys)
    assert code == 2 and "one altitude" in err

    code, _, err = _run([a], capsys)
    assert code == 2 and "one altitude" in err

    bare = [_write(tmp_path, rng, f"bare{i}.npz", h, altitude_m=math.nan) for i, h in enumerate((0.5, 0.6))]
    code, _, err = _run(bare, capsys)
    assert code == 2 and "no altitude information" in err and bare[0] in err

    code, _, err = _run([a, b, same, "--delta-h", "0.1"], capsys)
    assert code == 2 and "exactly two frames" in err

    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"not a zip")
    code, _, err = _run([a, str(broken)], capsys)
    assert code == 2 and str(broken) in err


def test_shipped_paper_tank_example(data_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The README's example: two rendered frames of the paper's tank, 0.5 and 0.6 m up.
    examples = Path(__file__).resolve().parents[3] / "planner" / "data" / "examples"
    files = [str(examples / "paper_tank_0.50m.npz"), str(examples / "paper_tank_0.60m.npz")]
    code, out, err = _run([*files, "--json", "-"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["delta_h_m"] == pytest.approx([0.0, 0.1])
    table_i = json.loads((data_dir / "paper_tables.json").read_text())["table_I_targets_cm"]
    truth_m = sorted(t["H"] / 100 for t in table_i)
    found_m = sorted(t["height_m"] for t in doc["targets"])
    assert found_m == pytest.approx(truth_m, abs=0.0015)


@pytest.mark.slow
def test_aris_recording_from_the_simulator(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    world = World(
        seabed=Seabed(depth_m=5.0),
        targets=(TargetSpec("T", "box", 1.25, 0.0, 0.10, 0.05, 0.039),),
    )
    base = SonarConfig(seed=3)
    _, _, grid = aris_grid(0.7, 3.0, 1000, base.sound_speed_m_s)
    renderer = SonarRenderer(world, base.with_range_grid(grid))
    frames = [
        renderer.render(SonarPose(0.0, 0.0, 5.0 - h, tilt_rad=math.radians(25.0)), 1.7e9 + i)[0]
        for i, h in enumerate((0.5, 0.6))
    ]
    path = write_aris(tmp_path / "dive.aris", frames)
    code, out, err = _run([str(path), "--json", "-"], capsys)
    assert code == 0, err
    (target,) = json.loads(out)["targets"]
    assert target["height_m"] == pytest.approx(0.039, abs=0.002)


def test_frames_of_different_windows_samples_and_dtypes(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    # One scene from two altitudes: 800 uint8 samples over 0.9-2.6 m, then 1300 samples of
    # linear power (float32, 20 dB more gain) over 1.0-2.8 m. Ranges are in metres and
    # levels in each frame's own spread: the heights are those of the plain pair.
    a = _write(tmp_path, rng, "a.npz", 0.5)
    frame, _, _ = render(SynthConfig(boxes=BOXES, altitude_m=0.6, tilt_deg=25.0, window_m=(1.0, 2.8),
                                     n_samples=1300), rng=rng)
    power = (100.0 * 10.0 ** (frame.image.astype(np.float64) * (80 / 255) / 10)).astype(np.float32)
    b = str(save_frame(tmp_path / "b.npz", frame.with_fields(image=power)))
    code, out, err = _run([a, b, "--json", "-"], capsys)
    assert code == 0, err
    by_azimuth = sorted(json.loads(out)["targets"], key=lambda t: t["azimuth_deg"])
    assert [t["height_m"] for t in by_azimuth] == pytest.approx([0.039, 0.047], abs=0.002)


def test_rounded_targets_are_read_at_their_summit_when_asked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A half-buried stone 6 cm high: its echo fades towards the shadow, which a grazing
    # point below the summit casts.
    world = World(seabed=Seabed(depth_m=0.85),
                  targets=(TargetSpec("S", "stone", 1.2, 0.0, 0.12, 0.10, 0.06, material="rock"),))
    renderer = SonarRenderer(world, SonarConfig(seed=3))
    paths = []
    for k, altitude in enumerate((0.5, 0.6)):
        frame, _ = renderer.render(SonarPose(0.0, 0.0, 0.85 - altitude, tilt_rad=math.radians(25.0)), 10.0 + k)
        paths.append(str(tmp_path / f"{k}.npz"))
        save_frame(paths[-1], frame)
    found = {}
    for flag in ([], ["--rounded-targets"]):
        out_path = tmp_path / f"out{len(flag)}.json"
        code, _, err = _run([*paths, *flag, "--json", str(out_path)], capsys)
        assert code == 0, err
        (target,) = json.loads(out_path.read_text())["targets"]
        found[bool(flag)] = target
    assert found[False]["shadow_start"] == "far top edge"
    assert found[True]["shadow_start"] == "rounded top"
    assert found[False]["height_m"] < found[True]["height_m"]
    assert abs(found[True]["height_m"] - 0.06) < abs(found[False]["height_m"] - 0.06)
    assert found[True]["height_m"] == pytest.approx(0.06, abs=0.004)
