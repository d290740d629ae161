"""Figures drawn in a helper process, so that the dry run's pictures take two cores.

The pictures of a dry run (the map, ``mosaic_heights.png``, and the report's figures) come
at its end, when the sonar and map processes are done and one core would draw them all in
turn. :class:`FigureWorker` is a fresh interpreter (:class:`perception.child_process.ChildProcess`)
started when the dive starts: it imports matplotlib and the figure modules while the dive
flies (at a lower priority, in the cores' idle moments), then draws what it is sent while
the dive's own process draws the rest. A picture is the same file whichever process draws
it: the same code and matplotlib, the same data (the report's figures are drawn from the
run folder, read again by the child).

A child that cannot draw (it died, or never started) is not an error of the dive: the job
is drawn here instead (:meth:`FigureWorker.result`), so the pictures are always written.
An error of the drawing itself is raised here, as it would be drawing here.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import os
from collections.abc import Sequence
from typing import IO, Any

from perception.child_process import ChildProcess, answer_each, child_streams

_log = logging.getLogger(__name__)

#: Niceness the child adds to its own: its imports during the dive yield to the dive's
#: three processes; at the end it draws on a core of its own.
CHILD_NICENESS = 5

#: The report's figures the child draws (the others are drawn in the dive's process):
#: about half the drawing time each way on the default dive.
CHILD_REPORT_FIGURES = ("tilt", "heights")

#: What the dive's process imports to draw its share of the report's figures
#: (:func:`planner.report.report_figures.draw_figures`: matplotlib).
REPORT_DRAWING_MODULES = ("planner.report.figures",)


class FigureWorkerError(RuntimeError):
    """The figure process died or could not be started."""


def run_job(kind: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> Any:
    """Draw one job, in whichever process: ``"map"`` (:func:`planner.report.map_plot.render_map_png`),
    ``"report"`` (:func:`planner.report.report_figures.draw_report_figures`) or ``"plan"``
    (:func:`planner.survey.plot.plot_plan`)."""
    if kind == "map":
        from planner.report.map_plot import render_map_png

        return render_map_png(*args, **kwargs)
    if kind == "report":
        from planner.report.report_figures import draw_report_figures

        return draw_report_figures(*args, **kwargs)
    if kind == "plan":
        from planner.survey.plot import plot_plan

        return plot_plan(*args, **kwargs)
    raise ValueError(f"unknown figure job {kind!r}")


def serve(jobs: IO[bytes], results: IO[bytes]) -> None:
    """The child's loop: draw every job in order until ``None``, answering each."""
    answer_each(jobs, results, _answer)


def _answer(job: tuple[str, tuple[Any, ...], dict[str, Any]]) -> tuple[str, Any]:
    try:
        return "ok", run_job(*job)
    except Exception as exc:  # raised in the parent, where it belongs
        return "error", exc


class FigureWorker:
    """Jobs to the figure process (:meth:`submit`), their results in order (:meth:`result`).
    One caller thread; close it (:meth:`close`) when done."""

    def __init__(self) -> None:
        self._jobs: collections.deque[tuple[str, tuple[Any, ...], dict[str, Any]]] = collections.deque()
        self._child: ChildProcess | None = None
        try:
            self._child = ChildProcess("planner.report.figure_worker", what="the figure process",
                                       error=FigureWorkerError)
        except OSError as exc:  # no process to be had: everything is drawn here
            _log.warning("figures drawn in this process: the figure process did not start (%s)", exc)

    def submit(self, kind: str, *args: Any, **kwargs: Any) -> None:
        """Queue one job (:func:`run_job`); its result comes with :meth:`result`, in order."""
        self._jobs.append((kind, args, kwargs))
        if self._child is not None:
            try:
                self._child.send((kind, args, kwargs))
            except FigureWorkerError as exc:
                self._lost(exc)

    def result(self) -> Any:
        """The oldest job's result: the child's, or drawn here if the child cannot."""
        kind, args, kwargs = self._jobs.popleft()
        if self._child is not None:
            try:
                status, value = self._child.receive()
            except FigureWorkerError as exc:
                self._lost(exc)
            else:
                if status == "error":
                    raise value
                return value
        return run_job(kind, args, kwargs)

    def wait_all(self, *, warm_here: Sequence[str] = ()) -> list[Any]:
        """Every queued job's result, in order (:meth:`result`). ``warm_here``: modules to
        import in this process first, while the child draws (those of the figures this
        process draws next: the wait then costs nothing)."""
        if warm_here and self._jobs and self._child is not None:
            warm_up(warm_here)
        return [self.result() for _ in range(len(self._jobs))]

    def _lost(self, exc: Exception) -> None:
        _log.warning("figures drawn in this process: %s", exc)
        if self._child is not None:
            self._child.close()
        self._child = None

    def close(self) -> None:
        """Stop the child, at once: whatever it could still do is unwanted. One sent nothing
        (a refused input) holds nothing; one with jobs left (a failed dive, whose folder is
        set aside) must write nothing after this; one whose every result was taken is done,
        and its own ending (a matplotlib interpreter's teardown, about 0.25 s) is not
        waited for."""
        if self._child is not None:
            self._child.process.kill()
            self._child.process.wait()
            self._child.close()
            self._child = None

    def __enter__(self) -> FigureWorker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def warm_up(modules: Sequence[str] = ("planner.report.figures", "planner.report.map_plot", "planner.survey.plot",
                                      "planner.report.report_figures")) -> None:
    """Import the drawing modules (matplotlib, its fonts) before the first job arrives."""
    import importlib

    for name in modules:
        importlib.import_module(name)


def main() -> None:
    """The child process."""
    with contextlib.suppress(AttributeError, OSError):  # no niceness here: the same pictures, only less polite
        os.nice(CHILD_NICENESS)
    streams = child_streams()
    warm_up()
    serve(*streams)


if __name__ == "__main__":
    # Through the module's own name, so that what it pickles names its classes there.
    from planner.report.figure_worker import main as _main

    _main()
