"""The dive report's figures, drawn from a :class:`~planner.report.data.RunData`.

Each ``figure_*`` function writes one PNG (atomically) and returns its path, or ``None``
when the run folder lacks the data the figure needs. Plane plots are east to the right,
north up, local metres about the plan's origin; time axes are seconds (minutes for long
dives) since the start of the run. The shared drawing helpers are
:mod:`planner.report.plotting`; the state timeline :mod:`planner.report.timeline`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from planner.report.data import RunData, Series
from planner.report.height_score import HeightScore
from planner.report.md import truth_label
from planner.report.plotting import (
    TimeAxis,
    alert_legend,
    legend_above,
    new_figure,
    place_labels,
    robust_limits,
    save_png,
    time_panels,
)
from planner.report.timeline import (
    PASS_COLOURS,
    alerts,
    state_at,
    state_colour,
    state_spans,
)


def figure_track(run: RunData, path: Path, *, dpi: int = 110) -> Path | None:
    """Plan view: planned lanes, flown track coloured by state, true track, targets."""
    have_nav = run.nav is not None and run.nav.has("north_m") and run.nav.has("east_m")
    if not (have_nav or run.plan or run.truth_track is not None):
        return None
    fig = new_figure(10.0, 8.0)
    ax = fig.add_subplot(1, 1, 1)
    handles: list[Any] = []
    for k, p in enumerate(run.plan or ()):
        colour = PASS_COLOURS[k % len(PASS_COLOURS)]
        ls = "-" if k == 0 else (0, (5, 3))
        ax.plot(p.path_ne_m[:, 1], p.path_ne_m[:, 0], color=colour, lw=1.1, ls=ls, alpha=0.7, zorder=2)
        if len(p.lanes_ne_m):
            segs = p.lanes_ne_m[:, :, ::-1]
            ax.add_collection(LineCollection(list(segs), colors=colour, lw=9.0, alpha=0.16, zorder=1,
                                            capstyle="round"))
        tilt = f", tilt {math.degrees(p.tilt_rad):.1f} deg" if math.isfinite(p.tilt_rad) else ""
        handles.append(Line2D([], [], color=colour, lw=1.0, ls=ls, alpha=0.6,
                              label=f"planned {p.name} (altitude {p.altitude_m:.2f} m{tilt})"))
        if len(p.lanes_ne_m):
            handles.append(Line2D([], [], color=colour, lw=7.0, alpha=0.16, label=f"{p.name} lanes"))
    if run.truth_track is not None and run.truth_track.n_rows:
        tt = run.truth_track
        ax.plot(tt.col("east_m"), tt.col("north_m"), color="black", lw=0.7, ls=(0, (1, 1.5)), zorder=3)
        handles.append(Line2D([], [], color="black", lw=0.7, ls=(0, (1, 1.5)), label="true track (simulator)"))
    if have_nav and run.nav is not None:
        nav = run.nav
        t, north, east = nav.col("t_s"), nav.col("north_m"), nav.col("east_m")
        ok = np.isfinite(north) & np.isfinite(east)
        t, north, east = t[ok], north[ok], east[ok]
        spans = state_spans(run.events, run.end_s())
        states = state_at(spans, t)
        order = [s.state for s in spans]
        pts = np.column_stack([east, north])
        if len(pts) >= 2:
            segs = np.stack([pts[:-1], pts[1:]], axis=1)
            colours = [state_colour(s, order) if s else "#555555" for s in states[:-1]]
            ax.add_collection(LineCollection(list(segs), colors=colours, lw=1.8, zorder=4))
        seg_len = np.hypot(*np.diff(pts, axis=0).T) if len(pts) >= 2 else np.array([])
        per_state: dict[str, float] = {}
        for s, d in zip(states[:-1], seg_len, strict=True):
            per_state[s] = per_state.get(s, 0.0) + float(d)
        # States that drew a visible line (not position noise while waiting on the surface).
        moved = {s for s, d in per_state.items() if d >= max(1.0, 0.02 * float(seg_len.sum()))}
        for s in [s for s in dict.fromkeys(states) if s in moved]:
            handles.append(Line2D([], [], color=state_colour(s, order) if s else "#555555", lw=2.2,
                                  label=f"flown: {s or 'before first state'}"))
        if len(pts):
            ax.plot(*pts[0], marker="*", ms=15, color="#2a9d3a", mec="black", zorder=7, ls="")
            aborted = next((e for e in alerts(run) if e.kind == "state"), None)
            end_marker: dict[str, Any] = ({"marker": "X", "ms": 13, "color": "#c62828"} if aborted
                                          else {"marker": "s", "ms": 9, "color": "black"})
            ax.plot(*pts[-1], mec="white", zorder=7, ls="", **end_marker)
            if aborted:
                why = (run.summary or {}).get("reason") or aborted.message
                ax.annotate(f"ABORTED at {aborted.t_s:.0f} s\n{why}", pts[-1], xytext=(10, -4),
                            textcoords="offset points", fontsize=8, color="#c62828", fontweight="bold", zorder=8,
                            va="top",
                            bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "#c62828", "alpha": 0.85})
            handles.append(Line2D([], [], marker="*", ms=12, color="#2a9d3a", mec="black", ls="", label="start"))
            handles.append(Line2D([], [], ls="", mec="white", label="aborted here" if aborted else "end",
                                  **end_marker))
    labels: list[tuple[float, float, str, dict[str, Any]]] = []
    truth_style = {"fontsize": 7.5, "color": "#b71c1c", "zorder": 6,
                   "bbox": {"boxstyle": "round,pad=0.12", "fc": "white", "ec": "none", "alpha": 0.7}}
    for tgt in run.truth or ():
        ax.plot(tgt.east_m, tgt.north_m, marker="x", ms=9, mew=2.0, color="#c62828", zorder=5, ls="")
        labels.append((tgt.east_m, tgt.north_m, f"{truth_label(tgt.target_id)}: {tgt.height_m * 100:.1f} cm",
                       truth_style))
    if run.truth:
        handles.append(Line2D([], [], marker="x", mew=2.0, color="#c62828", ls="", label="true target (height)"))
    est_style = {"fontsize": 7.5, "zorder": 6,
                 "bbox": {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.75}}
    for tgt in run.targets or ():
        solved = math.isfinite(tgt.height_m)
        ax.plot(tgt.east_m, tgt.north_m, marker="o", ms=8, mfc="#ffd23f" if solved else "white", mec="black",
                zorder=6, ls="")
        text = f"#{tgt.target_id}: {tgt.height_m * 100:.1f} ± {tgt.height_std_m * 100:.2f} cm" if solved \
            else f"#{tgt.target_id}: no height"
        labels.append((tgt.east_m, tgt.north_m, text, est_style))
    if run.targets:
        handles.append(Line2D([], [], marker="o", mfc="#ffd23f", mec="black", ls="", label="estimated target"))
        handles.append(Line2D([], [], marker="o", mfc="white", mec="black", ls="", label="target without a height"))
    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east of origin (m)")
    ax.set_ylabel("north of origin (m)")
    ax.grid(True, color="#e4e4e4", lw=0.6)
    ax.set_title("Track against plan", fontsize=11)
    fig.legend(handles=handles, loc="outside right upper", fontsize=8, frameon=False)
    place_labels(ax, labels)
    return save_png(fig, path, dpi)


def figure_altitude(run: RunData, path: Path, *, dpi: int = 110) -> Path | None:
    """Altitude (altimeter, filter ±2σ, target, truth), altitude error and depth over time, with the states."""
    nav, flt, tilt, tt = run.nav, run.filter, run.tilt, run.truth_track
    if not any(s is not None and s.n_rows for s in (nav, flt, tt)):
        return None
    fig, axes, axis, _ = time_panels(run, 3, (2.2, 1.3, 1.3), 9.5)
    ax_alt, ax_err, ax_depth = axes[1], axes[2], axes[3]
    handles: list[Any] = []

    def line(ax: Any, s: Series | None, col: str, label: str, **kw: Any) -> Any:
        if s is not None and s.has(col):
            (h,) = ax.plot(s.col("t_s") * axis.scale, s.col(col), label=label, **kw)
            return h
        return None

    if flt is not None and flt.has("altimeter_m"):
        handles.append(ax_alt.scatter(flt.col("t_s") * axis.scale, flt.col("altimeter_m"), s=4, color="#9a9a9a",
                                      label="altimeter reading", zorder=2))
    if flt is not None and flt.has("altitude_est_m") and flt.has("altitude_std_m"):
        t, est, std = flt.col("t_s") * axis.scale, flt.col("altitude_est_m"), flt.col("altitude_std_m")
        handles.append(ax_alt.fill_between(t, est - 2 * std, est + 2 * std, color="#1f6fb4", alpha=0.22, lw=0,
                                           label="filter ±2σ", zorder=3))
    handles += [
        line(ax_alt, flt, "altitude_est_m", "filter estimate", color="#1f6fb4", lw=1.4, zorder=4),
        line(ax_alt, nav, "altitude_m", "telemetry altitude", color="#2a9d8f", lw=0.9, alpha=0.8, zorder=3),
        line(ax_alt, tilt, "altitude_target_m", "altitude target", color="#d9541e", lw=1.4, ls="--",
             drawstyle="steps-post", zorder=5),
        line(ax_alt, tt, "altitude_m", "true altitude (simulator)", color="black", lw=0.8, ls=(0, (1, 1)), zorder=6),
    ]
    if flt is not None and flt.has("rejected_total"):
        rej, t = flt.col("rejected_total"), flt.col("t_s")
        jumps = np.flatnonzero(np.diff(np.nan_to_num(rej, nan=0.0), prepend=0.0) > 0)
        if len(jumps):
            handles.append(ax_alt.scatter(t[jumps] * axis.scale, np.zeros(len(jumps)), marker="|", s=80,
                                          color="#c62828", transform=ax_alt.get_xaxis_transform(), clip_on=False,
                                          label=f"reading rejected ({int(np.nanmax(rej))})", zorder=6))
    ax_alt.set_ylabel("altitude above\nseabed (m)")
    legend_above(ax_alt, [h for h in handles if h is not None] + alert_legend(run))
    _altitude_error_panel(ax_err, run, axis)
    depth_handles = [
        line(ax_depth, nav, "depth_m", "telemetry depth", color="#2a9d8f", lw=1.2),
        line(ax_depth, flt, "depth_est_m", "filter depth", color="#1f6fb4", lw=1.0, ls="--"),
        line(ax_depth, flt, "seabed_depth_est_m", "seabed depth estimate", color="#8c564b", lw=1.2),
        line(ax_depth, tt, "depth_m", "true depth (simulator)", color="black", lw=0.8, ls=(0, (1, 1))),
    ]
    ax_depth.invert_yaxis()
    ax_depth.set_ylabel("depth (m, down)")
    legend_above(ax_depth, [h for h in depth_handles if h is not None])
    fig.suptitle("Altitude, altitude filter and depth", fontsize=11)
    return save_png(fig, path, dpi)


def _altitude_error_panel(ax: Any, run: RunData, axis: TimeAxis) -> None:
    """Filter estimate minus target (how well the altitude is held) and, in simulation, minus truth."""
    flt, tilt, tt = run.filter, run.tilt, run.truth_track
    handles: list[Any] = []
    shown: list[np.ndarray] = []
    if flt is None or not flt.has("altitude_est_m"):
        ax.text(0.5, 0.5, "no filter estimate (filter.csv)", ha="center", va="center", transform=ax.transAxes,
                color="#777777")
        ax.set_ylabel("altitude error (cm)")
        return
    t, est = flt.col("t_s"), flt.col("altitude_est_m")
    if flt.has("altitude_std_m"):
        two_sigma = 200 * flt.col("altitude_std_m")
        handles.append(ax.fill_between(t * axis.scale, -two_sigma, two_sigma, color="#1f6fb4", alpha=0.15, lw=0,
                                       label="filter ±2σ about 0"))
        shown.append(two_sigma)
    spans = state_spans(run.events, run.end_s())
    surveying = np.array([s.startswith("PASS") for s in state_at(spans, t)], dtype=bool)
    if tilt is not None and tilt.has("altitude_target_m"):
        target = np.interp(t, tilt.col("t_s"), tilt.col("altitude_target_m"), left=np.nan, right=np.nan)
        held = np.where(surveying | (not spans), 100 * (est - target), np.nan)
        (h,) = ax.plot(t * axis.scale, held, color="#d9541e", lw=1.2, label="estimate − target (on a pass)", zorder=4)
        handles.append(h)
        shown.append(held)
    if tt is not None and tt.has("altitude_m"):
        true_alt = np.interp(t, tt.col("t_s"), tt.col("altitude_m"), left=np.nan, right=np.nan)
        (h,) = ax.plot(t * axis.scale, 100 * (est - true_alt), color="black", lw=0.8, zorder=3,
                       label="estimate − truth (simulator)")
        handles.append(h)
        shown.append(100 * (est - true_alt))
    ax.axhline(0.0, color="#555555", lw=0.8)
    limits = robust_limits(shown)
    if limits is not None:
        ax.set_ylim(*limits)
    ax.set_ylabel("altitude error (cm)")
    legend_above(ax, handles)


def figure_tilt(run: RunData, path: Path, *, dpi: int = 110) -> Path | None:
    """Sonar tilt (commanded, measured), pitch, shadow margin, tracked targets; shadows in FOV (sim)."""
    tilt = run.tilt
    shadows = run.shadows if run.shadows is not None and run.shadows.n_rows else None
    if (tilt is None or not tilt.n_rows) and shadows is None:
        return None
    panels = [1.8, 1.5, 0.7] + ([1.3] if shadows is not None else [])
    fig, axes, axis, _ = time_panels(run, len(panels), panels, 2.4 + 2.0 * len(panels))
    ax_ang, ax_margin, ax_n = axes[1], axes[2], axes[3]
    angle_handles: list[Any] = []
    margin_handles: list[Any] = []
    if tilt is not None and tilt.n_rows:
        t = tilt.col("t_s") * axis.scale
        for col, label, kw in (("tilt_cmd_deg", "tilt commanded", {"color": "#d9541e", "ls": "--", "lw": 1.3,
                                                                     "drawstyle": "steps-post"}),
                               ("tilt_meas_deg", "tilt measured", {"color": "#1f6fb4", "lw": 1.3})):
            if tilt.has(col):
                angle_handles += ax_ang.plot(t, tilt.col(col), label=label, **kw)
        tt = run.truth_track
        if tt is not None and tt.has("tilt_deg"):
            angle_handles += ax_ang.plot(tt.col("t_s") * axis.scale, tt.col("tilt_deg"), color="black", lw=0.8,
                                         ls=(0, (1, 1)), label="true tilt (simulator)")
        if tilt.has("pitch_deg"):
            ax_pitch = ax_ang.twinx()
            angle_handles += ax_pitch.plot(t, tilt.col("pitch_deg"), color="#8a8a8a", lw=0.8,
                                           label="vehicle pitch (right axis)")
            lim = max(float(np.nanmax(np.abs(tilt.col("pitch_deg")))) * 1.3, 2.0)
            ax_pitch.set_ylim(-lim, lim)
            ax_pitch.set_ylabel("pitch (deg,\nnose up +)", color="#6d6d6d")
            ax_pitch.tick_params(axis="y", colors="#6d6d6d")
        if tilt.has("min_margin_deg"):
            m = tilt.col("min_margin_deg")
            margin_handles += ax_margin.plot(t, m, color="black", lw=1.0, label="smallest shadow margin")
            margin_handles.append(ax_margin.fill_between(t, 0, m, where=m < 0, color="#c62828", alpha=0.4, lw=0,
                                                         label="shadow outside FOV", interpolate=True))
            ax_margin.fill_between(t, 0, m, where=m >= 0, color="#2e7d32", alpha=0.15, lw=0, interpolate=True)
        else:
            ax_margin.text(0.5, 0.5, "no shadow margins logged (min_margin_deg empty: no target tracked, or a "
                           "fixed tilt)", ha="center", va="center", transform=ax_margin.transAxes, color="#777777")
        if tilt.has("n_tracked"):
            ax_n.plot(t, tilt.col("n_tracked"), color="#8e44ad", lw=1.1, drawstyle="steps-post")
    ax_ang.set_ylabel("tilt (deg,\ndown +)")
    legend_above(ax_ang, angle_handles + alert_legend(run))
    ax_margin.axhline(0.0, color="#c62828", lw=1.0)
    ax_margin.set_ylabel("shadow margin to\nFOV edge (deg)")
    legend_above(ax_margin, margin_handles)
    ax_n.set_ylabel("targets\ntracked")
    ax_n.yaxis.get_major_locator().set_params(integer=True)
    if shadows is not None:
        _shadow_raster(axes[4], shadows, axis)
    fig.suptitle("Sonar tilt and shadow margins", fontsize=11)
    return save_png(fig, path, dpi)


def _shadow_raster(ax: Any, shadows: Series, axis: TimeAxis) -> None:
    """Per true target and frame: shadow inside the vertical FOV (green) or not (red).

    Frames counted in the ratio are the ``settled`` ones when the column exists (the
    simulator's definition), else those ``within_range``; the others are drawn grey.
    """
    ids = shadows.text.get("target_id", ())
    order = list(dict.fromkeys(sorted(ids, key=lambda s: (len(s), s))))
    y = np.array([order.index(i) for i in ids], dtype=float)
    t = shadows.col("t_s") * axis.scale
    in_fov = shadows.col("in_fov") > 0.5
    near = shadows.col("within_range") > 0.5 if shadows.has("within_range") else np.ones(len(t), bool)
    counted = near & (shadows.col("settled") > 0.5) if "settled" in shadows.numbers else near
    ax.scatter(t[near & ~counted], y[near & ~counted], marker="|", s=60, color="#bdbdbd",
               label="settling (not counted)")
    ax.scatter(t[counted & in_fov], y[counted & in_fov], marker="|", s=60, color="#2e7d32", label="in FOV")
    ax.scatter(t[counted & ~in_fov], y[counted & ~in_fov], marker="|", s=60, color="#c62828",
               label="outside FOV")
    ratio = float(np.mean(in_fov[counted])) if counted.any() else math.nan
    ax.set_yticks(range(len(order)), [truth_label(i) for i in order], fontsize=7)
    ax.set_ylim(-0.7, len(order) - 0.3)
    ax.set_ylabel("target\n(simulator)")
    ax.set_title(f"simulator: whole shadow in the vertical FOV, {100 * ratio:.1f} % of {int(counted.sum())} "
                 "counted pairs", fontsize=8, loc="left")
    legend_above(ax, [h for h in ax.get_legend_handles_labels()[0]])


def figure_heights(run: RunData, score: HeightScore, path: Path, *, dpi: int = 110) -> Path | None:
    """Estimated against true heights (±2σ bars, 1:1 line) and the error per target."""
    if not score.errors or run.targets is None or run.truth is None:
        return None
    fig = new_figure(11.0, 5.2)
    ax, ax_err = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.0, 1.3]})
    true_cm = np.array([e.true_height_m for e in score.errors]) * 100
    est_cm = np.array([e.height_m for e in score.errors]) * 100
    std_cm = np.nan_to_num(np.array([e.height_std_m for e in score.errors]) * 100, nan=0.0)
    labels = [f"{truth_label(run.truth[e.truth].target_id)} (#{run.targets[e.estimated].target_id})"
              for e in score.errors]
    top = float(max(true_cm.max(), (est_cm + 2 * std_cm).max(), 1.0)) * 1.12
    ax.plot([0, top], [0, top], color="#6d6d6d", lw=1.0, ls="--", label="1:1 (perfect)")
    ax.errorbar(true_cm, est_cm, yerr=2 * std_cm, fmt="o", color="#1f6fb4", ecolor="#1f6fb4", capsize=3, ms=6,
                label="estimate ±2σ")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_aspect("equal")
    place_labels(ax, [(float(x), float(y), lab, {"fontsize": 7.5})
                      for x, y, lab in zip(true_cm, est_cm, labels, strict=True)])
    ax.set_xlabel("true height (cm)")
    ax.set_ylabel("estimated height (cm)")
    ax.grid(True, color="#e4e4e4", lw=0.6)
    ax.legend(fontsize=8, loc="upper left")
    by_truth = {e.truth: e for e in score.errors}
    no_height = {m.truth for m in score.no_height}
    ax_err.set_axisbelow(True)
    names, x_missing, why = [], [], []
    for k, t in enumerate(run.truth):
        names.append(truth_label(t.target_id))
        e = by_truth.get(k)
        if e is None:
            x_missing.append(k)
            why.append("no height" if k in no_height else "not found")
            continue
        err, two_s = (e.height_m - e.true_height_m) * 100, 2 * e.height_std_m * 100
        ok = math.isfinite(two_s) and abs(err) <= two_s
        ax_err.bar(k, err, color="#2e7d32" if ok else "#d9541e", width=0.6)
        if math.isfinite(two_s):
            ax_err.errorbar(k, err, yerr=two_s, fmt="none", ecolor="black", capsize=3, lw=0.9)
    for k, text in zip(x_missing, why, strict=True):
        ax_err.text(k, 0.5, text, rotation=90, ha="center", va="center", fontsize=8, color="#777777",
                    transform=ax_err.get_xaxis_transform())
    ax_err.axhline(0.0, color="black", lw=0.8)
    ax_err.set_xticks(range(len(names)), names, fontsize=8)
    ax_err.set_xlim(-0.6, len(names) - 0.4)
    ax_err.set_ylabel("estimated − true height (cm)")
    ax_err.grid(True, axis="y", color="#e4e4e4", lw=0.6)
    ax_err.set_title(f"mean |error| {score.mean_abs_error_m * 100:.2f} cm, max {score.max_abs_error_m * 100:.2f} cm, "
                     f"bias {score.mean_error_m * 100:+.2f} cm", fontsize=9)
    ax_err.legend(handles=[Patch(color="#2e7d32", label="error within ±2σ"),
                           Patch(color="#d9541e", label="error beyond ±2σ"),
                           Line2D([], [], color="black", lw=0.9, label="±2σ of the estimate")],
                  fontsize=7.5, loc="best")
    fig.suptitle(f"Target heights against simulator truth ({len(score.errors)} matched within "
                 f"{score.radius_m:g} m)", fontsize=11)
    return save_png(fig, path, dpi)
