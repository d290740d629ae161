"""Figures drawn in the figure process (planner.report.figure_worker) are the files drawn here;
a figure process that dies costs nothing but its help; a drawing error is raised here."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from planner.report.data import RunFolderError
from planner.report.figure_worker import CHILD_REPORT_FIGURES, FigureWorker
from planner.report.markdown import FIGURE_DIR, REPORT_NAME, generate_report
from planner.report.report_figures import REPORT_FIGURES
from tests.planner.report.report_run import write_run


@pytest.fixture
def two_runs(tmp_path: Path, rng: np.random.Generator) -> tuple[Path, Path]:
    here, there = tmp_path / "here" / "dive", tmp_path / "there" / "dive"  # the same name: the title
    write_run(here, rng)
    shutil.copytree(here, there)
    return here, there


def test_the_report_drawn_with_the_figure_process_is_the_report_drawn_here(two_runs) -> None:
    here, there = two_runs
    generate_report(here)
    with FigureWorker() as worker:
        generate_report(there, helper=worker)
        assert worker._child is not None, "the figure process drew its share"
    assert set(CHILD_REPORT_FIGURES) < set(REPORT_FIGURES)
    for name in REPORT_FIGURES:
        a, b = (root / FIGURE_DIR / f"{name}.png" for root in (here, there))
        assert a.read_bytes() == b.read_bytes(), name
    assert (here / REPORT_NAME).read_text(encoding="utf-8") == \
        (there / REPORT_NAME).read_text(encoding="utf-8").replace(str(there), str(here))


def test_a_dead_figure_process_leaves_the_drawing_here(two_runs) -> None:
    here, there = two_runs
    generate_report(here)
    with FigureWorker() as worker:
        assert worker._child is not None
        worker._child.process.kill()  # as the OOM killer would
        worker._child.process.wait()
        generate_report(there, helper=worker)
        assert worker._child is None, "the dead process is let go"
    for name in REPORT_FIGURES:
        assert (there / FIGURE_DIR / f"{name}.png").read_bytes() == (here / FIGURE_DIR / f"{name}.png").read_bytes()


def test_a_drawing_error_of_the_figure_process_is_raised_here(tmp_path: Path) -> None:
    with FigureWorker() as worker:
        worker.submit("report", tmp_path, ["track"])
        with pytest.raises(RunFolderError, match="not a run folder"):
            worker.result()
        run = tmp_path / "dive"
        write_run(run, np.random.default_rng(1))
        worker.submit("report", run, ["nonsense"])
        with pytest.raises(ValueError, match="unknown report figure 'nonsense'"):
            worker.result()
        assert worker._child is not None, "an error of the drawing does not end the process"


def test_a_figure_process_is_stopped_at_once(two_runs) -> None:
    idle = FigureWorker()
    child = idle._child
    assert child is not None
    idle.close()  # a refused input: nothing to draw, no wait for its imports
    assert child.process.returncode == -9
    here, _ = two_runs
    busy = FigureWorker()
    child = busy._child
    busy.submit("report", here, ["track"])
    busy.close()  # a failed dive: its jobs are abandoned, nothing writes after close
    assert child.process.returncode is not None
    done = FigureWorker()
    child = done._child
    done.submit("report", here, ["track"])
    assert done.result() == {"track": here / FIGURE_DIR / "track.png"}
    done.close()  # every result taken: its own teardown is not waited for
    assert child.process.returncode == -9
    assert (here / FIGURE_DIR / "track.png").stat().st_size > 0
