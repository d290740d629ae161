"""A PNG of a planned survey: area, obstacles, both passes' lanes, footprints, start.

Plane coordinates ``(east_m, north_m)`` about the plan's origin, east to the right.
Uses matplotlib's Agg canvas directly (no global pyplot state).
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.patches import Polygon as MplPolygon

from perception.atomic_file import atomic_write_bytes
from planner.survey.area import SurveyArea
from planner.survey.footprint import Footprint
from planner.survey.plan import SurveyPlan

PASS_COLOURS = ("#1f6fb4", "#d9541e")


def _fill(ax: Any, geom: shapely.Geometry, **kw: Any) -> None:
    for poly in shapely.get_parts(geom):
        if poly.geom_type != "Polygon" or poly.is_empty:
            continue
        ax.add_patch(MplPolygon(np.asarray(poly.exterior.coords), closed=True, **kw))


def plot_plan(plan: SurveyPlan, area: SurveyArea, path: str | Path, *, dpi: int = 130) -> None:
    """Write the plan's picture to ``path`` (PNG)."""
    exc = max(p.excursion_limit_m for p in plan.passes)
    minx, miny, maxx, maxy = area.outer.buffer(exc + 2.0).bounds
    aspect = (maxx - minx) / max(maxy - miny, 1e-9)
    plot_h = 7.0 if aspect <= 1.4 else max(3.5, 9.5 / aspect)
    fig = Figure(figsize=(min(max(plot_h * aspect, 4.0), 11.0) + 3.6, plot_h + 1.0),
                 layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_facecolor("#eef3f7")
    _fill(ax, area.outer, facecolor="#fbf7ea", edgecolor="#333333", lw=1.5, zorder=1)
    for ring in area.boundary.interiors:
        _fill(ax, shapely.Polygon(ring), facecolor="#9a9a9a", edgecolor="#333333", hatch="//",
              lw=1.0, zorder=2)
    for k in area.keepouts:
        _fill(ax, k, facecolor="#e8a0a0", edgecolor="#a02020", hatch="xx", lw=1.0, zorder=2,
              alpha=0.9)
    handles: list[Line2D | Patch] = [
        Patch(facecolor="#fbf7ea", edgecolor="#333333", label="survey area"),
        Patch(facecolor="#9a9a9a", edgecolor="#333333", hatch="//", label="hole"),
        Patch(facecolor="#e8a0a0", edgecolor="#a02020", hatch="xx", label="keep-out"),
    ]
    for i, p in enumerate(plan.passes):
        xy = np.array([[w.east_m, w.north_m] for w in p.waypoints])
        colour = PASS_COLOURS[i % len(PASS_COLOURS)]
        offset = (i - 0.5) * 0.12 * plan.summary.lane_spacing_m
        ax.plot(xy[:, 0] + offset, xy[:, 1] + offset, color=colour, lw=0.9 if i == 0 else 0.7,
                ls="-" if i == 0 else (0, (4, 2)), zorder=4, alpha=0.9)
        fp = Footprint(p.altitude_m, p.tilt_rad, p.near_ground_m, p.far_ground_m,
                       math.atan(p.swath_m / (2 * p.near_ground_m)))
        for run in p.runs[:: max(1, len(p.runs) // 6)]:
            pos = (run.start_east_m, run.start_north_m)
            ax.add_patch(MplPolygon(fp.corners_plane(pos, run.heading_rad), closed=True,
                                    facecolor=colour, alpha=0.35, edgecolor=colour, zorder=5))
        handles.append(Line2D([], [], color=colour, lw=1.5, ls="-" if i == 0 else "--",
                              label=f"{p.name}: altitude {p.altitude_m:.2f} m,\n"
                              f"  tilt {math.degrees(p.tilt_rad):.1f} deg, swath {p.swath_m:.2f} m"))
    handles.append(Patch(facecolor="#777777", alpha=0.35, label="sonar footprint (at a run start)"))
    first = plan.passes[0].waypoints[0]
    ax.plot(first.east_m, first.north_m, marker="*", ms=16, color="#2a9d3a", mec="black",
            zorder=7)
    last = plan.passes[-1].waypoints[-1]
    ax.plot(last.east_m, last.north_m, marker="s", ms=9, color="black", zorder=7)
    handles += [
        Line2D([], [], marker="*", ms=12, color="#2a9d3a", mec="black", ls="", label="start"),
        Line2D([], [], marker="s", ms=7, color="black", ls="", label="end"),
    ]
    s = plan.summary
    ax.set_title(
        f"Dual-altitude survey: {s.n_lanes} lanes at {math.degrees(s.lane_heading_rad):.0f} deg, "
        f"spacing {s.lane_spacing_m:.2f} m, {s.total_length_m / 1000:.2f} km, "
        f"{s.total_duration_s / 3600:.2f} h at {s.speed_m_s:g} m/s\n"
        f"coverage {100 * s.coverage_fraction:.2f} % (worse pass), height resolution "
        f"{1000 * s.height_resolution_m:.1f} mm ({s.samples_per_cm:.2f} samples/cm)",
        fontsize=10,
    )
    ax.set_xlabel("east of origin (m)")
    ax.set_ylabel("north of origin (m)")
    ax.set_aspect("equal")
    ax.set_xlim(minx, maxx)
    ax.set_ylim(miny, maxy)
    ax.grid(True, color="white", lw=0.8)
    fig.legend(handles=handles, loc="outside right upper", fontsize=8, frameon=False)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    atomic_write_bytes(path, buffer.getvalue())
