"""The dive report: ``report.md`` and its figures, built from a run folder's files.

:func:`generate_report` reads a run folder (:mod:`planner.report.data` lists the files
and columns), draws the figures into ``<run>/report/`` (:mod:`planner.report.figures`)
and writes ``<run>/report.md``. It can be run during a dive or after it, on a real
vehicle (no simulator truth) or in simulation; missing files are said in the report,
malformed ones raise :class:`~planner.report.data.RunFolderError` naming the file.

:func:`match_targets` and :func:`score_heights` (from :mod:`planner.report.height_score`) score
estimated heights against simulator truth; the whole-loop tests use them too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from perception.atomic_file import atomic_write_text
from planner.report.data import Event, RunData, RunFolderError, load_run
from planner.report.figure_worker import CHILD_REPORT_FIGURES, FigureWorker
from planner.report.height_score import HeightScore, Matching, match_targets, score_heights
from planner.report.key_figures import key_figures, nan_stat
from planner.report.md import cell, fmt, short, table
from planner.report.report_figures import (
    DEFAULT_MATCH_RADIUS_M,
    FIGURE_DIR,
    REPORT_FIGURES,
    draw_figures,
    load_scored,
)
from planner.report.shadows import margin_lines, shadows_section
from planner.report.timeline import ALERT_KINDS, TERMINAL_STATES, StateSpan, state_at, state_spans

__all__ = ["FIGURE_DIR", "REPORT_NAME", "Matching", "HeightScore", "RunFolderError", "generate_report",
           "load_run", "match_targets", "render_markdown", "score_heights"]

REPORT_NAME = "report.md"
#: Event kinds listed one by one in the events table.
LISTED_KINDS = ("warning", *ALERT_KINDS)

def _status(run: RunData) -> tuple[str, str]:
    """(status, reason): from summary.json, else from the last state event."""
    summary = run.summary or {}
    if summary.get("status"):
        status, reason = str(summary["status"]).upper(), str(summary.get("reason") or "")
        aborts = [e for e in run.events or () if e.kind == "state" and e.state == "ABORTED"]
        if status == "ABORTED" and aborts:
            spans = state_spans(run.events, run.end_s())
            reason += f" (in {_state_before(spans, aborts[0].t_s, aborts[0]) or 'no state'} at {aborts[0].t_s:.1f} s)"
        return status, reason
    last = [e for e in run.events or () if e.kind == "state"]
    if last and last[-1].state in TERMINAL_STATES:
        return last[-1].state, last[-1].message + " (no summary.json)"
    where = f"; last state {last[-1].state} at {last[-1].t_s:.1f} s" if last else ""
    return "UNKNOWN", f"no summary.json: the run is still going or stopped without finishing{where}"


def _header(run: RunData, score: HeightScore | None) -> list[str]:
    status, reason = _status(run)
    icon = {"COMPLETED": "✅", "ABORTED": "⛔"}.get(status, "⚠️")
    detail = (run.summary or {}).get("reason_detail")
    if detail:
        reason += f": {detail}"
    lines = [f"# Dive report: {run.root.name}", "", f"**Status: {icon} {status}**" + (f" — {cell(reason)}" if reason
                                                                                    else ""), ""]
    if status == "PARTIAL":
        lines += [f"_{cell((run.summary or {}).get('partial', 'the run stopped before it was complete'))}._", ""]
    lines += key_figures(run, score)
    kind = "simulation (truth available)" if run.simulated else "no simulator truth"
    lines.append(f"Run folder `{run.root}`; {kind}.")
    return lines + [""]


def _altitude_warnings(run: RunData) -> list[str]:
    s = run.summary or {}
    if "altitude_excursions" not in s:
        return []
    excursions = [e for e in (*(s.get("altitude_excursions") or ()), *(s.get("altitude_excursions_true") or ()))
                  if isinstance(e, dict)]
    lines = ["### Altitude warnings", ""]
    if not excursions:
        return lines + ["None: the altitude never went below a pass altitude by more than 3 sigma of the filter, nor "
                        "below the lowest allowed altitude.", ""]
    rows = [[cell("simulator truth" if e.get("source") == "truth" else "filter estimate"),
             cell("below the pass altitude" if e.get("check") == "pass" else "below the lowest allowed altitude"),
             cell(e.get("state", "")), f"{float(e.get('limit_m') or 0):.3f} m",
             f"{float(e.get('lowest_m') or 0):.3f} m",
             fmt(e.get("lowest_s"), "s"), fmt(e.get("start_s"), "s"), fmt(e.get("end_s"), "s")]
            for e in sorted(excursions, key=lambda e: float(e.get("start_s") or 0.0))]
    lines += table(["altitude", "check", "state", "limit", "lowest", "at", "from", "to"], rows)
    return lines + ["Below the pass altitude: in DESCEND, a pass or ALTITUDE_CHANGE, lower than the pass altitude "
                    "(the lower of two while changing) by more than 3 sigma of the altitude filter's estimate at "
                    "that moment; the limit shown is that bound. Below the lowest allowed altitude: lower than "
                    "min_clearance_m above the tallest expected target. Each is a warning in events.jsonl.", ""]


def _drift_section(run: RunData) -> list[str]:
    drift = (run.summary or {}).get("navigation_drift")
    if not isinstance(drift, dict):
        return []
    lines = ["## Navigation drift", ""]
    rows = [["correction (north, east)", f"{fmt(drift.get('correction_north_m'), 'm')}, "
             f"{fmt(drift.get('correction_east_m'), 'm')}"],
            ["size of the correction", fmt(drift.get("correction_m"), "m")],
            ["its 1-sigma per axis", fmt(drift.get("correction_std_m"), "m")],
            ["registrations accepted / refused", f"{drift.get('registrations_accepted', '–')} / "
             f"{drift.get('registrations_refused', '–')}"],
            ["track it rests on", fmt(drift.get("track_m"), "m")],
            ["largest drift the prior allows there", fmt(drift.get("plausible_drift_max_m"), "m")]]
    lines += table(["navigation drift", "value"], rows)
    if drift.get("meaning"):
        lines += [cell(drift["meaning"]), ""]
    return lines


def _files_section(run: RunData) -> list[str]:
    def seriescell(s: Any) -> str:
        return "missing" if s is None else f"{s.n_rows} rows"

    rows = [
        ["events.jsonl", "missing" if run.events is None else f"{len(run.events)} events"],
        ["nav.csv", seriescell(run.nav)], ["filter.csv", seriescell(run.filter)],
        ["tilt.csv", seriescell(run.tilt)],
        ["plan/plan.json", "missing" if run.plan is None else f"{len(run.plan)} passes"],
        ["targets.csv", "missing" if run.targets is None else f"{len(run.targets)} targets"],
        ["summary.json", "missing" if run.summary is None else "present"],
        ["truth.json", "missing (expected on a real vehicle)" if run.truth is None else f"{len(run.truth)} targets"],
        ["truth_track.csv", seriescell(run.truth_track)], ["shadows.csv", seriescell(run.shadows)],
    ]
    lines = ["## Data files", "", *table(["file", "content"], rows)]
    if run.notes:
        lines += [f"- {cell(n)}" for n in run.notes] + [""]
    return lines


def _figure_link(path: Path | None, run: RunData, alt: str, missing: str) -> list[str]:
    if path is None:
        return [f"_{missing}_", ""]
    return [f"![{alt}]({path.relative_to(run.root).as_posix()})", ""]


def _track_section(run: RunData, fig: Path | None) -> list[str]:
    lines = ["## Track against plan", ""]
    lines += _figure_link(fig, run, "track against plan", "No track or plan data (nav.csv and plan/plan.json missing).")
    if run.plan:
        rows = [[cell(p.name), fmt(p.altitude_m, "m"), f"{math.degrees(p.tilt_rad):.1f} deg",
                 f"{len(p.path_ne_m)}", f"{len(p.lanes_ne_m)}"] for p in run.plan]
        lines += table(["planned pass", "altitude", "tilt", "waypoints", "lane runs"], rows)
    else:
        lines += ["_No plan/plan.json: the track is drawn without the planned lanes._", ""]
    return lines


def _altitude_section(run: RunData, fig: Path | None) -> list[str]:
    lines = ["## Altitude and the altitude filter", ""]
    lines += _figure_link(fig, run, "altitude and filter",
                          "No altitude data (nav.csv and filter.csv missing or empty).")
    lines += _altitude_warnings(run)
    flt = run.filter
    if flt is not None and flt.n_rows and run.events:
        spans = [s for s in state_spans(run.events, run.end_s()) if s.state not in TERMINAL_STATES]
        states = state_at(state_spans(run.events, run.end_s()), flt.col("t_s"))
        tilt = run.tilt
        tilt_states = state_at(state_spans(run.events, run.end_s()), tilt.col("t_s")) if tilt is not None else []
        rows = []
        for s in dict.fromkeys(sp.state for sp in spans):
            sel = np.array([x == s for x in states], dtype=bool)
            est = flt.col("altitude_est_m")[sel]
            std = flt.col("altitude_std_m")[sel]
            target = (tilt.col("altitude_target_m")[np.array([x == s for x in tilt_states], dtype=bool)]
                      if tilt is not None else np.array([]))
            rows.append([s, fmt(nan_stat(np.mean, est), "m"), fmt(nan_stat(np.min, est), "m"),
                         fmt(nan_stat(np.median, target), "m"), fmt(nan_stat(np.mean, std), "m")])
        lines += table(["state", "mean altitude (filter)", "lowest altitude (filter)", "altitude target (median)",
                         "mean filter σ"], rows)
    if flt is not None and flt.has("rejected_total"):
        lines += [f"Altimeter readings rejected by the filter: {int(np.nanmax(flt.col('rejected_total')))}.", ""]
    return lines


def _tilt_section(run: RunData, fig: Path | None) -> list[str]:
    lines = ["## Tilt and shadow margins", ""]
    lines += _figure_link(fig, run, "tilt and shadow margins", "No tilt data (tilt.csv missing or empty).")
    tilt = run.tilt
    lines += margin_lines(run)
    if tilt is not None and tilt.has("tilt_cmd_deg") and tilt.has("tilt_meas_deg"):
        err = tilt.col("tilt_meas_deg") - tilt.col("tilt_cmd_deg")
        lines += [f"Tilt mount: measured minus commanded, median {fmt(nan_stat(np.median, err), 'deg')}, "
                  f"largest {fmt(nan_stat(lambda a: np.max(np.abs(a)), err), 'deg')}.", ""]
    return lines


def _heights_section(run: RunData, score: HeightScore | None, fig: Path | None) -> list[str]:
    lines = ["## Target heights", ""]
    if run.targets is None:
        return lines + ["_No targets.csv: no heights were estimated (yet)._", ""]
    rows = [[cell(t.target_id), f"{t.north_m:.2f}", f"{t.east_m:.2f}",
             f"{100 * t.height_m:.2f} ± {100 * t.height_std_m:.2f}" if math.isfinite(t.height_m) else "–",
             f"{t.frames_used}", cell(t.note)] for t in run.targets]
    lines += table(["target", "north (m)", "east (m)", "height ± σ (cm)", "frames", "note"], rows)
    lines += ["### Heights against truth", ""]
    if score is None or run.truth is None:
        return lines + ["_No truth.json: not a simulation run, heights cannot be scored._", ""]
    lines += _figure_link(fig, run, "heights against truth", "No estimated height matched a true target.")
    rows = []
    by_truth = {e.truth: e for e in score.errors}
    no_height = {m.truth: m for m in score.no_height}
    for i, t in enumerate(run.truth):
        shape = cell(t.note)
        if i in by_truth:
            e = by_truth[i]
            est = run.targets[e.estimated]
            rows.append([cell(t.target_id), shape, f"{100 * t.height_m:.2f}", cell(est.target_id),
                         f"{100 * e.height_m:.2f} ± {100 * e.height_std_m:.2f}", f"{100 * e.error_m:+.2f}",
                         f"{e.z:+.1f}" if math.isfinite(e.z) else "–", f"{e.distance_m:.2f}"])
        elif i in no_height:
            est = run.targets[no_height[i].estimated]
            rows.append([cell(t.target_id), shape, f"{100 * t.height_m:.2f}", cell(est.target_id),
                         f"no height ({cell(est.note) or 'no reason given'})", "–", "–",
                         f"{no_height[i].distance_m:.2f}"])
        else:
            rows.append([cell(t.target_id), shape, f"{100 * t.height_m:.2f}", "not found", "–", "–", "–", "–"])
    lines += table(["true target", "shape", "true height (cm)", "estimate", "estimated ± σ (cm)", "error (cm)",
                     "error / σ", "position error (m)"], rows)
    lines.append(f"Matched one to one by seabed position within {score.radius_m:g} m. Mean \\|error\\| "
                 f"{fmt(score.mean_abs_error_m, 'cm')}, max {fmt(score.max_abs_error_m, 'cm')}, "
                 f"RMS {fmt(score.rms_error_m, 'cm')}, bias {fmt(score.mean_error_m, 'cm')}.")
    if score.unmatched_estimated:
        ids = ", ".join(cell(run.targets[i].target_id) for i in score.unmatched_estimated)
        lines.append(f"Estimated targets matching no true target (false detections?): {ids}.")
    if score.unmatched_truth:
        ids = ", ".join(cell(run.truth[i].target_id) for i in score.unmatched_truth)
        lines.append(f"True targets with no estimate within {score.radius_m:g} m: {ids}.")
    return lines + [""]


def _state_before(spans: Sequence[StateSpan], t_s: float, event: Event | None = None) -> str:
    """The state at ``t_s``; for a state event, the state it left."""
    before = [s for s in spans if s.start_s < t_s or (s.start_s == t_s and event is not None and event.kind != "state")]
    return before[-1].state if before else ""


def _events_section(run: RunData) -> list[str]:
    lines = ["## States and events", ""]
    if run.events is None:
        return lines + ["_No events.jsonl._", ""]
    spans = state_spans(run.events, run.end_s())
    if spans:
        rows = [[s.state, f"{s.start_s:.1f}", f"{s.end_s - s.start_s:.1f}" if s.state not in TERMINAL_STATES else "–"]
                for s in spans]
        lines += table(["state", "entered at (s)", "lasted (s)"], rows)
    counts: dict[str, int] = {}
    for e in run.events:
        counts[e.kind] = counts.get(e.kind, 0) + 1
    lines += ["Events by kind: " + ", ".join(f"{k} {n}" for k, n in sorted(counts.items())) + ".", ""]
    listed = sorted((e for e in run.events if e.kind in LISTED_KINDS or (e.kind == "state" and e.state == "ABORTED")),
                    key=lambda e: e.t_s)
    if not listed:
        return lines + ["No warnings, failsafes or aborts.", ""]
    rows = []
    for e in listed:
        kind = "**ABORT**" if e.kind == "state" else (f"**{e.kind}**" if e.kind in ALERT_KINDS else e.kind)
        extra = ", ".join(f"{k}={v}" for k, v in e.fields.items() if k != "state" and not isinstance(v, dict | list))
        rows.append([f"{e.t_s:.1f}", kind, _state_before(spans, e.t_s, e), cell(short(e.message)),
                     cell(short(extra))])
    return lines + table(["t (s)", "kind", "during state", "message", "details"], rows)


def _maps_section(run: RunData) -> list[str]:
    lines = ["## Maps", ""]
    for name, what in (("mosaic.png", "Seabed mosaic"), ("mosaic_heights.png", "2.5D map: mosaic with target heights")):
        if (run.root / name).is_file():
            lines += [f"### {what}", "", f"![{what}]({name})", ""]
        else:
            lines += [f"_{what}: {name} not in the run folder._", ""]
    return lines


def render_markdown(run: RunData, figures: Mapping[str, Path | None], score: HeightScore | None) -> str:
    """The report text for ``run`` with the given figure files (keys track/altitude/tilt/heights)."""
    lines = _header(run, score)
    lines += _track_section(run, figures.get("track"))
    lines += _altitude_section(run, figures.get("altitude"))
    lines += _tilt_section(run, figures.get("tilt"))
    lines += shadows_section(run)
    lines += _heights_section(run, score, figures.get("heights"))
    lines += _drift_section(run)
    lines += _events_section(run)
    lines += _maps_section(run)
    lines += _files_section(run)
    return "\n".join(lines).rstrip() + "\n"


def generate_report(run_dir: Path | str, *, match_radius_m: float = DEFAULT_MATCH_RADIUS_M, dpi: int = 110,
                    helper: FigureWorker | None = None) -> Path:
    """Read the run folder, draw the figures into ``<run>/report/``, write ``<run>/report.md``.

    ``helper``: a figure process that draws some of the figures meanwhile
    (:data:`~planner.report.figure_worker.CHILD_REPORT_FIGURES`); the files are the same.

    Returns
    -------
    Path
        The path of ``report.md``.

    Raises
    ------
    NotADirectoryError
        When ``run_dir`` is not a folder.
    RunFolderError
        When a run-folder file is malformed (the message names the file and line), or the
        folder holds no run file at all (an empty or unrelated folder: nothing is written).
    ValueError
        For a match radius that is not positive.
    """
    run, score = load_scored(Path(run_dir), match_radius_m)
    out = run.root / FIGURE_DIR
    out.mkdir(exist_ok=True)
    names = [n for n in REPORT_FIGURES if n != "heights" or score is not None]
    theirs = [n for n in names if helper is not None and n in CHILD_REPORT_FIGURES]
    if theirs:
        assert helper is not None
        helper.submit("report", run.root, theirs, match_radius_m=match_radius_m, dpi=dpi)
    drawn = draw_figures(run, score, [n for n in names if n not in theirs], dpi=dpi)
    if theirs:
        drawn.update(helper.result())
    figures = {name: drawn.get(name) for name in REPORT_FIGURES}
    for name, path in figures.items():
        stale = out / f"{name}.png"
        if path is None and stale.is_file():
            stale.unlink()
    return atomic_write_text(run.root / REPORT_NAME, render_markdown(run, figures, score))
