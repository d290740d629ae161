"""Drawing helpers the dive report's figures share: the time axis, the state ribbon,
legends above panels, alert marks, labels that avoid each other, atomic PNG saving.

matplotlib's Agg canvas is used directly (no pyplot global state).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from perception.atomic_file import atomic_write
from planner.report.data import Event, RunData
from planner.report.timeline import TERMINAL_STATES, StateSpan, alerts, state_colour, state_spans


@dataclass(frozen=True)
class TimeAxis:
    """Seconds, or minutes for runs longer than 20 minutes (the run folder's ``t_s`` clock)."""

    scale: float
    label: str

    @classmethod
    def for_run(cls, end_s: float) -> TimeAxis:
        """The axis for a run ending at ``end_s``."""
        if end_s > 1200.0:
            return cls(1.0 / 60.0, "run time (min)")
        return cls(1.0, "run time (s)")


def new_figure(width_in: float, height_in: float) -> Figure:
    """A figure on its own Agg canvas (no pyplot), laid out by constrained layout."""
    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Figure, path: Path, dpi: int) -> Path:
    """Write ``fig`` as a PNG, atomically; returns the path."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return atomic_write(path, lambda h: h.write(buffer.getvalue()))


def draw_ribbon(ax: Any, spans: Sequence[StateSpan], axis: TimeAxis, end_s: float) -> None:
    """The state timeline as a coloured bar, names written in where they fit, and a key above."""
    order = [s.state for s in spans]
    width_total = max(end_s, 1e-9) * axis.scale
    for span in spans:
        colour = state_colour(span.state, order)
        x0, width = span.start_s * axis.scale, (span.end_s - span.start_s) * axis.scale
        if span.state in TERMINAL_STATES:
            ax.axvline(x0, color=colour, lw=3.0)
            continue
        ax.broken_barh([(x0, width)], (0, 1), facecolors=colour, edgecolor="white", lw=0.8)
        # About 0.0075 of a 10-inch axis per character at this font size.
        if width > 0.0075 * (len(span.state) + 2) * width_total:
            ax.text(x0 + width / 2, 0.5, span.state, ha="center", va="center", fontsize=7.5, color="white",
                    fontweight="bold", clip_on=True)
    key = [Patch(color=state_colour(s, order), label=s) for s in dict.fromkeys(order)]
    if key:
        ax.legend(handles=key, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncols=min(len(key), 11), fontsize=7.5,
                  frameon=False, handlelength=1.2, columnspacing=1.2)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.set_ylabel("state", rotation=0, ha="right", va="center", fontsize=8)
    for side in ("top", "right", "left"):
        ax.spines[side].set_visible(False)


def legend_above(ax: Any, handles: Sequence[Any], ncols: int = 4) -> None:
    """A legend in a row above the panel, right-aligned, never over the data."""
    if handles:
        ax.legend(handles=list(handles), loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=min(ncols, len(handles)),
                  fontsize=7.5, frameon=False, borderaxespad=0.1)


def mark_changes(axes: Sequence[Any], spans: Sequence[StateSpan], alerts: Sequence[Event], axis: TimeAxis) -> None:
    """Faint lines at state changes and red lines at failsafes/aborts, on every panel."""
    for ax in axes:
        for span in spans:
            ax.axvline(span.start_s * axis.scale, color="#999999", lw=0.6, ls=":", zorder=0)
        for e in alerts:
            ax.axvline(e.t_s * axis.scale, color="#c62828", lw=1.2, ls="--", zorder=1)
    if axes:
        for e in alerts:
            text = e.state if e.kind == "state" else f"{e.kind}: {e.message}"
            axes[0].text(e.t_s * axis.scale, 0.98, text[:40], rotation=90, ha="right", va="top", fontsize=7,
                         color="#c62828", transform=axes[0].get_xaxis_transform(), zorder=7,
                         bbox={"boxstyle": "square,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.7})


def time_panels(run: RunData, n_panels: int, ratios: Sequence[float],
                 height_in: float) -> tuple[Figure, list[Any], TimeAxis, tuple[StateSpan, ...]]:
    """A figure of the state ribbon over ``n_panels`` time panels sharing the time axis."""
    end_s = run.end_s()
    axis = TimeAxis.for_run(end_s)
    spans = state_spans(run.events, end_s)
    fig = new_figure(11.0, height_in)
    axes = fig.subplots(n_panels + 1, 1, sharex=True, gridspec_kw={"height_ratios": [0.35, *ratios]})
    draw_ribbon(axes[0], spans, axis, end_s)
    mark_changes(list(axes[1:]), spans, alerts(run), axis)
    for ax in axes[1:]:
        ax.grid(True, color="#e4e4e4", lw=0.6)
    axes[-1].set_xlabel(axis.label)
    start_s = run.start_s()
    axes[-1].set_xlim(start_s * axis.scale, (end_s + 0.01 * max(end_s - start_s, 1.0)) * axis.scale)
    return fig, list(axes), axis, spans


def alert_legend(run: RunData) -> list[Line2D]:
    """The legend entry for the failsafe/abort marks, when the run has any."""
    return [Line2D([], [], color="#c62828", ls="--", lw=1.2, label="failsafe / abort")] if alerts(run) else []


#: Label offsets tried in turn (points from the anchor, horizontal and vertical alignment).
_LABEL_OFFSETS = ((6, 4, "left", "bottom"), (6, -4, "left", "top"), (-6, 4, "right", "bottom"),
                  (-6, -4, "right", "top"), (0, 10, "center", "bottom"), (0, -10, "center", "top"),
                  (10, 16, "left", "bottom"), (10, -16, "left", "top"), (-10, 16, "right", "bottom"),
                  (-10, -16, "right", "top"))


def place_labels(ax: Any, labels: Sequence[tuple[float, float, str, dict[str, Any]]]) -> None:
    """Annotate points ``(x, y, text, style)`` (data coordinates), each label where it covers the least
    of the labels and points placed before it (first free offset of :data:`_LABEL_OFFSETS`)."""
    if not labels:
        return
    fig = ax.get_figure()
    fig.draw_without_rendering()  # fixes limits, aspect and layout (no pixels): the boxes below are as drawn
    renderer = fig.canvas.get_renderer()
    points = ax.transData.transform(np.array([[x, y] for x, y, _, _ in labels]))
    # Every placed box as one row (x0, y0, x1, y1), display pixels: the points, then the labels.
    occupied = np.empty((len(labels) * 2, 4))
    occupied[: len(labels)] = np.column_stack([points - 5.0, (points - 5.0) + 10.0])  # as Bbox.from_bounds
    n_occupied = len(labels)
    for x, y, text, style in labels:
        best: tuple[float, Any, Any] | None = None
        for dx, dy, ha, va in _LABEL_OFFSETS:
            ann = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points", ha=ha, va=va, **style)
            box = ann.get_window_extent(renderer)
            cover = covered_area(box.extents, occupied[:n_occupied])
            if best is None or cover < best[0]:
                if best is not None:
                    best[1].remove()
                best = (cover, ann, box)
            else:
                ann.remove()
            if cover == 0.0:
                break
        if best is not None:
            occupied[n_occupied] = best[2].extents
            n_occupied += 1


def covered_area(box: Sequence[float], others: np.ndarray) -> float:
    """Area of ``box`` (x0, y0, x1, y1) that the boxes ``others`` (rows of x0, y0, x1, y1)
    cover, summed over them in their order (an area covered twice counts twice); edges
    that only touch cover nothing."""
    x0, y0, x1, y1 = min(box[0], box[2]), min(box[1], box[3]), max(box[0], box[2]), max(box[1], box[3])
    lo_x, hi_x = np.minimum(others[:, 0], others[:, 2]), np.maximum(others[:, 0], others[:, 2])
    lo_y, hi_y = np.minimum(others[:, 1], others[:, 3]), np.maximum(others[:, 1], others[:, 3])
    width = np.minimum(hi_x, x1) - np.maximum(lo_x, x0)
    height = np.minimum(hi_y, y1) - np.maximum(lo_y, y0)
    cover = 0.0
    for area in (width * height)[(width > 0.0) & (height > 0.0)]:
        cover += float(area)  # in order, one at a time: the same sum as box by box
    return cover


def robust_limits(values: Sequence[np.ndarray], pad: float = 0.15) -> tuple[float, float] | None:
    """Axis limits covering the 1st to 99th percentile of ``values`` with some padding."""
    finite = np.concatenate([v[np.isfinite(v)] for v in values]) if values else np.array([])
    if not len(finite):
        return None
    lo, hi = np.percentile(finite, [1.0, 99.0])
    span = max(hi - lo, 1.0)
    return float(lo - pad * span), float(hi + pad * span)


