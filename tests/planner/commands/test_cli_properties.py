"""Property tests: scene files, navigation CSVs, connection strings and numbers on the command line.

Random and damaged inputs into ``render`` (scenes), ``mosaic --nav`` (navigation CSV),
``run --connect`` (connection strings) and every numeric option of the commands: each
exits 0, or 2 with one stderr line naming the file or the option (tests/fuzz.py).
"""

from __future__ import annotations

import argparse
import math
import tempfile
from importlib import resources
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from perception.sonar_io.npz import load_frames
from planner.cli import main
from planner.commands.args import connection_string
from planner.commands.nav_csv import NavTable
from sim_harness.sonar.scene import load_scene
from tests.fuzz import assert_contract, check_reader, file_case, mutated_bytes, mutated_toml, run_cli

SCENES = Path(str(resources.files("sim_harness").joinpath("data", "scenes")))
TANK_TEXT = (SCENES / "paper-tank.toml").read_text(encoding="utf-8")
FAST = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SOAK = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _scene_case(text: str | bytes) -> None:
    file_case("scene.toml", text, load_scene, lambda scene, tmp: [
        "render", str(scene), "--altitude", "0.5", "--samples", "64", "--no-preview", "--out", str(tmp / "out")])


@FAST
@given(text=mutated_toml(TANK_TEXT))
def test_damaged_scene_files(text: str) -> None:
    _scene_case(text)


@FAST
@given(data=mutated_bytes(TANK_TEXT.encode("utf-8")))
def test_damaged_scene_bytes(data: bytes) -> None:
    _scene_case(data)


@pytest.fixture(scope="module")
def bare_frames(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Path], str]:
    """Two rendered tank frames without their pose, and the navigation CSV that gives it."""
    out = tmp_path_factory.mktemp("nav_frames")
    assert main(["render", "paper-tank", "--altitude", "0.5", "0.6", "--samples", "200", "--no-preview",
                 "--out", str(out)]) == 0
    bare, rows = [], ["t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg,depth_m"]
    from perception.sonar_io.npz import save_frame

    for k, path in enumerate(sorted(p for p in out.glob("*.npz") if not p.name.endswith(".truth.npz"))):
        frame = load_frames(path)[0]
        rows.append(f"{float(k)},{frame.north_m},{frame.east_m},{math.degrees(frame.heading_rad)},"
                    f"{frame.altitude_m},{math.degrees(frame.tilt_rad)},{frame.sonar_depth_m}")
        stripped = frame.with_fields(timestamp_s=float(k), north_m=math.nan, east_m=math.nan, heading_rad=math.nan,
                                     altitude_m=math.nan, tilt_rad=math.nan)
        bare.append(save_frame(out / f"bare{k}.npz", stripped))
    return bare, "\n".join(rows) + "\n"


CSV_CELLS = st.sampled_from(["", "nan", "inf", "-1", "abc", "1e999", "0", "91", "-5000", "1e6", '"1,2"', "\x00",
                             "0.5", "2", "\u00e9"])


@st.composite
def damaged_csv(draw: st.DrawFn, text: str) -> str:
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(lines) - 1))
        cells = lines[i].split(",")
        op = draw(st.sampled_from(("cell", "cell", "drop_cell", "drop_line", "swap", "header")))
        if op == "cell":
            cells[draw(st.integers(0, len(cells) - 1))] = draw(CSV_CELLS)
        elif op == "drop_cell" and len(cells) > 1:
            del cells[draw(st.integers(0, len(cells) - 1))]
        elif op == "drop_line" and len(lines) > 1:
            del lines[i]
            continue
        elif op == "swap" and len(lines) > 2:
            lines[1], lines[2] = lines[2], lines[1]
        elif op == "header":
            cells = draw(st.permutations(cells))
        lines[i] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _nav_case(frames: list[Path], data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        nav = Path(tmp) / "nav.csv"
        nav.write_bytes(data)
        check_reader(NavTable, nav)
        code, _, err = run_cli(["mosaic", *map(str, frames), "--nav", str(nav), "--origin", "43.3,5.37",
                                "--out", str(Path(tmp) / "map"), "--no-registration"])
        assert_contract(code, err, [str(nav), *map(str, frames)])


@FAST
@given(data=st.data())
def test_damaged_navigation_csv(bare_frames: tuple[list[Path], str], data: st.DataObject) -> None:
    frames, text = bare_frames
    damaged = data.draw(damaged_csv(text) | mutated_bytes(text.encode("utf-8")).map(lambda b: b.decode("latin-1")))
    _nav_case(frames, damaged.encode("utf-8") if data.draw(st.booleans()) else damaged.encode("latin-1"))


CONNECTION_TEXT = st.text(max_size=30) | st.builds(
    lambda kind, host, port: f"{kind}:{host}:{port}",
    st.sampled_from(["udpin", "udpout", "udp", "tcp", "tcpin", "serial", "foo", ""]),
    st.sampled_from(["0.0.0.0", "127.0.0.1", "localhost", "192.168.2.2", "300.1.1.1", "", "a b", "-x", "host.local"]),
    st.sampled_from(["14550", "0", "65536", "-1", "", "abc", "14550.5", "99999999999"]),
) | st.sampled_from(["/dev/ttyACM0", "/dev/ttyUSB0,115200", "COM3", "COM3,57600", "/dev/ttyACM0,abc", "foo:bar"])


@settings(max_examples=200, deadline=None)
@given(text=CONNECTION_TEXT)
def test_connection_strings_are_parsed_or_refused(text: str) -> None:
    try:
        value = connection_string(text)
    except argparse.ArgumentTypeError as exc:
        assert str(exc)
        return
    assert value == value.strip() and (value.startswith(("/dev/", "COM")) or value.count(":") == 2)


@FAST
@given(text=CONNECTION_TEXT)
def test_run_refuses_bad_connections_naming_the_option(text: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        plan = Path(tmp) / "no-plan"
        code, _, err = run_cli(["run", "--connect", text, "--plan", str(plan), "--out", str(Path(tmp) / "run")])
        assert code == 2  # a bad connection, or (a good one) the missing plan: nothing is flown
        assert_contract(code, err, ["--connect", str(plan)])


NUMBER_TEXT = st.sampled_from(["nan", "inf", "-inf", "1e999", "-1e999", "abc", "", "0", "-0.1", "-5", "1e308",
                               "0x10", "1,5", "  7 ", "1e-320"]) | st.floats().map(repr) | st.integers().map(str)

#: (argv before the value, option, argv after): a missing file keeps a valid value cheap.
NUMERIC_OPTIONS = (
    (["plan", "missing.geojson", "--out", "OUT"], "--lane-heading-deg", []),
    (["heights", "missing.npz", "missing2.npz"], "--delta-h", []),
    (["heights", "missing.npz", "missing2.npz"], "--altitude", []),
    (["mosaic", "missing.npz", "--out", "OUT", "--origin", "43,5"], "--resolution-m", []),
    (["mosaic", "missing.npz", "--out", "OUT"], "--origin", []),
    (["plan", "missing.geojson", "--out", "OUT"], "--origin", []),
    (["report", "missing-run"], "--match-radius-m", []),
    (["report", "missing-run"], "--dpi", []),
    (["render", "missing.toml"], "--altitude", []),
    (["render", "missing.toml", "--altitude", "0.5"], "--tilt-deg", []),
    (["render", "missing.toml", "--altitude", "0.5"], "--samples", []),
    (["render", "missing.toml", "--altitude", "0.5"], "--noise-floor-db", []),
    (["sim-vehicle", "--scene", "missing.toml"], "--speedup", []),
    (["sim-vehicle", "--scene", "missing.toml"], "--seabed-depth-m", []),
    (["sim-vehicle", "--scene", "missing.toml"], "--start-depth-m", []),
    (["convert", "missing.aris", "OUT.npz"], "--frames", []),
)


@settings(max_examples=60, deadline=None)
@given(case=st.sampled_from(NUMERIC_OPTIONS), value=NUMBER_TEXT)
def test_numbers_on_the_command_line(case: tuple[list[str], str, list[str]], value: str) -> None:
    before, option, after = case
    with tempfile.TemporaryDirectory() as tmp:
        argv = [a.replace("OUT", str(Path(tmp) / "out")) for a in before]
        code, _, err = run_cli([*argv, f"{option}={value}", *after])
        assert code == 2  # a bad value, or (a good one) the missing file
        assert_contract(code, err, [option, "missing"])


@pytest.mark.soak
@SOAK
@given(text=mutated_toml(TANK_TEXT))
def test_soak_damaged_scene_files(text: str) -> None:
    _scene_case(text)


@pytest.mark.soak
@SOAK
@given(data=st.data())
def test_soak_damaged_navigation_csv(bare_frames: tuple[list[Path], str], data: st.DataObject) -> None:
    frames, text = bare_frames
    _nav_case(frames, data.draw(damaged_csv(text)).encode("utf-8"))
