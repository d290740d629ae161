"""`shadowsurvey run`: the arming confirmation and the sonar-folder source."""

from __future__ import annotations

import io
import math
import socket

import numpy as np
import pytest

from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import save_frame
from planner.cli import main
from planner.commands.run import confirm_arming
from planner.mission.sonar_sources import DirectorySonarSource


def _frame(t: float) -> SonarFrame:
    return SonarFrame(image=np.zeros((20, 8), np.uint8), range_m=np.linspace(0.7, 3.0, 20),
                      beam_azimuth_rad=np.linspace(-0.25, 0.25, 8), elevation_aperture_rad=math.radians(14),
                      timestamp_s=t)


def test_confirmation_needs_the_word_arm():
    out = io.StringIO()
    assert confirm_arming("plan x", stdin=io.StringIO("ARM\n"), stdout=out)
    assert "Type ARM" in out.getvalue()
    assert not confirm_arming("plan x", stdin=io.StringIO("yes\n"), stdout=io.StringIO())
    assert not confirm_arming("plan x", stdin=io.StringIO(""), stdout=io.StringIO())


def test_unconfirmed_run_sends_nothing(tmp_path, monkeypatch, capsys):
    """Without ARM at the prompt the command exits 2 before opening any link."""
    plan_dir = tmp_path / "plan"
    assert main(["plan", "tests/whole_loop/data/compact/area.geojson", "--config",
                 "tests/whole_loop/data/compact/survey.toml", "--out", str(plan_dir), "--no-plot"]) == 0
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as listener:
        listener.bind(("127.0.0.1", 0))
        listener.settimeout(0.3)
        port = listener.getsockname()[1]
        monkeypatch.setattr("sys.stdin", io.StringIO("no\n"))
        code = main(["run", "--connect", f"udpout:127.0.0.1:{port}", "--plan", str(plan_dir),
                     "--config", "tests/whole_loop/data/compact/survey.toml", "--out", str(tmp_path / "dive")])
        assert code == 2
        assert "arming not confirmed" in capsys.readouterr().err
        with pytest.raises(TimeoutError):
            listener.recvfrom(1024)  # not a single MAVLink byte was sent


def test_directory_source_reads_each_file_once(tmp_path):
    save_frame(tmp_path / "0001.npz", _frame(1.0))
    save_frame(tmp_path / "0002.npz", _frame(2.0))
    (tmp_path / "0003.npz").write_bytes(b"not a frame")
    source = DirectorySonarSource(tmp_path)
    frames = source.poll(0.0)
    assert [f.timestamp_s for f in frames] == [1.0, 2.0]
    assert source.files_rejected == 1
    assert source.poll(0.0) == []
    save_frame(tmp_path / "0004.npz", _frame(4.0))
    assert [f.timestamp_s for f in source.poll(0.0)] == [4.0]


def test_directory_source_needs_the_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        DirectorySonarSource(tmp_path / "missing")


def test_directory_source_refuses_frames_on_another_clock(tmp_path, caplog):
    save_frame(tmp_path / "0001.npz", _frame(1_700_000_000.0))  # Unix time: not the companion's monotonic clock
    save_frame(tmp_path / "0002.npz", _frame(101.0))
    source = DirectorySonarSource(tmp_path)
    with caplog.at_level("WARNING"):
        frames = source.poll(100.0)
    assert [f.timestamp_s for f in frames] == [101.0]
    assert source.frames_off_clock == 1
    assert "time.monotonic()" in caplog.text and "0001.npz" in caplog.text
