"""Scene files: built-ins, TOML/JSON equivalence, includes and clear errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from sim_harness.sonar.scene import builtin_scenes, load_scene
from sim_harness.world.errors import SceneError

MINIMAL = """
[seabed]
depth_m = 5.0

[[targets]]
id = "a"
shape = "box"
north_m = 2.0
east_m = 0.0
length_m = 0.2
width_m = 0.1
height_m = 0.05

[viewpoint]
altitude_m = 1.0
"""


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_paper_tank_holds_table_one(data_dir: Path) -> None:
    tables = json.loads((data_dir / "paper_tables.json").read_text())
    scene = load_scene("paper-tank")
    assert scene.world.seabed_depth_m(0.0, 0.0) == pytest.approx(tables["table_I_tank"]["water_depth_cm"] / 100)
    specs = {t.target_id: t for t in scene.world.targets}
    assert len(specs) == 5
    for row in tables["table_I_targets_cm"]:
        spec = specs[str(row["target"])]
        assert (spec.length_m, spec.width_m, spec.height_m) == pytest.approx(
            (row["L"] / 100, row["W"] / 100, row["H"] / 100)
        )
    assert scene.viewpoint.altitude_m == pytest.approx(0.5)


def test_open_seabed_has_a_dozen_targets_2_to_40_cm() -> None:
    scene = load_scene("open-seabed")
    heights = [t.height_m for t in scene.world.targets]
    assert len(heights) == 12
    assert min(heights) == pytest.approx(0.02) and max(heights) == pytest.approx(0.40)
    assert {t.shape for t in scene.world.targets} == {"box", "cylinder", "stone", "rock"}
    for t in scene.world.targets:
        assert 0.0 <= t.north_m <= 30.0 and 0.0 <= t.east_m <= 30.0
    assert not math.isnan(scene.world.origin_lat_deg)
    assert set(builtin_scenes()) == {"paper-tank", "open-seabed"}


def test_toml_and_json_give_the_same_world(tmp_path: Path) -> None:
    import tomllib

    doc = tomllib.loads(MINIMAL)
    a = load_scene(_write(tmp_path, "s.toml", MINIMAL))
    b = load_scene(_write(tmp_path, "s.json", json.dumps(doc)))
    assert a.world.targets == b.world.targets
    assert a.world.seabed == b.world.seabed
    assert a.name == "s"


def test_include_composes_scenes(tmp_path: Path) -> None:
    text = """
include = ["open-seabed"]
[[targets]]
id = "extra"
shape = "cylinder"
north_m = 3.0
east_m = 15.0
diameter_m = 0.3
height_m = 0.6
"""
    scene = load_scene(_write(tmp_path, "dive.toml", text))
    ids = [t.target_id for t in scene.world.targets]
    assert len(ids) == 13 and ids[-1] == "extra"
    assert scene.world.seabed == load_scene("open-seabed").world.seabed
    base = load_scene("open-seabed").viewpoint
    assert (scene.viewpoint.north_m, scene.viewpoint.east_m, scene.viewpoint.altitude_m) == (
        base.north_m, base.east_m, base.altitude_m)
    assert scene.sonar == load_scene("open-seabed").sonar


@pytest.mark.parametrize(
    ("change", "key", "message"),
    [
        (("depth_m = 5.0", "depth_m = -5.0"), "seabed.depth_m", "> 0"),
        (("depth_m = 5.0", "dept_m = 5.0"), "seabed.dept_m", "unknown key"),
        (('shape = "box"', 'shape = "pyramid"'), "targets[0].shape", "unknown shape"),
        (("height_m = 0.05", "height_m = 0.0"), "targets[0].height_m", "> 0"),
        (("height_m = 0.05", 'height_m = "tall"'), "targets[0].height_m", "must be a number"),
        (("width_m = 0.1\n", ""), "targets[0].width_m", "is required"),
        (("altitude_m = 1.0", "altitude_m = 1.0\nzoom = 2"), "viewpoint.zoom", "unknown key"),
    ],
)
def test_bad_scene_files_name_file_and_key(tmp_path: Path, change: tuple[str, str], key: str, message: str) -> None:
    path = _write(tmp_path, "bad.toml", MINIMAL.replace(*change))
    with pytest.raises(SceneError, match=message) as info:
        load_scene(path)
    assert info.value.key == key
    assert str(path) in str(info.value)


def test_other_scene_errors(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="cannot parse"):
        load_scene(_write(tmp_path, "broken.toml", "[seabed\ndepth_m = 1"))
    with pytest.raises(SceneError, match="not a built-in scene"):
        load_scene("no-such-scene")
    with pytest.raises(SceneError, match="not found"):
        load_scene(tmp_path / "missing.toml")
    with pytest.raises(SceneError, match="unknown material 'kryptonite'"):
        text = MINIMAL.replace('shape = "box"', 'shape = "box"\nmaterial = "kryptonite"')
        load_scene(_write(tmp_path, "mat.toml", text))
    dup = MINIMAL + MINIMAL.split("[viewpoint]")[0].split("[[targets]]")[1].join(["[[targets]]", ""])
    with pytest.raises(SceneError, match="duplicate target id 'a'"):
        load_scene(_write(tmp_path, "dup.toml", dup))
    _write(tmp_path, "x.toml", 'include = ["y.toml"]\n' + MINIMAL)
    _write(tmp_path, "y.toml", 'include = ["x.toml"]\n')
    with pytest.raises(SceneError, match="include cycle"):
        load_scene(tmp_path / "x.toml")
    with pytest.raises(SceneError, match="no \\[viewpoint\\]"):
        load_scene(_write(tmp_path, "noview.toml", MINIMAL.split("[viewpoint]")[0]))
    with pytest.raises(SceneError, match="gentle"):
        load_scene(_write(tmp_path, "steep.toml", MINIMAL.replace(
            "depth_m = 5.0", "depth_m = 5.0\nrelief = { amplitude_m = 1.0, wavelength_m = 1.0 }")))


# -- targets placed by latitude and longitude ----------------------------------------------------
ORIGIN = "[origin]\nlat_deg = 43.2951\nlon_deg = 5.3745\n"
#: MINIMAL's target at north 2 m, east 0 m, as WGS84 degrees about ORIGIN (pymap3d, computed once).
GEOGRAPHIC = MINIMAL.replace("north_m = 2.0\neast_m = 0.0", "lat_deg = 43.29511800\nlon_deg = 5.37450000")


def test_a_target_by_lat_lon_lands_where_north_east_puts_it(tmp_path: Path) -> None:
    from perception.geodesy import LocalOrigin

    by_metres = load_scene(_write(tmp_path, "m.toml", ORIGIN + MINIMAL)).world.targets[0]
    by_degrees = load_scene(_write(tmp_path, "d.toml", ORIGIN + GEOGRAPHIC)).world.targets[0]
    north, east = LocalOrigin(43.2951, 5.3745).to_local(43.295118, 5.3745)
    assert (by_degrees.north_m, by_degrees.east_m) == pytest.approx((float(north), float(east)), abs=1e-9)
    assert (by_degrees.north_m, by_degrees.east_m) == pytest.approx((by_metres.north_m, by_metres.east_m), abs=0.01)
    assert by_degrees.height_m == by_metres.height_m and by_degrees.target_id == "a"


def test_a_geographic_target_stays_put_when_an_including_scene_moves_the_origin(tmp_path: Path) -> None:
    _write(tmp_path, "base.toml", ORIGIN + GEOGRAPHIC)
    moved = 'include = ["base.toml"]\n[origin]\nlat_deg = 43.2950\nlon_deg = 5.3745\n'
    spec = load_scene(_write(tmp_path, "moved.toml", moved)).world.targets[0]
    # 0.0001 deg further south, the origin lies about 11.1 m closer to the equator: the target is 11.1 m
    # further north of it, where north_m/east_m targets keep their metres
    assert spec.north_m == pytest.approx(2.0 + 11.12, abs=0.02) and spec.east_m == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize(
    ("text", "key", "message"),
    [
        (ORIGIN + MINIMAL.replace("east_m = 0.0", "east_m = 0.0\nlat_deg = 43.3"), "targets[0].lat_deg",
         "give either lat_deg/lon_deg or north_m/east_m, not both"),
        (ORIGIN + MINIMAL.replace("north_m = 2.0", "lon_deg = 5.3"), "targets[0].lon_deg", "not both"),
        (ORIGIN + GEOGRAPHIC.replace("lon_deg = 5.37450000\n", ""), "targets[0].lon_deg", "is required with lat_deg"),
        (ORIGIN + GEOGRAPHIC.replace("lat_deg = 43.29511800\n", ""), "targets[0].lat_deg", "is required with lon_deg"),
        (ORIGIN + MINIMAL.replace("north_m = 2.0\neast_m = 0.0\n", ""), "targets[0].north_m",
         "is required (a target's place"),
        (ORIGIN + GEOGRAPHIC.replace("lat_deg = 43.29511800", "lat_deg = 95.0"), "targets[0].lat_deg",
         "within (-90, 90)"),
        (ORIGIN + GEOGRAPHIC.replace("lon_deg = 5.37450000", "lon_deg = 200.0"), "targets[0].lon_deg",
         "within -180..180"),
        (ORIGIN + GEOGRAPHIC.replace("lat_deg = 43.29511800", 'lat_deg = "43 N"'), "targets[0].lat_deg",
         "must be a number"),
        (ORIGIN + GEOGRAPHIC.replace("lat_deg = 43.29511800", "lat_deg = 44.5"), "targets[0].lat_deg",
         "lies 134 km from the scene's origin"),
        (GEOGRAPHIC, "targets[0].lat_deg", "needs the scene's [origin]"),
        ("[origin]\nlat_deg = 90.0\nlon_deg = 0.0\n" + GEOGRAPHIC, "origin", "cannot place targets"),
    ],
)
def test_bad_target_places_name_file_and_key(tmp_path: Path, text: str, key: str, message: str) -> None:
    path = _write(tmp_path, "scene.toml", text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.key == key and message in str(info.value), str(info.value)
    assert str(info.value).startswith(f"{path}: {key}: ")


def test_an_included_geographic_target_without_an_origin_names_its_own_file(tmp_path: Path) -> None:
    base = _write(tmp_path, "base.toml", GEOGRAPHIC)
    with pytest.raises(SceneError, match="needs the scene's") as info:
        load_scene(_write(tmp_path, "top.toml", 'include = ["base.toml"]\n'))
    assert info.value.path == str(base) and info.value.key == "targets[0].lat_deg"
