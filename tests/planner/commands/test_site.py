"""``shadowsurvey site DIR --area AREA --depth-m D``: a dry-run scenario of a user's own site.

The folder it writes plans as written (``prepare_dry_dive``) and flies (a tiny site, end to
end); it never overwrites what a user has and leaves nothing half-written; and every
mistake in the options or, afterwards, in the files the user edits exits 2 with one line
naming the file (or option) and the key.
"""

from __future__ import annotations

import json
import shutil
import tomllib
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import pytest

from perception.geodesy import LocalOrigin
from planner.dryrun.consistency import check_consistent
from planner.dryrun.dive import prepare_dry_dive
from planner.dryrun.scenario import load_scenario
from planner.dryrun.site_template import EXAMPLES_BEGIN, EXAMPLES_END
from planner.survey.area import load_area
from sim_harness.sonar.scene import load_scene
from tests.fuzz import run_cli

DATA = Path(str(resources.files("planner").joinpath("data")))
HARBOUR_AREA = DATA / "scenarios" / "harbour-field" / "area.geojson"
LAT, LON = 43.2951, 5.3745


def rectangle(north_m: float, east_m: float, *, lat: float = LAT, lon: float = LON) -> dict[str, Any]:
    """A WGS84 GeoJSON boundary ``north_m`` x ``east_m`` with its south-west corner at (lat, lon)."""
    origin = LocalOrigin(lat, lon)
    corners = [(0.0, 0.0), (0.0, east_m), (north_m, east_m), (north_m, 0.0), (0.0, 0.0)]
    ring = []
    for n, e in corners:
        la, lo = origin.to_lat_lon(n, e)
        ring.append([round(float(lo), 9), round(float(la), 9)])
    feature = {"type": "Feature", "properties": {"role": "boundary"},
               "geometry": {"type": "Polygon", "coordinates": [ring]}}
    return {"type": "FeatureCollection", "features": [feature]}


def write_area(folder: Path, doc: Any, name: str = "my-area.geojson") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(doc) if not isinstance(doc, str) else doc, encoding="utf-8")
    return path


def site(folder: Path, area: Path, *options: str) -> tuple[int, str, str]:
    return run_cli(["site", str(folder), "--area", str(area), *options])


def uncomment_examples(scene: Path) -> None:
    """The example targets of a written scene.toml, uncommented (as a user starts)."""
    out, inside = [], False
    for line in scene.read_text(encoding="utf-8").splitlines():
        if line in (EXAMPLES_BEGIN, EXAMPLES_END):
            inside = line == EXAMPLES_BEGIN
            continue
        if inside and (line.startswith("# [[") or (line.startswith("# ") and " = " in line)):
            line = line[2:]
        out.append(line)
    scene.write_text("\n".join(out) + "\n", encoding="utf-8")


# -- the folder ------------------------------------------------------------------------------------
def test_a_harbour_site_plans_as_written(tmp_path: Path) -> None:
    folder = tmp_path / "quay"
    code, out, err = site(folder, HARBOUR_AREA, "--depth-m", "12", "--slope-deg", "2", "--slope-direction-deg", "180")
    assert code == 0, err
    assert sorted(p.name for p in folder.iterdir()) == ["area.geojson", "scenario.toml", "scene.toml", "survey.toml"]
    assert (folder / "area.geojson").read_bytes() == HARBOUR_AREA.read_bytes()
    assert "field settings" in out and f"shadowsurvey sim {folder}" in out
    prepared = prepare_dry_dive(load_scenario(folder))
    check_consistent(prepared)
    # the origin is the area's own: the centre of its bounding box, as `shadowsurvey plan` takes it
    area = load_area(HARBOUR_AREA)
    assert (prepared.origin.lat_deg, prepared.origin.lon_deg) == pytest.approx(
        (area.origin_lat_deg, area.origin_lon_deg), abs=1e-9)
    seabed = prepared.scene.world.seabed
    assert seabed.depth_m == 12.0 and seabed.slope_rad == pytest.approx(0.0349066, abs=1e-6)
    assert seabed.plane_depth_m(-10.0, 0.0) == pytest.approx(12.349, abs=1e-3)  # deeper to the south
    assert prepared.scene.world.targets == () and prepared.scene.world.seabed.texture is not None
    settings = prepared.settings
    assert settings.site.water_depth_m == 12.0 and settings.vehicle.max_depth_m == 16.0
    assert (settings.sonar.window_start_m, settings.sonar.window_end_m) == (1.0, 8.0)
    # 2 deg at 0.5 m/s rises 1.75 cm/s: 3 s of it (the vehicle trails a rising seabed) on 5 cm
    assert settings.vehicle.depth_hold_m == 0.16  # 0.05 + 6 s of a 2 deg rise at 0.5 m/s
    assert prepared.plan.passes[0].altitude_m == pytest.approx(settings.min_altitude_m + 0.16, abs=1e-4)
    assert prepared.scenario.start_north_m == pytest.approx(-12.0, abs=0.01)  # 2 m south of the area
    assert len(prepared.plan.passes) == 2


@pytest.mark.parametrize(("depth", "slope", "preset", "window_end_m"), [
    ("2", None, "near-bottom", 3.0), ("7.5", None, "near-bottom", 3.0), ("8", None, "field", 8.0),
    ("300", None, "field", 8.0), ("8.2", ("2", "0"), "near-bottom", 3.0)])
def test_the_settings_suit_the_shallowest_seabed(tmp_path: Path, depth: str, slope: tuple[str, str] | None,
                                                 preset: str, window_end_m: float) -> None:
    area = write_area(tmp_path, rectangle(12.0, 8.0))
    folder = tmp_path / "site"
    options = ["--depth-m", depth] + (["--slope-deg", slope[0], "--slope-direction-deg", slope[1]] if slope else [])
    code, out, err = site(folder, area, *options)
    assert code == 0, err
    assert f"({preset} settings)" in out
    prepared = prepare_dry_dive(load_scenario(folder))
    assert prepared.settings.sonar.window_end_m == window_end_m
    shallowest = float(depth) - (0.21 if slope else 0.0)  # a 2 deg slope over 6 m north of the centre
    assert prepared.plan.passes[-1].altitude_m <= shallowest - prepared.settings.vehicle.min_depth_m


def test_an_area_in_local_metres_keeps_its_origin(tmp_path: Path) -> None:
    doc = {"type": "Polygon", "local_origin": {"lat_deg": 43.3, "lon_deg": 5.37},
           "coordinates": [[[0, 0], [6, 0], [6, 4], [0, 4], [0, 0]]]}
    folder = tmp_path / "local"
    code, _, err = site(folder, write_area(tmp_path, doc), "--depth-m", "6")
    assert code == 0, err
    prepared = prepare_dry_dive(load_scenario(folder))
    assert (prepared.origin.lat_deg, prepared.origin.lon_deg) == (43.3, 5.37)
    assert prepared.scenario.start_north_m == -2.0 and prepared.scenario.start_east_m == 3.0
    assert prepared.area.outer.bounds == pytest.approx((0.0, 0.0, 6.0, 4.0))


@pytest.mark.parametrize("depth", ["5", "20"])
def test_the_example_targets_load_inside_the_area(tmp_path: Path, depth: str) -> None:
    folder = tmp_path / "site"
    assert site(folder, HARBOUR_AREA, "--depth-m", depth)[0] == 0
    uncomment_examples(folder / "scene.toml")
    prepared = prepare_dry_dive(load_scenario(folder))
    check_consistent(prepared)
    targets = prepared.scene.world.targets
    assert len(targets) == 4 and {t.shape for t in targets} == {"box", "cylinder", "pipe", "stone" if depth == "5"
                                                               else "rock"}
    tallest = max(t.height_m for t in targets)
    assert tallest <= prepared.settings.site.target_height_max_m
    # the second example is placed by lat_deg/lon_deg
    raw = tomllib.loads((folder / "scene.toml").read_text(encoding="utf-8"))["targets"]
    assert "lat_deg" in raw[1] and "north_m" not in raw[1] and "north_m" in raw[0]


def test_a_name_with_quotes_and_accents_is_kept(tmp_path: Path) -> None:
    folder = tmp_path / "site"
    assert site(folder, HARBOUR_AREA, "--depth-m", "12", "--name", 'Quai "B" \\ Saint-Jean, été')[0] == 0
    scenario = load_scenario(folder)
    assert scenario.name == 'Quai "B" \\ Saint-Jean, été' and "été" in scenario.description
    assert load_scene(folder / "scene.toml").name == scenario.name


def test_an_area_across_the_antimeridian_with_its_examples(tmp_path: Path) -> None:
    area = write_area(tmp_path, rectangle(10.0, 20.0, lat=-16.5, lon=179.99990))
    folder = tmp_path / "site"
    code, _, err = site(folder, area, "--depth-m", "9")
    assert code == 0, err
    uncomment_examples(folder / "scene.toml")
    prepared = prepare_dry_dive(load_scenario(folder))
    check_consistent(prepared)
    assert len(prepared.scene.world.targets) == 4 and prepared.area.outer.bounds == pytest.approx(
        (-10.0, -5.0, 10.0, 5.0), abs=0.01)


# -- nothing a user has is overwritten, nothing is left half-written --------------------------------
def test_an_existing_folder_needs_overwrite_and_must_be_a_scenario(tmp_path: Path) -> None:
    folder = tmp_path / "site"
    assert site(folder, HARBOUR_AREA, "--depth-m", "12")[0] == 0
    (folder / "scene.toml").write_text((folder / "scene.toml").read_text() + "# my notes\n")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    code, _, err = site(folder, HARBOUR_AREA, "--depth-m", "14")
    assert code == 2 and err.count("\n") == 1 and str(folder) in err and "--overwrite" in err
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    code, _, err = site(folder, HARBOUR_AREA, "--depth-m", "14", "--overwrite")
    assert code == 0, err
    assert "# my notes" not in (folder / "scene.toml").read_text() and "depth_m = 14.0" in (
        folder / "scene.toml").read_text()
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "chapter1.txt").write_text("years of work")
    code, _, err = site(mine, HARBOUR_AREA, "--depth-m", "12", "--overwrite")
    assert code == 2 and "not a shadowsurvey scenario folder" in err and err.count("\n") == 1
    assert [p.name for p in mine.iterdir()] == ["chapter1.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site", "thesis"]


def test_ctrl_c_while_writing_leaves_the_old_folder_and_no_debris(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import planner.commands.site as command

    folder = tmp_path / "site"
    assert site(folder, HARBOUR_AREA, "--depth-m", "12")[0] == 0
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    real: Callable[..., Path] = command.atomic_write_text
    calls: list[Path] = []

    def interrupted(path: Path, text: str) -> Path:
        calls.append(path)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(path, text)

    monkeypatch.setattr(command, "atomic_write_text", interrupted)
    code, _, err = site(folder, HARBOUR_AREA, "--depth-m", "20", "--overwrite")
    assert code == 130 and "nothing written" in err and err.count("\n") == 1
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["site"]  # the folder built aside is gone


# -- a tiny site, end to end -----------------------------------------------------------------------
@pytest.mark.slow
def test_a_tiny_site_flies_with_its_example_targets(tmp_path: Path) -> None:
    folder = tmp_path / "tiny"
    code, _, err = site(folder, write_area(tmp_path, rectangle(3.0, 1.3)), "--depth-m", "6")
    assert code == 0, err
    uncomment_examples(folder / "scene.toml")
    code, out, err = run_cli(["sim", str(folder), "--out", str(tmp_path / "run"), "--no-progress"])
    assert code == 0, err
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["n_truth_targets"] == 4
    assert summary["n_matched"] >= 3 and summary["height_mean_abs_error_m"] < 0.02
    truth = {t["id"] for t in json.loads((tmp_path / "run" / "truth.json").read_text())["targets"]}
    assert truth == {"BLOCK", "CAN", "STONE", "PIPE"}


@pytest.mark.slow
def test_a_sloping_site_is_flown_above_its_clearance(tmp_path: Path) -> None:
    """6 m x 1.3 m on a 3 deg slope, deeper to the south: the lanes run up and down it. The
    helm leads the rising seabed (``ExecutorConfig.slope_lead_s``) and ``site`` plans the
    lower pass ``depth_hold_m`` = 0.21 m above the clearance (6 s of the rise,
    ``SLOPE_FOLLOW_LAG_S``). With 0.13 m (3 s) the lowest was 0.513-0.550 m in six dives with
    the lead, once 0.494 m without it (6 mm below the 0.50 m clearance).

    The vehicle must never go below its clearance. It need not finish: the altitude filter
    is built for level lanes (its seabed estimate climbs a slope in steps, and in two of
    four dives its depth estimate ran away after a reset on a lane down the slope, so the
    altitude change that followed did not settle and the dive ended in its safe hold,
    ``altitude_not_settled``)."""
    folder = tmp_path / "slope"
    code, _, err = site(folder, write_area(tmp_path, rectangle(6.0, 1.3)), "--depth-m", "6", "--slope-deg", "3",
                        "--slope-direction-deg", "180")
    assert code == 0, err
    code, _, err = run_cli(["sim", str(folder), "--out", str(tmp_path / "run"), "--no-progress"])
    assert code in (0, 1), err  # 1: the dive ended before the survey was flown
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert (code == 0) == (summary["status"] == "completed")
    assert summary["status"] == "completed" or (summary["status"] == "aborted"
                                                 and summary["reason"] == "altitude_not_settled"
                                                 and summary["safe_action"] is not None), summary["message"]
    allowed = summary["min_altitude_allowed_m"]
    assert summary["min_clearance_m"] >= allowed, (summary["min_clearance_m"], allowed)
    assert not [e for e in summary["altitude_excursions_true"] if e["check"] == "clearance"]


# -- every mistake: exit 2, one line naming the file (or option) and the key -----------------------
def refused(argv: list[str], *names: str) -> str:
    code, _, err = run_cli(argv)
    assert code == 2, (code, err)
    assert err.endswith("\n") and err.count("\n") == 1 and "Traceback" not in err, err
    for name in names:
        assert name in err, (name, err)
    return err


@pytest.mark.parametrize(("options", "names"), [
    ([], ["--depth-m", "required"]),
    (["--depth-m", "-6"], ["--depth-m", "must be >= 2 m"]),
    (["--depth-m", "0"], ["--depth-m", "must be >= 2 m"]),
    (["--depth-m", "nan"], ["--depth-m", "finite"]),
    (["--depth-m", "deep"], ["--depth-m", "must be a number"]),
    (["--depth-m", "301"], ["--depth-m", "must be <= 300 m"]),
    (["--depth-m", "6", "--slope-deg", "30", "--slope-direction-deg", "0"], ["--slope-deg", "must be <= 10 deg"]),
    (["--depth-m", "6", "--slope-deg", "-1", "--slope-direction-deg", "0"], ["--slope-deg", "must be >= 0 deg"]),
    (["--depth-m", "6", "--slope-deg", "2"], ["--slope-deg", "needs --slope-direction-deg"]),
    (["--depth-m", "6", "--slope-direction-deg", "90"], ["--slope-direction-deg", "needs --slope-deg"]),
    (["--depth-m", "6", "--slope-deg", "2", "--slope-direction-deg", "400"], ["--slope-direction-deg", "<= 360"]),
    (["--depth-m", "2.5", "--slope-deg", "10", "--slope-direction-deg", "90"],
     ["--slope-deg", "2-300 m deep everywhere"]),
    (["--depth-m", "6", "--name", " "], ["--name", "one line of printable text"]),
    (["--depth-m", "6", "--name", "quay\nb = 1"], ["--name", "one line of printable text"]),
])
def test_bad_options_are_named_and_write_nothing(tmp_path: Path, options: list[str], names: list[str]) -> None:
    area = write_area(tmp_path, rectangle(30.0, 20.0))
    refused(["site", str(tmp_path / "site"), "--area", str(area), *options], *names)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my-area.geojson"]


@pytest.mark.parametrize(("doc", "names"), [
    ('{"type": "Polygon", "coordinates": [[[5.37, 43.29], ', ["not valid JSON"]),
    ("", ["not valid JSON"]),
    ({"type": "Point", "coordinates": [5.37, 43.29]}, ["no polygon"]),
    ({"type": "Polygon", "coordinates": [[[5.37, 43.29], [5.371, 43.29], [5.37, 43.29]]]}, ["at least 4 positions"]),
    ({"type": "Polygon", "coordinates": [[[543.0, 43.29], [543.1, 43.29], [543.1, 43.3], [543.0, 43.29]]]},
     ["out of range for [lon, lat]"]),
    (rectangle(2500.0, 100.0), ["--area", "within 1000 m of the origin"]),
])
def test_a_bad_area_file_is_named(tmp_path: Path, doc: Any, names: list[str]) -> None:
    area = write_area(tmp_path, doc)
    file_or_option = [] if names[0] == "--area" else [str(area)]
    refused(["site", str(tmp_path / "site"), "--area", str(area), "--depth-m", "6"], *file_or_option, *names)
    assert not (tmp_path / "site").exists()


def test_a_missing_area_file_and_a_folder_that_is_a_file_are_named(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.geojson"
    refused(["site", str(tmp_path / "site"), "--area", str(missing), "--depth-m", "6"], str(missing), "cannot read")
    afile = tmp_path / "notes.txt"
    afile.write_text("keep")
    refused(["site", str(afile), "--area", str(HARBOUR_AREA), "--depth-m", "6"], "DIR", str(afile), "not a folder")
    assert afile.read_text() == "keep"


@pytest.fixture(scope="module")
def written_site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A site written once (a 6 m x 4 m area at 6 m), copied by each case."""
    tmp = tmp_path_factory.mktemp("written")
    folder = tmp / "site"
    code, _, err = site(folder, write_area(tmp, rectangle(6.0, 4.0)), "--depth-m", "6")
    assert code == 0, err
    return folder


_BOX = ('[[targets]]\nid = "X"\nshape = "box"\nnorth_m = 0.5\neast_m = 0.5\nlength_m = 0.2\nwidth_m = 0.1\n'
        'height_m = 0.05\n')
_LAT_LON = "lat_deg = 43.2951\nlon_deg = 5.3745\n"  # the area's south-west corner


def _append(text: str) -> Callable[[str], str]:
    return lambda old: old.replace("\n[viewpoint]", f"\n{text}\n[viewpoint]", 1)


def _sub(old: str, new: str) -> Callable[[str], str]:
    def change(text: str) -> str:
        assert old in text, old
        return text.replace(old, new, 1)
    return change


#: (file, how the user breaks it, what the one line must name besides the file)
BROKEN: list[tuple[str, Callable[[str], str], list[str]]] = [
    ("scene.toml", _sub("depth_m = 6.0 ", "# depth_m = 6.0 "), ["seabed.depth_m", "is required"]),
    ("scene.toml", _sub("depth_m = 6.0 ", "depth_m = -6.0 "), ["seabed.depth_m", "must be > 0"]),
    ("scene.toml", _sub("slope_deg = 0.0 ", "slope_deg = 50.0 "), ["seabed.slope_deg", "[0, 45) deg"]),
    ("scene.toml", _sub("slope_deg = 0.0 ", 'slope_deg = "steep" '), ["seabed.slope_deg", "must be a number"]),
    ("scene.toml", _sub('material = "sand"', 'material = "kryptonite"'), ["material", "unknown material"]),
    ("scene.toml", _sub("texture_seed = 1", "texture_seed = 1\ncolour = 3"), ["seabed.colour", "unknown key"]),
    ("scene.toml", _append(_BOX.replace("north_m = 0.5", "north_m = 9.5")), ["targets[0]", "outside the survey area"]),
    ("scene.toml", _append(_BOX.replace("north_m = 0.5\neast_m = 0.5\n", "lat_deg = 43.2953\nlon_deg = 5.3745\n")),
     ["targets[0]", "outside the survey area"]),
    ("scene.toml", _append(_BOX.replace('"box"', '"pyramid"')), ["targets[0].shape", "unknown shape 'pyramid'"]),
    ("scene.toml", _append(_BOX.replace("width_m = 0.1\n", "")), ["targets[0].width_m", "is required"]),
    ("scene.toml", _append(_BOX.replace("length_m = 0.2\nwidth_m = 0.1\n", "diameter_m = 0.2\n")),
     ["targets[0].diameter_m", "a box takes length_m and width_m"]),
    ("scene.toml", _append(_BOX.replace("height_m = 0.05", "height_m = -0.05")), ["targets[0].height_m", "> 0"]),
    ("scene.toml", _append(_BOX.replace("east_m = 0.5\n", "east_m = 0.5\n" + _LAT_LON)),
     ["targets[0].lat_deg", "give either lat_deg/lon_deg or north_m/east_m, not both"]),
    ("scene.toml", _append(_BOX.replace("north_m = 0.5\neast_m = 0.5\n", "lat_deg = 43.2951\n")),
     ["targets[0].lon_deg", "is required with lat_deg"]),
    ("scene.toml", _append(_BOX.replace("north_m = 0.5\neast_m = 0.5\n", "lat_deg = 91.0\nlon_deg = 5.3745\n")),
     ["targets[0].lat_deg", "(-90, 90)"]),
    ("scene.toml", _append(_BOX + _BOX), ["targets", "duplicate target id 'X'"]),
    ("scene.toml", _sub("lat_deg = 43.29", "lat_deg = 43.39"), ["origin", "km from the vehicle's start"]),
    ("scene.toml", _sub("lat_deg = 43.29", "lat_deg = 44.29"), ["area.geojson", "km from the origin"]),
    ("scene.toml", _sub("\n[origin]", "\n[orign]"), ["orign", "unknown key"]),
    ("scene.toml", _sub("[viewpoint]", "[viewpoint\n"), ["cannot parse"]),
    ("area.geojson", lambda text: text[: len(text) // 2], ["not valid JSON"]),
    ("area.geojson", lambda text: text.replace('"Polygon"', '"Polygon2"'), ["Polygon2"]),
    ("survey.toml", _sub("water_depth_m = 6.0 ", "water_depth_m = -6.0 "), ["site.water_depth_m", "must be > 0"]),
    ("survey.toml", _sub("altitude_max_m = 1.0", "altitude_max_m = 0.2"), ["altitudes.altitude_max_m"]),
    ("scenario.toml", _sub("start_north_m = ", "start_north_m = 5000.0 #"), ["vehicle.start_north_m"]),
    ("scenario.toml", _sub('scene = "scene.toml"', 'scene = "scenery.toml"'), ["scene", "not found"]),
]


@pytest.mark.parametrize(("name", "change", "names"), BROKEN,
                         ids=[f"{n}-{'-'.join(k[:1])}-{i}" for i, (n, _, k) in enumerate(BROKEN)])
def test_every_mistake_in_the_sites_files_is_one_line_naming_file_and_key(
        tmp_path: Path, written_site: Path, no_dive: list[Any], name: str, change: Callable[[str], str],
        names: list[str]) -> None:
    folder = tmp_path / "site"
    shutil.copytree(written_site, folder)
    path = folder / name
    path.write_text(change(path.read_text(encoding="utf-8")), encoding="utf-8")
    culprit = str(folder / "area.geojson") if "area.geojson" in names else str(path)
    refused(["sim", str(folder), "--out", str(tmp_path / "run"), "--no-progress"], culprit, *names)
    assert not no_dive and not (tmp_path / "run").exists()


def test_the_written_site_itself_reaches_the_dive(tmp_path: Path, written_site: Path, no_dive: list[Any]) -> None:
    code, _, err = run_cli(["sim", str(written_site), "--out", str(tmp_path / "run"), "--no-progress"])
    assert code == 130 and len(no_dive) == 1, err  # the stub stopped it where the dive starts
    assert load_scene(written_site / "scene.toml").world.targets == ()
