"""`shadowsurvey mosaic`: the 2.5D map from recorded frames, with pose in the frames or a nav CSV."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import rasterio

from perception.sonar_io.npz import load_frames, save_frame
from planner.cli import main


@pytest.fixture(scope="module")
def tank_frames(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    out = tmp_path_factory.mktemp("render")
    assert main(["render", "paper-tank", "--altitude", "0.5", "0.6", "--out", str(out), "--no-preview"]) == 0
    return sorted(p for p in out.glob("*.npz") if not p.name.endswith(".truth.npz"))


def test_map_from_frames_with_pose(tank_frames, tmp_path):
    assert main(["mosaic", *map(str, tank_frames), "--out", str(tmp_path), "--origin", "43.3,5.37"]) == 0
    with rasterio.open(tmp_path / "mosaic.tif") as ds:
        assert ds.crs is not None and ds.count == 2
        heights = ds.read(2)
    assert np.nanmax(heights) == pytest.approx(0.047, abs=0.005)  # the tallest tank target, 4.7 cm
    doc = json.loads((tmp_path / "targets.geojson").read_text())
    solved = [f for f in doc["features"] if f["properties"]["height_m"] is not None]
    assert len(solved) == 5
    assert sorted(round(f["properties"]["height_m"] * 100) for f in solved) == [3, 3, 3, 4, 5]
    assert (tmp_path / "mosaic_heights.png").stat().st_size > 10_000


def test_pose_from_a_nav_csv(tank_frames, tmp_path):
    bare = []
    rows = ["t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg"]
    for k, path in enumerate(tank_frames):
        frame = load_frames(path)[0]
        rows.append(f"{float(k)},{frame.north_m},{frame.east_m},{math.degrees(frame.heading_rad)},"
                    f"{frame.altitude_m},{math.degrees(frame.tilt_rad)}")
        stripped = frame.with_fields(timestamp_s=float(k), north_m=math.nan, east_m=math.nan, heading_rad=math.nan,
                                     altitude_m=math.nan, tilt_rad=math.nan)
        bare.append(save_frame(tmp_path / f"bare{k}.npz", stripped))
    nav = tmp_path / "nav.csv"
    nav.write_text("\n".join(rows) + "\n")
    origin = ["--origin", "43.3,5.37"]
    assert main(["mosaic", *map(str, bare), "--out", str(tmp_path / "a"), "--no-registration", *origin]) == 2
    assert main(["mosaic", *map(str, bare), "--nav", str(nav), "--out", str(tmp_path / "b"), *origin]) == 0
    doc = json.loads((tmp_path / "b" / "targets.geojson").read_text())
    assert sum(f["properties"]["height_m"] is not None for f in doc["features"]) == 5


def test_bad_nav_is_named(tank_frames, tmp_path, capsys):
    nav = tmp_path / "nav.csv"
    nav.write_text("t_s,north_m\n0,1\n1,2\n")
    assert main(["mosaic", str(tank_frames[0]), "--nav", str(nav), "--out", str(tmp_path / "x"),
                 "--origin", "43.3,5.37"]) == 2
    assert "lacks columns" in capsys.readouterr().err
