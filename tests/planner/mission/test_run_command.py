"""`shadowsurvey run` against a simulated sub: checks before the ARM prompt, no arming without
ARM, Ctrl-C; the sonar-folder source."""

from __future__ import annotations

import io
import json
import math
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from pymavlink import mavutil

from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import save_frame
from planner.cli import main
from planner.commands.run import confirm_arming
from planner.mission.sonar_sources import DirectorySonarSource
from planner.survey.plan import load_plan
from sim_harness.autopilot.autopilot import AutopilotConfig, Mode
from sim_harness.clock import SimClock
from sim_harness.simulator import VehicleConfig, VehicleSimulator
from sim_harness.vehicle.sensors import FlatSeabed

COMPACT = "tests/whole_loop/data/compact"


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


@contextmanager
def _vehicle(tmp_path: Path) -> Iterator[tuple[VehicleSimulator, Path]]:
    """The compact plan and a simulated sub at 4x real time, booted at the plan's origin
    with the BlueOS services heartbeating and no topside."""
    plan_dir = tmp_path / "plan"
    assert main(["plan", f"{COMPACT}/area.geojson", "--config", f"{COMPACT}/survey.toml", "--out", str(plan_dir),
                 "--no-plot"]) == 0
    plan = load_plan(plan_dir)
    config = VehicleConfig(autopilot=AutopilotConfig(origin=(plan.origin_lat_deg, plan.origin_lon_deg, 0.0)))
    sim = VehicleSimulator(FlatSeabed(20.0), config=config, clock=SimClock(speedup=4.0), listen="udp:127.0.0.1:0")
    sim.start()
    try:
        yield sim, plan_dir
    finally:
        sim.stop()
    if sim.error is not None:
        raise sim.error


def _run(sim: VehicleSimulator, plan_dir: Path, out: Path, *extra: str) -> int:
    return main(["run", "--connect", f"udpout:127.0.0.1:{sim.address[1]}", "--plan", str(plan_dir),
                 "--config", f"{COMPACT}/survey.toml", "--out", str(out), *extra])


def _ever_armed(tlog: Path) -> bool:
    log = mavutil.mavlink_connection(str(tlog))
    try:
        while (hb := log.recv_match(type="HEARTBEAT")) is not None:
            if hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1 and hb.base_mode & 128:
                return True
        return False
    finally:
        log.close()


def test_run_refuses_to_arm_without_the_topside(tmp_path, monkeypatch, capsys):
    """The checks run after connecting and before the prompt: no topside heartbeat, no
    arming (the vehicle's GCS failsafe would disarm it), and the reason is printed."""
    monkeypatch.setattr("sys.stdin", io.StringIO("ARM\n"))
    with _vehicle(tmp_path) as (sim, plan_dir):
        code = _run(sim, plan_dir, tmp_path / "dive")
    assert code == 1
    out = capsys.readouterr().out
    assert "arming refused: no heartbeat from the topside (system 255)" in out
    assert "Type ARM" not in out  # refused before the prompt
    summary = json.loads((tmp_path / "dive" / "summary.json").read_text())
    assert summary["reason"] == "preflight_refused"
    assert not _ever_armed(tmp_path / "dive" / "dive.tlog")


def test_unconfirmed_run_never_arms(tmp_path, monkeypatch, capsys):
    """A bench test (--no-topside): the prompt shows the checks' findings; anything but
    ARM exits 2 with the vehicle never armed and the run folder written."""
    monkeypatch.setattr("sys.stdin", io.StringIO("no\n"))
    with _vehicle(tmp_path) as (sim, plan_dir):
        code = _run(sim, plan_dir, tmp_path / "dive", "--no-topside")
    assert code == 2
    captured = capsys.readouterr()
    assert "arming not confirmed" in captured.err
    assert "pre-flight checks passed" in captured.out and "SYSID_MYGCS 255" in captured.out
    assert "Type ARM" in captured.out
    summary = json.loads((tmp_path / "dive" / "summary.json").read_text())
    assert summary["reason"] == "arming_not_confirmed"
    assert not _ever_armed(tmp_path / "dive" / "dive.tlog")


def test_ctrl_c_commands_the_safe_action_and_writes_the_summary(tmp_path, monkeypatch, capsys):
    """Ctrl-C while diving: the configured safe action (surface: ALT_HOLD and an ascent)
    is commanded, then the summary is written."""
    monkeypatch.setattr("sys.stdin", io.StringIO("ARM\n"))
    main_thread = threading.get_ident()
    with _vehicle(tmp_path) as (sim, plan_dir):

        def interrupt_when_diving() -> None:
            while not (sim.truth().armed and sim.truth().depth_m > 0.5):
                time.sleep(0.05)
            signal.pthread_kill(main_thread, signal.SIGINT)

        threading.Thread(target=interrupt_when_diving, daemon=True).start()
        code = _run(sim, plan_dir, tmp_path / "dive", "--no-topside")
        truth = sim.truth()
    assert code == 1
    summary = json.loads((tmp_path / "dive" / "summary.json").read_text())
    assert summary["reason"] == "operator_interrupt", summary["message"]
    assert summary["safe_action"] == "surface"
    assert _ever_armed(tmp_path / "dive" / "dive.tlog")  # the helper sees arming when there is one
    assert truth.mode == Mode.ALT_HOLD and truth.depth_m < 0.5
    assert "stopped by the operator (Ctrl-C)" in capsys.readouterr().out


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
