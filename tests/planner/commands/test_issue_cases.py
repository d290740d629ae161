"""The bad and odd inputs of issue 19, one by one: each gives exit 0 with a right result, or
exit 2 with one stderr line naming the file (or option), the key and what is wrong."""

from __future__ import annotations

import json
import math
import shutil
import struct
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import DATA_DIR
from tests.fuzz import run_cli

DATA = Path(str(resources.files("planner").joinpath("data")))
SITE = DATA / "scenarios" / "paper-targets"
EXAMPLES = DATA / "examples"
TANK_50, TANK_60 = EXAMPLES / "paper_tank_0.50m.npz", EXAMPLES / "paper_tank_0.60m.npz"
LAT, LON = 43.29512, 5.37451


def refused(argv: list[str], *names: str) -> str:
    """Run the command; assert exit 2 and one stderr line naming every one of ``names``."""
    code, _, err = run_cli(argv)
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for name in names:
        assert name in err, (name, err)
    return err


def _polygon(ring: list[list[object]]) -> dict[str, object]:
    return {"type": "Polygon", "coordinates": [ring]}


def _square(lon: float, lat: float, side_deg: float) -> list[list[float]]:
    return [[lon, lat], [lon + side_deg, lat], [lon + side_deg, lat + side_deg], [lon, lat + side_deg], [lon, lat]]


def _plan(tmp_path: Path, doc: object, *extra: str) -> tuple[int, str, str, Path]:
    area = tmp_path / "area.geojson"
    area.write_text(json.dumps(doc), encoding="utf-8")
    out = tmp_path / "plan"
    code, stdout, err = run_cli(["plan", str(area), "--config", str(SITE / "survey.toml"), "--out", str(out),
                                 "--no-plot", *extra])
    return code, stdout, err, area


# -- survey areas -------------------------------------------------------------------------------
def test_multipolygon_whose_coordinates_are_a_number(tmp_path: Path) -> None:
    area = tmp_path / "a.geojson"
    area.write_text(json.dumps({"type": "MultiPolygon", "coordinates": 5}))
    refused(["plan", str(area), "--out", str(tmp_path / "o")], str(area), "coordinates", "MultiPolygon")


def test_coordinates_given_as_strings(tmp_path: Path) -> None:
    ring = [[str(x), str(y)] for x, y in _square(LON, LAT, 1e-4)]
    code, _, err, area = _plan(tmp_path, _polygon(ring))
    assert code == 2 and str(area) in err and "coordinates[0][0]" in err and "not text" in err


def test_an_area_of_a_tenth_of_a_metre_is_refused(tmp_path: Path) -> None:
    code, _, err, area = _plan(tmp_path, _polygon(_square(LON, LAT, 0.1 / 111_000)))
    assert code == 2 and str(area) in err and "m^2" in err and "smaller than 1 m^2" in err


def test_a_small_area_reports_its_size(tmp_path: Path) -> None:
    code, stdout, err, _ = _plan(tmp_path, _polygon(_square(LON, LAT, 4e-5)))  # about 4.4 m x 3.2 m
    assert code == 0, err
    line = next(x for x in stdout.splitlines() if x.startswith("area to cover"))
    assert "0 m^2" not in line and float(line.split()[3]) == pytest.approx(14.3, abs=1.0)


def test_a_polygon_across_the_antimeridian_is_planned_where_it_is(tmp_path: Path) -> None:
    ring = [[179.9996, -16.5], [-179.9996, -16.5], [-179.9996, -16.4996], [179.9996, -16.4996], [179.9996, -16.5]]
    code, _, err, _ = _plan(tmp_path, _polygon(ring))
    assert code == 0, err
    plan = json.loads((tmp_path / "plan" / "survey.plan").read_text())
    lons = [item["params"][5] for item in plan["mission"]["items"] if item["params"][5] not in (0, None)]
    assert lons and all(abs(abs(lon) - 180.0) < 0.01 for lon in lons)  # beside the antimeridian, not at 0


def test_a_multipolygon_second_part_is_not_silently_a_keepout(tmp_path: Path) -> None:
    doc = {"type": "MultiPolygon", "coordinates": [[_square(LON, LAT, 1e-4)], [_square(LON + 3e-4, LAT, 1e-4)]]}
    code, _, err, area = _plan(tmp_path, doc)
    assert code == 2 and str(area) in err and "MultiPolygon of 2 parts" in err
    keepouts = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"role": "boundary"}, "geometry": _polygon(_square(LON, LAT, 3e-4))},
        {"type": "Feature", "properties": {"role": "keepout"},
         "geometry": {"type": "MultiPolygon", "coordinates": [[_square(LON + 1e-5, LAT + 1e-5, 2e-5)],
                                                              [_square(LON + 2e-4, LAT + 2e-4, 2e-5)]]}}]}
    code, _, err, _ = _plan(tmp_path, keepouts)
    assert code == 0, err  # a keep-out MultiPolygon is two keep-outs


def test_local_origin_that_is_not_a_number(tmp_path: Path) -> None:
    doc = {"type": "Polygon", "local_origin": {"lat_deg": "abc", "lon_deg": 5.0},
           "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]]}
    code, _, err, area = _plan(tmp_path, doc)
    assert code == 2 and str(area) in err and "local_origin.lat_deg" in err
    assert "could not convert" not in err


def test_lane_heading_nan(tmp_path: Path) -> None:
    refused(["plan", str(SITE / "area.geojson"), "--out", str(tmp_path / "o"), "--lane-heading-deg", "nan"],
            "--lane-heading-deg", "finite")


@pytest.mark.parametrize("name", ["area.geojson", "survey.toml"])
def test_files_that_are_not_utf8_are_named(tmp_path: Path, name: str) -> None:
    bad = tmp_path / name
    bad.write_bytes(b"\xff\xfe\x00garbage")
    area = bad if name == "area.geojson" else SITE / "area.geojson"
    config = bad if name == "survey.toml" else SITE / "survey.toml"
    err = refused(["plan", str(area), "--config", str(config), "--out", str(tmp_path / "o")], str(bad), "UTF-8")
    assert "codec can't decode" not in err


# -- plan folders ---------------------------------------------------------------------------------
def test_plan_into_an_existing_plan_needs_overwrite_and_replaces_it_whole(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    args = ["plan", str(SITE / "area.geojson"), "--config", str(SITE / "survey.toml"), "--out", str(out)]
    assert run_cli(args)[0] == 0
    assert (out / "survey.png").is_file()
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    refused(args, "--out", str(out), "--overwrite")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert run_cli([*args, "--overwrite", "--no-plot"])[0] == 0
    assert not (out / "survey.png").exists()  # no stale picture beside the new plan
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan"]  # nothing left beside it


def test_plan_never_replaces_someone_elses_folder(tmp_path: Path) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.txt").write_text("years of work")
    refused(["plan", str(SITE / "area.geojson"), "--out", str(out), "--overwrite"], str(out), "not a shadowsurvey")
    assert (out / "thesis.txt").read_text() == "years of work"


# -- scenarios --------------------------------------------------------------------------------------
@pytest.mark.parametrize(("line", "key"), [('vehicle = "fast"', "vehicle"), ("faults = [1, 2]", "faults"),
                                           ("[current]\nnorth_m_s = 'abc'", "current.north_m_s"),
                                           ("[faults]\npacket_loss = 2.0", "faults.packet_loss"),
                                           ("[faults]\nlink_cuts = [[5, 1]]", "faults.link_cuts[0]"),
                                           ("[executor]\ncontrol_period_s = 'x'", "executor.control_period_s"),
                                           ("[sensors]\naltimeter_noise_m = -1", "sensors.altimeter_noise_m")])
def test_bad_scenarios_name_the_key_and_touch_no_folder(tmp_path: Path, line: str, key: str) -> None:
    site = tmp_path / "site"
    shutil.copytree(SITE, site)
    name = line.split("]")[0].lstrip("[").split("=")[0].strip()
    text = _without_table((site / "scenario.toml").read_text(), name)
    # a top-level key goes before the first table, a table at the end
    text = f"{line}\n{text}\n" if not line.startswith("[") else f"{text}\n{line}\n"
    (site / "scenario.toml").write_text(text)
    run = tmp_path / "run"
    run.mkdir()
    (run / "events.jsonl").write_text('{"t_s": 1.0, "kind": "state", "message": "old dive"}\n')
    (run / "summary.json").write_text('{"status": "completed"}\n')
    before = {p.name: p.read_bytes() for p in run.iterdir()}
    refused(["sim", str(site), "--out", str(run), "--overwrite", "--no-progress"], str(site / "scenario.toml"), key)
    assert {p.name: p.read_bytes() for p in run.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "site"]


def _without_table(text: str, name: str) -> str:
    """``text`` without the table ``[name]`` (its header and keys) or a top-level key ``name``."""
    out, skipping = [], False
    for row in text.splitlines():
        stripped = row.strip()
        if stripped.startswith("["):
            skipping = stripped.split("]")[0].strip("[ ") == name
        elif stripped.split("=")[0].strip() == name and not skipping:
            continue
        if not skipping:
            out.append(row)
    return "\n".join(out)


# -- frames -----------------------------------------------------------------------------------------
def _frame_file(tmp_path: Path, name: str, **changes: object) -> Path:
    arrays = dict(np.load(TANK_60))
    for key, value in changes.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = np.asarray(value)
    path = tmp_path / name
    np.savez(path, **arrays)
    return path


def test_complex_range_is_refused(tmp_path: Path) -> None:
    bad = _frame_file(tmp_path, "c.npz", range_m=np.load(TANK_60)["range_m"] + 0j)
    refused(["heights", str(TANK_50), str(bad)], str(bad), "range_m", "real")


def test_negative_altitude_is_refused(tmp_path: Path) -> None:
    bad = _frame_file(tmp_path, "n.npz", altitude_m=-0.6)
    refused(["heights", str(TANK_50), str(bad)], str(bad), "altitude_m", "> 0")


def test_delta_h_against_the_frames_altitudes() -> None:
    refused(["heights", str(TANK_50), str(TANK_60), "--delta-h", "1000"], "--delta-h", "range window")
    refused(["heights", str(TANK_50), str(TANK_60), "--delta-h", "-0.1"], "--delta-h", "altitude_m", "contradicts")
    code, out, err = run_cli(["heights", str(TANK_50), str(TANK_60), "--delta-h", "0.1"])
    assert code == 0 and "array(" not in out


def test_negative_delta_h_without_altitudes_is_named_not_a_repr(tmp_path: Path) -> None:
    a = _frame_file(tmp_path, "a.npz", altitude_m=None, sonar_depth_m=None)
    b = _frame_file(tmp_path, "b.npz", altitude_m=None, sonar_depth_m=None,
                    image=np.load(TANK_60)["image"], timestamp_s=1.0)
    np.savez(a, **{k: v for k, v in np.load(TANK_50).items() if k not in ("altitude_m", "sonar_depth_m")})
    err = refused(["heights", str(a), str(b), "--delta-h", "-0.1"], "--delta-h", "below")
    assert "array(" not in err


def test_an_altitude_beyond_the_window_is_refused(tmp_path: Path) -> None:
    a = _frame_file(tmp_path, "a.npz", altitude_m=None, sonar_depth_m=None)
    b = _frame_file(tmp_path, "b.npz", altitude_m=None, sonar_depth_m=None, timestamp_s=1.0)
    refused(["heights", str(a), str(b), "--altitude", "4", "--delta-h", "0.1"], str(a), "range window")
    high = _frame_file(tmp_path, "h.npz", altitude_m=3.5, sonar_depth_m=None)
    refused(["mosaic", str(high), "--origin", "43.3,5.37", "--out", str(tmp_path / "m")], str(high), "range window")


def test_sim_and_run_never_write_into_someones_folder(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    refused(["sim", "--out", str(mine), "--no-progress"], str(mine), "--overwrite")
    refused(["sim", "--out", str(mine), "--overwrite", "--no-progress"], str(mine), "not a shadowsurvey run")
    refused(["run", "--connect", "udpin:0.0.0.0:14770", "--plan", "p", "--out", str(mine)], str(mine), "--overwrite")
    assert [p.name for p in mine.iterdir()] == ["notes.txt"] and (mine / "notes.txt").read_text() == "keep"


def test_frames_of_two_scenes(tmp_path: Path) -> None:
    water = _frame_file(tmp_path, "w.npz", sound_speed_mps=1540.0)
    refused(["heights", str(TANK_50), str(water)], str(water), str(TANK_50), "sound_speed_mps")
    deep = _frame_file(tmp_path, "d.npz", sonar_depth_m=5.25)
    refused(["heights", str(TANK_50), str(deep)], str(deep), "seabed", "sonar_depth_m")


def test_an_aris_file_named_npz(tmp_path: Path) -> None:
    fake = tmp_path / "recording.npz"
    shutil.copy(DATA_DIR / "aris" / "sample.aris", fake)
    err = refused(["info", str(fake)], str(fake), "ARIS recording", ".aris suffix")
    assert "allow_pickle" not in err


def _aris_with(tmp_path: Path, name: str, offset: int, fmt: str, value: object, frames: int = 6) -> Path:
    data = bytearray((DATA_DIR / "aris" / "sample.aris").read_bytes())
    frame_size = 1024 + 96_000
    for i in range(frames):
        struct.pack_into(fmt, data, 1024 + i * frame_size + offset, value)
    path = tmp_path / name
    path.write_bytes(bytes(data))
    return path


def test_aris_header_with_a_window_of_thousands_of_kilometres(tmp_path: Path) -> None:
    bad = _aris_with(tmp_path, "far.aris", 476, "<I", 4_293_000_000)  # SampleStartDelay, us
    refused(["convert", str(bad), str(tmp_path / "o.npz")], str(bad), "SampleStartDelay", "km")
    refused(["info", str(bad)], str(bad), "SampleStartDelay")
    refused(["heights", str(bad), str(TANK_50)], str(bad), "SampleStartDelay")


def test_aris_with_no_altimeter_records_altitude_zero_as_unknown(tmp_path: Path) -> None:
    path = _aris_with(tmp_path, "noalt.aris", 128, "<f", 4.5)  # Depth set, Altitude left 0
    code, out, err = run_cli(["info", "--json", str(path)])
    assert code == 0, err
    info = json.loads(out)
    assert "sonar_depth_m" in info["pose_fields"] and "altitude_m" not in info["pose_fields"]


# -- run folders, connections, options -----------------------------------------------------------------
def test_report_on_an_empty_folder_writes_nothing(tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    refused(["report", str(empty)], str(empty), "not a run folder")
    assert not any(empty.iterdir())


def test_run_connect_foo_bar() -> None:
    refused(["run", "--connect", "foo:bar", "--plan", "p"], "--connect", "foo:bar", "udpin:HOST:PORT")


def test_sim_vehicle_blames_the_seabed_option() -> None:
    refused(["sim-vehicle", "--seabed-depth-m", "-5"], "--seabed-depth-m")
    refused(["sim-vehicle", "--seabed-depth-m", "5", "--start-depth-m", "6"], "--start-depth-m",
            "--seabed-depth-m", "5 m")


def test_mosaic_needs_an_origin(tmp_path: Path) -> None:
    refused(["mosaic", str(TANK_50), "--out", str(tmp_path / "m")], "--origin")


def test_navigation_csv_cells_are_named(tmp_path: Path) -> None:
    nav = tmp_path / "nav.csv"
    nav.write_text("t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg\n0,0,0,0,0.5,20\n1,abc,0,0,0.5,20\n")
    err = refused(["mosaic", str(TANK_50), "--nav", str(nav), "--origin", "43.3,5.37", "--out", str(tmp_path / "m")],
                  f"{nav}:3", "north_m", "'abc'")
    assert "could not convert" not in err
    nav.write_bytes(b"t_s,north_m\n\xff\xfe\n")
    refused(["mosaic", str(TANK_50), "--nav", str(nav), "--origin", "43.3,5.37", "--out", str(tmp_path / "m")],
            str(nav), "UTF-8")


def test_mosaic_origin_places_the_map(tmp_path: Path) -> None:
    code, _, err = run_cli(["mosaic", str(TANK_50), str(TANK_60), "--origin", f"{LAT},{LON}",
                            "--out", str(tmp_path / "m")])
    assert code == 0, err
    doc = json.loads((tmp_path / "m" / "targets.geojson").read_text())
    for feature in doc["features"]:
        lon, lat = feature["geometry"]["coordinates"][:2]
        assert math.isclose(lat, LAT, abs_tol=1e-4) and math.isclose(lon, LON, abs_tol=1e-4)
