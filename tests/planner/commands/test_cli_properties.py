"""Property tests: scene files, navigation CSVs, connection strings and numbers on the command line.

Random and damaged inputs into ``render`` (scenes), ``mosaic --nav`` (navigation CSV),
``run --connect`` (connection strings) and every numeric option of the commands: each
exits 0, or 2 with one stderr line naming the file or the option (tests/fuzz.py).
"""

from __future__ import annotations

import argparse
import math
import re
import tempfile
from importlib import resources
from pathlib import Path

import numpy as np
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


#: Parts of KIND:HOST:PORT strings, each with whether pymavlink's form allows it (a
#: network kind it opens; an IPv4 address of octets <= 255 or a DNS name; a port 1..65535).
KINDS = {"udpin": True, "udpout": True, "udp": True, "tcp": True, "tcpin": True, "serial": False, "foo": False,
         "": False, "UDP": False}
HOSTS = {"0.0.0.0": True, "127.0.0.1": True, "localhost": True, "192.168.2.2": True, "host.local": True,
         "255.255.255.255": True, "300.1.1.1": False, "1.2.3.256": False, "": False, "a b": False, "-x": False,
         "host_1": False}
PORTS = {"14550": True, "1": True, "5760": True, "65535": True, "0": False, "65536": False, "-1": False, "": False,
         "abc": False, "14550.5": False, "99999999999": False, " 1": False}
#: Serial devices, and whether each is one (a /dev path or a COM port, optionally ",BAUD").
SERIALS = {"/dev/ttyACM0": True, "/dev/ttyUSB0,115200": True, "/dev/serial/by-id/usb-ArduPilot_0,57600": True,
           "COM3": True, "COM3,57600": True, "/dev/ttyACM0,abc": False, "/dev/ttyACM0,": False, "COM": False,
           "foo:bar": False, "ttyACM0": False}

NETWORK_TEXT = st.builds(
    lambda kind, host, port: (f"{kind}:{host}:{port}", KINDS[kind] and HOSTS[host] and PORTS[port],
                              f"{kind}:{host}:{port}"),
    st.sampled_from(sorted(KINDS)), st.sampled_from(sorted(HOSTS)), st.sampled_from(sorted(PORTS)))
SERIAL_TEXT = st.sampled_from(sorted(SERIALS)).map(lambda text: (text, SERIALS[text], text))
#: (text, whether it is a MAVLink connection, the value it is parsed to), worked out apart
#: from the parser; surrounding blanks are ignored.
CONNECTION_CASES = st.tuples(NETWORK_TEXT | SERIAL_TEXT, st.sampled_from(["", " ", "\t"])).map(
    lambda case: (case[1] + case[0][0] + case[1], *case[0][1:]))
CONNECTION_TEXT = st.text(max_size=30) | NETWORK_TEXT.map(lambda case: case[0]) | SERIAL_TEXT.map(
    lambda case: case[0])


@pytest.mark.parametrize(("text", "value"), [("udpout:127.0.0.1:14550", "udpout:127.0.0.1:14550"),
                                             ("/dev/ttyACM0,115200", "/dev/ttyACM0,115200"),
                                             (" tcpin:0.0.0.0:5760 ", "tcpin:0.0.0.0:5760")])
def test_connection_strings_accepted(text: str, value: str) -> None:
    assert connection_string(text) == value


@pytest.mark.parametrize(("text", "reason"), [
    ("tcp:300.1.1.1:5760", "'300.1.1.1' is not an IPv4 address"),
    ("udpin:0.0.0.0:65536", "port must be 1..65535, got '65536'"),
    ("foo:host:1", "is not a MAVLink connection"),
    ("/dev/ttyACM0,abc", "is not a MAVLink connection"),
])
def test_connection_strings_refused(text: str, reason: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match=re.escape(reason)):
        connection_string(text)


@settings(max_examples=200, deadline=None)
@given(case=CONNECTION_CASES)
def test_connection_strings_are_parsed_or_refused(case: tuple[str, bool, str]) -> None:
    text, valid, expected = case
    if valid:
        assert connection_string(text) == expected
    else:
        with pytest.raises(argparse.ArgumentTypeError) as info:
            connection_string(text)
        assert repr(text) in str(info.value)


@settings(max_examples=100, deadline=None)
@given(text=CONNECTION_TEXT)
def test_any_text_is_parsed_or_refused(text: str) -> None:
    try:
        value = connection_string(text)
    except argparse.ArgumentTypeError as exc:
        assert str(exc)
        return
    assert value == value.strip() and (value.startswith(("/dev/", "COM")) or value.count(":") == 2)


@FAST
@given(case=CONNECTION_CASES)
def test_run_refuses_bad_connections_naming_the_option(case: tuple[str, bool, str]) -> None:
    text, valid, _ = case
    with tempfile.TemporaryDirectory() as tmp:
        plan = Path(tmp) / "no-plan"
        code, _, err = run_cli(["run", "--connect", text, "--plan", str(plan), "--out", str(Path(tmp) / "run")])
        assert code == 2  # a bad connection, or (a good one) the missing plan: nothing is flown
        if valid:  # the connection is taken: what stops the run is the plan
            assert_contract(code, err, [str(plan)])
            assert "--connect" not in err, err
        else:
            assert_contract(code, err, ["--connect"])
            assert "error: argument --connect: " in err, err


EXAMPLE_AREA = str(resources.files("planner").joinpath("data", "example_area.geojson"))


@pytest.fixture(scope="module")
def real_inputs(bare_frames: tuple[list[Path], str], tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """Inputs every command reads without complaint: the shipped example area, the two
    rendered tank frames (with their pose) beside ``bare_frames``, and a synthetic run folder."""
    from tests.planner.report.report_run import write_run

    folder = bare_frames[0][0].parent
    posed = sorted(p for p in folder.glob("*.npz") if not p.name.endswith(".truth.npz")
                   and not p.name.startswith("bare"))
    assert len(posed) == 2
    run = tmp_path_factory.mktemp("report_run") / "run"
    write_run(run, np.random.default_rng(20261123))
    return {"AREA": EXAMPLE_AREA, "FRAME0": str(posed[0]), "FRAME1": str(posed[1]), "RUN": str(run),
            "BARE": str(bare_frames[0][0])}


#: Valid inputs for each command (OUT: a fresh folder; sim-vehicle stops by itself).
_PLAN = ["plan", "AREA", "--out", "OUT", "--no-plot"]
_HEIGHTS = ["heights", "FRAME0", "FRAME1"]
_MOSAIC = ["mosaic", "FRAME0", "FRAME1", "--out", "OUT", "--no-registration"]
_REPORT = ["report", "RUN"]
_RENDER = ["render", "paper-tank", "--samples", "64", "--no-preview", "--out", "OUT"]
_SIM = ["sim-vehicle", "--scene", "paper-tank", "--listen", "udp:127.0.0.1:14987", "--duration-s", "0.5"]

#: (valid argv, option, bad value, what the error says is wrong): each value is refused
#: at the option with the reason of planner/commands/args.py.
BAD_NUMBERS = (
    (_PLAN, "--lane-heading-deg", "nan", "must be a finite number, got 'nan'"),
    (_PLAN, "--lane-heading-deg", "1e999", "must be a finite number, got '1e999'"),
    (_PLAN, "--lane-heading-deg", "abc", "must be a number, got 'abc'"),
    (_PLAN, "--lane-heading-deg", "0x10", "must be a number, got '0x10'"),
    (_PLAN, "--lane-heading-deg", "400", "must be <= 360 deg, got 400"),
    (_PLAN, "--lane-heading-deg", "-361", "must be >= -360 deg, got -361"),
    (_PLAN, "--origin", "91,5", "latitude must be within -90..90 deg"),
    (_PLAN, "--origin", "43", "must be LAT,LON in degrees"),
    ([*_HEIGHTS], "--delta-h", "inf", "must be a finite number, got 'inf'"),
    ([*_HEIGHTS], "--delta-h", "2000", "must be <= 1000 m, got 2000"),
    ([*_HEIGHTS], "--delta-h", "-1e308", "must be >= -1000 m, got -1e308"),
    ([*_HEIGHTS], "--altitude", "0", "must be > 0 m, got 0"),
    ([*_HEIGHTS], "--altitude", "-0.1", "must be > 0 m, got -0.1"),
    ([*_HEIGHTS], "--altitude", "1001", "must be <= 1000 m, got 1001"),
    ([*_MOSAIC, "--origin", "43.3,5.37"], "--resolution-m", "0", "must be >= 0.001 m, got 0"),
    ([*_MOSAIC, "--origin", "43.3,5.37"], "--resolution-m", "2", "must be <= 1 m, got 2"),
    ([*_MOSAIC, "--origin", "43.3,5.37"], "--resolution-m", "-inf", "must be a finite number, got '-inf'"),
    (_MOSAIC, "--origin", "43,181", "longitude must be within -180..180 deg"),
    (_REPORT, "--match-radius-m", "0", "must be > 0 m, got 0"),
    (_REPORT, "--match-radius-m", "nan", "must be a finite number, got 'nan'"),
    (_REPORT, "--dpi", "1.5", "must be a whole number, got '1.5'"),
    (_REPORT, "--dpi", "10", "must be >= 20, got 10"),
    (_REPORT, "--dpi", "601", "must be <= 600, got 601"),
    (_RENDER, "--altitude", "0", "must be > 0, got 0"),
    (_RENDER, "--altitude", "nan", "must be a finite number, got 'nan'"),
    ([*_RENDER, "--altitude", "0.5"], "--tilt-deg", "91", "must be <= 90 deg, got 91"),
    ([*_RENDER, "--altitude", "0.5"], "--tilt-deg", "-1e999", "must be a finite number, got '-1e999'"),
    ([*_RENDER, "--altitude", "0.5"], "--samples", "1", "must be >= 2, got 1"),
    ([*_RENDER, "--altitude", "0.5"], "--noise-floor-db", "inf", "must be a finite number, got 'inf'"),
    (_SIM, "--speedup", "0", "must be > 0, got 0"),
    (_SIM, "--speedup", "nan", "must be a finite number, got 'nan'"),
    (_SIM, "--seabed-depth-m", "12000", "must be <= 11000 m, got 12000"),
    (_SIM, "--seabed-depth-m", "0", "must be > 0 m, got 0"),
    (_SIM, "--start-depth-m", "-1", "must be >= 0, got -1"),
)


@pytest.mark.parametrize(("before", "option", "value", "reason"), BAD_NUMBERS,
                         ids=[f"{c[0][0]}{c[1]}={c[2]}" for c in BAD_NUMBERS])
def test_numbers_on_the_command_line(real_inputs: dict[str, str], tmp_path: Path, before: list[str],
                                     option: str, value: str, reason: str) -> None:
    """Every other input is real and valid, so the bad number alone is refused: exit 2,
    one line naming the option and saying what is wrong with the value."""
    argv = [real_inputs.get(a, a).replace("OUT", str(tmp_path / "out")) for a in before]
    code, _, err = run_cli([*argv, f"{option}={value}"])
    assert_contract(code, err, [option])
    assert code == 2
    assert f"error: argument {option}: {reason}" in err, err


@pytest.mark.parametrize(("frames", "reason"), [("a:b", "'a' is not an integer"), ("0:10:0", "step must not be zero"),
                                                ("1", "expected START:STOP or START:STOP:STEP")])
def test_convert_refuses_a_bad_frame_slice(real_inputs: dict[str, str], tmp_path: Path, frames: str,
                                           reason: str) -> None:
    code, _, err = run_cli(["convert", real_inputs["BARE"], str(tmp_path / "out.npz"), f"--frames={frames}"])
    assert_contract(code, err, ["--frames"])
    assert code == 2
    assert f"--frames {frames!r}: {reason}" in err, err
    assert not (tmp_path / "out.npz").exists()


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
