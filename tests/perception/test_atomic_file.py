"""The one atomic writer: whole files or the previous ones, with the user's umask."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from perception.atomic_file import atomic_write, atomic_write_text


@pytest.fixture
def umask() -> Iterator[None]:
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_mode_follows_the_umask(tmp_path: Path, umask: None, mask: int, mode: int) -> None:
    os.umask(mask)
    path = atomic_write_text(tmp_path / "a.json", "{}")
    assert stat.S_IMODE(path.stat().st_mode) == mode
    plain = tmp_path / "plain"
    plain.write_text("x")
    assert stat.S_IMODE(plain.stat().st_mode) == mode  # the same as any file the user writes


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    path = atomic_write_text(tmp_path / "summary.json", "old")

    def broken(handle: object) -> None:
        handle.write(b"half")  # type: ignore[attr-defined]
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(path, broken)
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]


def test_products_are_written_with_the_umask(tmp_path: Path, umask: None) -> None:
    from perception.geodesy import LocalOrigin
    from perception.mapping.heights_layer import MappedTarget
    from perception.mapping.products import write_targets_geojson
    from perception.sonar_io.npz import save_frame
    from planner.mission.run_folder import RunFolder

    os.umask(0o022)
    target = MappedTarget(target_id=1, north_m=0.0, east_m=0.0, height_m=0.1, height_std_m=0.01, frames_used=2)
    written = [write_targets_geojson(tmp_path / "targets.geojson", [target], LocalOrigin(43.0, 5.0))]
    run = RunFolder(tmp_path / "run")
    written += [run.write_json("summary.json", {"a": 1}), run.write_csv("targets.csv", ["id"], [[1]])]
    run.close()
    from perception.sonar_io.npz import load_frames

    frame = load_frames(Path(__file__).resolve().parents[2] / "planner" / "data" / "examples" /
                        "paper_tank_0.50m.npz")[0]
    written.append(save_frame(tmp_path / "frame.npz", frame))
    assert {stat.S_IMODE(p.stat().st_mode) for p in written} == {0o644}
