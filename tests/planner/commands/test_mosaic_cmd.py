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
from planner.commands.nav_csv import NavTable


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


def _targets_ne(folder: Path) -> list[tuple[float, float, float | None]]:
    """(north, east, height) of each target of a map folder, sorted."""
    doc = json.loads((folder / "targets.geojson").read_text())
    return sorted((f["properties"]["north_m"], f["properties"]["east_m"], f["properties"]["height_m"])
                  for f in doc["features"])


def test_pose_from_a_nav_csv(tank_frames, tmp_path):
    # The frames moved 3 m north and 2 m east (so a sign or an offset of either shows),
    # once with their pose in the file and once bare, with the pose in the CSV.
    bare, posed = [], []
    rows = ["t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg"]
    for k, path in enumerate(tank_frames):
        frame = load_frames(path)[0].with_fields(timestamp_s=float(k))
        frame = frame.with_fields(north_m=frame.north_m + 3.0, east_m=frame.east_m + 2.0)
        rows.append(f"{float(k)},{frame.north_m},{frame.east_m},{math.degrees(frame.heading_rad)},"
                    f"{frame.altitude_m},{math.degrees(frame.tilt_rad)}")
        posed.append(save_frame(tmp_path / f"posed{k}.npz", frame))
        stripped = frame.with_fields(north_m=math.nan, east_m=math.nan, heading_rad=math.nan,
                                     altitude_m=math.nan, tilt_rad=math.nan)
        bare.append(save_frame(tmp_path / f"bare{k}.npz", stripped))
    nav = tmp_path / "nav.csv"
    nav.write_text("\n".join(rows) + "\n")
    # Each bare frame gets the CSV row at its timestamp: the pose it was stripped of.
    table = NavTable(nav)
    for k, (b, p) in enumerate(zip(bare, posed, strict=True)):
        applied, want = table.apply(load_frames(b)[0], f"bare{k}"), load_frames(p)[0]
        assert (applied.north_m, applied.east_m) == pytest.approx((want.north_m, want.east_m), abs=1e-9)
        assert applied.heading_rad == pytest.approx(want.heading_rad, abs=1e-9)
        assert applied.altitude_m == pytest.approx(want.altitude_m, abs=1e-9)
        assert applied.tilt_rad == pytest.approx(want.tilt_rad, abs=1e-9)
    origin = ["--origin", "43.3,5.37"]
    assert main(["mosaic", *map(str, bare), "--out", str(tmp_path / "a"), "--no-registration", *origin]) == 2
    assert main(["mosaic", *map(str, bare), "--nav", str(nav), "--out", str(tmp_path / "b"), *origin]) == 0
    assert main(["mosaic", *map(str, posed), "--out", str(tmp_path / "c"), *origin]) == 0
    from_csv, from_frames = _targets_ne(tmp_path / "b"), _targets_ne(tmp_path / "c")
    assert sum(h is not None for _, _, h in from_csv) == 5
    assert len(from_csv) == len(from_frames)
    for (n, e, h), (n0, e0, h0) in zip(from_csv, from_frames, strict=True):
        assert (n, e) == pytest.approx((n0, e0), abs=1e-3)  # targets placed alike, within 1 mm
        assert h == h0 or h == pytest.approx(h0, abs=1e-3)
    # And where the tank's targets are, 3 m north and 2 m east of the tank's own frame.
    tank = _targets_ne_from(tank_frames, tmp_path / "d")
    for (n, e, _), (n0, e0, _) in zip(from_frames, tank, strict=True):
        assert (n - n0, e - e0) == pytest.approx((3.0, 2.0), abs=1e-3)


def _targets_ne_from(frames: list[Path], out: Path) -> list[tuple[float, float, float | None]]:
    """Targets of a map made from ``frames`` (their own pose, timestamps 0, 1, ...)."""
    out.mkdir()
    again = [save_frame(out / f"f{k}.npz", load_frames(p)[0].with_fields(timestamp_s=float(k)))
             for k, p in enumerate(frames)]
    assert main(["mosaic", *map(str, again), "--out", str(out / "map"), "--origin", "43.3,5.37"]) == 0
    return _targets_ne(out / "map")


def test_bad_nav_is_named(tank_frames, tmp_path, capsys):
    nav = tmp_path / "nav.csv"
    nav.write_text("t_s,north_m\n0,1\n1,2\n")
    assert main(["mosaic", str(tank_frames[0]), "--nav", str(nav), "--out", str(tmp_path / "x"),
                 "--origin", "43.3,5.37"]) == 2
    assert "lacks columns" in capsys.readouterr().err


def test_frames_of_other_windows_and_dtypes_blend(tank_frames, tmp_path):
    # The second altitude's frames as float32 linear power (40 dB more gain) over a shorter
    # window (the first 100 samples cut): placed by their own range axes, blended at the
    # uint8 frames' seabed level, their targets measured all the same.
    mixed = []
    for k, path in enumerate(tank_frames):
        (frame,) = load_frames(path)
        if k >= len(tank_frames) // 2:
            power = 1e4 * 10.0 ** (frame.image[100:].astype(np.float64) * (80 / 255) / 10)
            frame = frame.with_fields(image=power.astype(np.float32), range_m=frame.range_m[100:])
        mixed.append(save_frame(tmp_path / f"mixed_{k}.npz", frame))
    plain_dir, mixed_dir = tmp_path / "plain", tmp_path / "mixed"
    assert main(["mosaic", *map(str, tank_frames), "--out", str(plain_dir), "--origin", "43.3,5.37"]) == 0
    assert main(["mosaic", *map(str, mixed), "--out", str(mixed_dir), "--origin", "43.3,5.37"]) == 0
    with rasterio.open(plain_dir / "mosaic.tif") as a, rasterio.open(mixed_dir / "mosaic.tif") as b:
        plain, blended = a.read(1), b.read(1)
    seabed = lambda img: float(np.nanmedian(img[np.isfinite(img) & (img > 0)]))  # noqa: E731
    assert seabed(blended) == pytest.approx(seabed(plain), rel=0.1)
    doc = json.loads((mixed_dir / "targets.geojson").read_text())
    solved = sorted(round(f["properties"]["height_m"] * 100) for f in doc["features"]
                    if f["properties"]["height_m"] is not None)
    assert solved == [3, 3, 3, 4, 5]
