"""Output folders: built aside, moved into place whole; an existing folder never lost or mixed."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.errors import OutputFolderError
from planner.mission.output_folder import check_output_folder, staged_folder
from planner.mission.run_folder import mark_partial


def _old_run(root: Path) -> dict[str, bytes]:
    root.mkdir(parents=True)
    (root / "summary.json").write_text('{"status": "completed", "reason": "survey flown"}\n')
    (root / "events.jsonl").write_text('{"t_s": 0.0, "kind": "state", "message": "x"}\n')
    (root / "plan").mkdir()
    (root / "plan" / "plan.json").write_text("{}")
    return _contents(root)


def _contents(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_new_folder_appears_only_when_complete(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with staged_folder(out, kind="run", overwrite=False) as stage:
        (stage / "summary.json").write_text("{}")
        assert not out.exists() and stage.parent == out.parent
    assert _contents(out) == {"summary.json": b"{}"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_existing_run_needs_overwrite_and_is_replaced_whole(tmp_path: Path) -> None:
    out = tmp_path / "run"
    before = _old_run(out)
    with pytest.raises(OutputFolderError, match="--overwrite"):
        check_output_folder(out, kind="run", overwrite=False)
    assert _contents(out) == before
    with staged_folder(out, kind="run", overwrite=True) as stage:
        (stage / "summary.json").write_text('{"status": "new"}')
        assert _contents(out) == before  # untouched while the new run is built
    assert _contents(out) == {"summary.json": b'{"status": "new"}'}  # nothing of the old run mixed in
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


@pytest.mark.parametrize("failure", [KeyboardInterrupt, RuntimeError, OSError])
def test_a_stopped_run_leaves_the_old_folder_byte_identical(tmp_path: Path, failure: type[BaseException]) -> None:
    out = tmp_path / "run"
    before = _old_run(out)
    with pytest.raises(failure) as info:
        with staged_folder(out, kind="run", overwrite=True, on_failure=mark_partial) as stage:
            (stage / "events.jsonl").write_text('{"t_s": 9.0, "kind": "state", "message": "new"}\n')
            raise failure("disk on fire") if failure is not KeyboardInterrupt else KeyboardInterrupt
    assert _contents(out) == before
    partial = tmp_path / "run.partial"
    summary = json.loads((partial / "summary.json").read_text())
    assert summary["status"] == "partial"
    assert summary["reason"] == ("interrupted (Ctrl-C)" if failure is KeyboardInterrupt
                                 else f"{failure.__name__}: disk on fire")
    assert (partial / "events.jsonl").read_text().endswith('"new"}\n')
    assert any(str(partial) in note for note in info.value.__notes__)


def test_a_stopped_first_run_is_kept_in_place_marked_partial(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt), staged_folder(out, kind="run", overwrite=False,
                                                         on_failure=mark_partial) as stage:
        (stage / "summary.json").write_text('{"status": "completed"}')
        raise KeyboardInterrupt
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "partial" and summary["summary_before_stop"] == {"status": "completed"}


def test_a_failed_plan_is_not_kept(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    with pytest.raises(ValueError), staged_folder(out, kind="plan", overwrite=False, keep_partial=False) as stage:
        (stage / "plan.json").write_text("{")
        raise ValueError("half a plan")
    assert not any(tmp_path.iterdir())


def test_foreign_folders_and_files_are_never_replaced(tmp_path: Path) -> None:
    mine = tmp_path / "notes"
    mine.mkdir()
    (mine / "todo.txt").write_text("x")
    with pytest.raises(OutputFolderError, match="not a shadowsurvey run folder"):
        check_output_folder(mine, kind="run", overwrite=True)
    a_file = tmp_path / "file"
    a_file.write_text("x")
    with pytest.raises(OutputFolderError, match="not a folder"):
        check_output_folder(a_file, kind="run", overwrite=True)
    empty = tmp_path / "empty"
    empty.mkdir()
    check_output_folder(empty, kind="run", overwrite=False)  # nothing there to lose
