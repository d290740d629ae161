"""A dry run against an existing finished run folder: Ctrl-C, a crash or a refused scenario leave
it byte for byte as it was; the stopped run is kept beside it, marked partial."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.dryrun.dive import dry_dive_into, prepare_dry_dive
from planner.dryrun.scenario import load_scenario

COMPACT = Path(__file__).resolve().parent / "data" / "compact"


class Crash(BaseException):
    """Something that is not an ordinary error (as a bug deep in a thread might raise)."""


def _finished_run(root: Path) -> dict[str, bytes]:
    root.mkdir()
    files = {"summary.json": '{"status": "completed", "reason": "survey flown", "n_targets": 8}\n',
             "events.jsonl": '{"t_s": 0.1, "kind": "state", "message": "", "state": "CONNECT"}\n',
             "nav.csv": "t_s,north_m\n0.0,1.0\n", "targets.csv": "id,north_m,east_m,height_m\n1,0,0,0.1\n",
             "report.md": "# Dive report: old\n"}
    for name, text in files.items():
        (root / name).write_text(text)
    (root / "plan").mkdir()
    (root / "plan" / "plan.json").write_text('{"passes": []}')
    return _contents(root)


def _contents(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize(("stop", "reason"), [(KeyboardInterrupt, "interrupted (Ctrl-C)"), (Crash, "Crash: boom")])
def test_a_stopped_dive_leaves_the_finished_run_untouched(tmp_path: Path, stop: type[BaseException],
                                                          reason: str) -> None:
    out = tmp_path / "run"
    before = _finished_run(out)
    prepared = prepare_dry_dive(load_scenario(COMPACT))

    def progress(sim_s: float, planned_s: float, state: str) -> None:
        if sim_s > 2.0:  # the dive has started writing its own files by now
            raise stop("boom") if stop is Crash else KeyboardInterrupt

    with pytest.raises(stop):
        dry_dive_into(prepared, out, overwrite=True, progress=progress)
    assert _contents(out) == before
    partial = tmp_path / "run.partial"
    summary = json.loads((partial / "summary.json").read_text())
    assert (summary["status"], summary["reason"]) == ("partial", reason)
    events = (partial / "events.jsonl").read_text().splitlines()
    assert json.loads(events[0])["state"] == "CONNECT" and len(events) > 1  # the new dive's log, whole lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "run.partial"]


def test_without_overwrite_nothing_starts(tmp_path: Path) -> None:
    out = tmp_path / "run"
    before = _finished_run(out)
    prepared = prepare_dry_dive(load_scenario(COMPACT))
    with pytest.raises(FileExistsError, match="--overwrite"):
        dry_dive_into(prepared, out, overwrite=False)
    assert _contents(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["run"]
