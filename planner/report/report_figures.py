"""The report's figures drawn from a run folder, by name (:func:`draw_figures`): what
:func:`planner.report.markdown.generate_report` draws, here or in the figure process
(:mod:`planner.report.figure_worker`), which draws some of them meanwhile."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from planner.report.data import RUN_FILES, RunData, RunFolderError, load_run
from planner.report.height_score import HeightScore, score_heights

#: Folder of the figures in the run folder.
FIGURE_DIR = "report"
#: The report's figures, in the order of its sections.
REPORT_FIGURES = ("track", "altitude", "tilt", "heights")
#: Default largest distance between an estimated and a true target to count as one, m.
DEFAULT_MATCH_RADIUS_M = 1.0


def draw_report_figures(run_dir: Path | str, names: Sequence[str], *, match_radius_m: float = DEFAULT_MATCH_RADIUS_M,
                        dpi: int = 110) -> dict[str, Path | None]:
    """Draw the report figures ``names`` (of :data:`REPORT_FIGURES`) of a run folder into
    ``<run>/report/``, as :func:`planner.report.markdown.generate_report` does; each name's file, or None (nothing
    to draw)."""
    run, score = load_scored(Path(run_dir), match_radius_m)
    return draw_figures(run, score, names, dpi=dpi)


def load_scored(run_dir: Path, match_radius_m: float) -> tuple[RunData, HeightScore | None]:
    """The run folder read (:func:`planner.report.data.load_run`) and its heights scored
    against the truth (None without truth or targets); a folder with no run file refused."""
    run = load_run(run_dir)
    if run.empty:
        raise RunFolderError(run.root, f"not a run folder: it holds none of {', '.join(RUN_FILES)}; nothing to "
                             "report")
    score = None
    if run.truth is not None and run.targets is not None:
        score = score_heights(run.targets, run.truth, radius_m=match_radius_m)
    return run, score


def draw_figures(run: RunData, score: HeightScore | None, names: Sequence[str], *, dpi: int) -> dict[str, Path | None]:
    """Draw ``names`` (of :data:`REPORT_FIGURES`) into ``<run>/report/``; each one's file or None."""
    from planner.report.figures import figure_altitude, figure_heights, figure_tilt, figure_track  # matplotlib

    out = run.root / FIGURE_DIR
    drawn: dict[str, Path | None] = {}
    for name in names:
        if name == "track":
            drawn[name] = figure_track(run, out / "track.png", dpi=dpi)
        elif name == "altitude":
            drawn[name] = figure_altitude(run, out / "altitude.png", dpi=dpi)
        elif name == "tilt":
            drawn[name] = figure_tilt(run, out / "tilt.png", dpi=dpi)
        elif name == "heights":
            drawn[name] = figure_heights(run, score, out / "heights.png", dpi=dpi) if score is not None else None
        else:
            raise ValueError(f"unknown report figure {name!r} (one of {', '.join(REPORT_FIGURES)})")
    return drawn
