"""``shadowsurvey info`` and ``shadowsurvey convert`` end to end through planner.cli.main."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from perception.sonar_io.aris.reader import ArisRecording
from perception.sonar_io.npz import load_frames
from planner.cli import EXIT_BAD_INPUT, main
from planner.commands.convert import parse_frame_slice
from planner.errors import UsageError


@pytest.fixture
def sample(data_dir):
    return data_dir / "aris" / "sample.aris"


def test_info_text(sample, capsys):
    assert main(["info", str(sample)]) == 0
    out = capsys.readouterr().out
    for expected in (
        "ARIS 1200, telephoto lens",
        "frames          6",
        "beams           48",
        "samples         2000",
        "3.2976 to 23.4007 m",
        "6.545 Hz",
        "tilt_rad",
        "heading_rad",
    ):
        assert expected in out, expected


def test_info_json(sample, capsys):
    assert main(["info", "--json", str(sample)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert (info["n_frames"], info["n_beams"], info["n_samples"]) == (6, 48, 2000)
    assert info["acquisition_window_m"] == pytest.approx([3.2976, 23.4007], abs=5e-5)
    assert info["duration_s"] == pytest.approx(0.763977, abs=1e-6)


def test_convert_whole_recording(sample, tmp_path, capsys):
    out = tmp_path / "all.npz"
    assert main(["convert", str(sample), str(out)]) == 0
    assert "wrote 6 frames" in capsys.readouterr().err
    with np.load(out) as raw:  # plain numpy, frame-format.md stacked form
        assert raw["image"].shape == (6, 2000, 48) and raw["image"].dtype == np.uint8
        assert raw["range_m"].shape == (2000,) and raw["beam_azimuth_deg"].shape == (48,)
        assert raw["timestamp_s"].shape == (6,)
        assert "heading_deg" in raw.files and "tilt_deg" in raw.files
        assert "altitude_m" not in raw.files
    converted = load_frames(out)
    with ArisRecording(sample) as rec:
        for a, b in zip(rec, converted, strict=True):
            np.testing.assert_array_equal(a.image, b.image)
            np.testing.assert_array_equal(a.range_m, b.range_m)
            np.testing.assert_allclose(a.beam_azimuth_rad, b.beam_azimuth_rad, rtol=1e-12)
            assert a.timestamp_s == b.timestamp_s
            assert a.heading_rad == pytest.approx(b.heading_rad, rel=1e-12)


@pytest.mark.parametrize(
    ("text", "expected"),
    [("1:4", [1, 2, 3]), (":2", [0, 1]), ("-2:", [4, 5]), ("::2", [0, 2, 4]), ("4:100", [4, 5]), ("5:0:-2", [5, 3, 1])],
)
def test_convert_frame_ranges(sample, tmp_path, text, expected):
    out = tmp_path / "part.npz"
    assert main(["convert", str(sample), str(out), f"--frames={text}", "--uncompressed"]) == 0
    with ArisRecording(sample) as rec:
        want = [rec[i].timestamp_s for i in expected]
    assert [f.timestamp_s for f in load_frames(out)] == want


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    start=st.one_of(st.none(), st.integers(-20, 20)),
    stop=st.one_of(st.none(), st.integers(-20, 20)),
    step=st.one_of(st.none(), st.integers(-5, 5).filter(bool)),
)
def test_parse_frame_slice_is_python_slice(start, stop, step):
    text = ":".join("" if v is None else str(v) for v in (start, stop, step))
    assert parse_frame_slice(text) == slice(start, stop, step)
    two = ":".join("" if v is None else str(v) for v in (start, stop))
    assert parse_frame_slice(two) == slice(start, stop)


@pytest.mark.parametrize("text", ["5", "a:b", "1:2:3:4", "1:2:0", "1.5:3", ""])
def test_parse_frame_slice_rejects(text):
    with pytest.raises(UsageError):
        parse_frame_slice(text)


def run_bad(args, capsys):
    assert main(args) == EXIT_BAD_INPUT
    return capsys.readouterr().err


def test_bad_input_exits_2(sample, tmp_path, capsys):
    out = str(tmp_path / "o.npz")
    assert "selects none" in run_bad(["convert", str(sample), out, "--frames", "7:9"], capsys)
    assert "not an integer" in run_bad(["convert", str(sample), out, "--frames", "x:2"], capsys)
    assert ".npz" in run_bad(["convert", str(sample), str(tmp_path / "o.txt")], capsys)
    assert "absent.aris" in run_bad(["convert", str(tmp_path / "absent.aris"), out], capsys)
    assert "absent.aris" in run_bad(["info", str(tmp_path / "absent.aris")], capsys)
    junk = tmp_path / "junk.aris"
    junk.write_bytes(bytes(2048))
    err = run_bad(["info", str(junk)], capsys)
    assert "junk.aris" in err and "Version" in err
    bad_npz = tmp_path / "bad.npz"
    np.savez(bad_npz, image=np.zeros((3, 2), dtype=np.uint8))
    err = run_bad(["info", str(bad_npz)], capsys)
    assert "bad.npz" in err and "range_m" in err
    assert not (tmp_path / "o.npz").exists()


def test_convert_refuses_overwriting_input(tmp_path, sample, capsys):
    out = tmp_path / "a.npz"
    assert main(["convert", str(sample), str(out)]) == 0
    assert "overwrite" in run_bad(["convert", str(out), str(out)], capsys)


def test_truncated_recording(sample, tmp_path, capsys):
    cut = tmp_path / "cut.aris"
    cut.write_bytes(sample.read_bytes()[:-5000])
    # info describes what it can read (stdout), then exits 2 like convert and heights
    assert main(["info", str(cut)]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    assert "frame 5, field SampleData" in captured.out
    assert captured.err.count("\n") == 1 and str(cut) in captured.err and "truncated" in captured.err
    err = run_bad(["convert", str(cut), str(tmp_path / "c.npz")], capsys)
    assert "frame 5" in err and "--frames 0:5" in err
    assert main(["convert", str(cut), str(tmp_path / "c.npz"), "--frames", "0:5"]) == 0
    assert len(load_frames(tmp_path / "c.npz")) == 5


def test_corrupt_frame_fails_convert_naming_it(sample, tmp_path, capsys):
    data = bytearray(sample.read_bytes())
    frame_size = 1024 + 96_000
    data[1024 + 3 * frame_size + 464 : 1024 + 3 * frame_size + 468] = np.float32(math.nan).tobytes()
    bad = tmp_path / "bad.aris"
    bad.write_bytes(bytes(data))
    err = run_bad(["convert", str(bad), str(tmp_path / "b.npz")], capsys)
    assert "frame 3" in err and "SoundSpeed" in err
    assert main(["convert", str(bad), str(tmp_path / "b.npz"), "--frames", ":3"]) == 0
    capsys.readouterr()
    assert main(["info", str(bad)]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    assert "corrupt" in captured.out
    assert captured.err.count("\n") == 1 and str(bad) in captured.err and "SoundSpeed" in captured.err


def test_info_on_converted_npz(sample, tmp_path, capsys):
    out = tmp_path / "two.npz"
    assert main(["convert", str(sample), str(out), "--frames", "0:2"]) == 0
    capsys.readouterr()
    assert main(["info", "--json", str(out)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert (info["format"], info["n_frames"], info["n_beams"]) == ("npz", 2, 48)
    assert info["acquisition_window_m"] is None and info["sonar"] == "unknown"
    assert set(info["pose_fields"]) == {"tilt_rad", "heading_rad", "sound_speed_m_s"}


def test_a_command_imports_its_own_module_only(sample):
    """``shadowsurvey info`` does not pay for the dry run's imports (matplotlib, casadi, the
    simulator): the parser is built from the named command's module alone; the full list
    is still there for ``--help`` and a mistyped command."""
    import subprocess
    import sys

    probe = ("import sys; from planner.cli import main; code = main(['info', sys.argv[1]]); "
             "heavy = sorted(m for m in ('matplotlib', 'casadi', 'sim_harness', 'planner.mission') "
             "if m in sys.modules); "
             "print('HEAVY', heavy, code)")
    run = subprocess.run([sys.executable, "-c", probe, str(sample)], capture_output=True, text=True, timeout=120)
    assert run.stdout.strip().splitlines()[-1] == "HEAVY [] 0", run.stdout + run.stderr
    typo = subprocess.run([sys.executable, "-m", "planner.cli", "infoo"], capture_output=True, text=True, timeout=120)
    assert typo.returncode == EXIT_BAD_INPUT
    assert "'sim-vehicle'" in typo.stderr and "'info'" in typo.stderr and len(typo.stderr.strip().splitlines()) == 1
