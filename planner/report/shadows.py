"""The report's account of shadows in view: the judge's ratio, what it counts, and what it does not.

Two figures speak of shadows outside the field of view and must not seem to contradict
each other:

- the **judge's ratio** (``summary.json`` ``shadow_in_fov_ratio``, simulation only,
  :mod:`planner.dryrun.scoring`): over the survey frames, the targets in the *counted
  zone* (whole shadow in the window and the fan, far enough ahead, holdable by one tilt
  together with the window's end, and settled for a second), the share whose whole
  shadow was in view. Targets nearer or taller than that zone are in the *near band*
  and are not counted; their seconds are reported apart (``shadow_time_by_target``);
- the **controller's margins** (``tilt.csv`` ``min_margin_deg``): the pitch loop's own
  view of every target it tracks, near band and settling included.

So 100 % in view and "a shadow outside the field of view for 35 s" can both be true: the
seconds outside were outside the counted zone. This module writes both, and the
per-target seconds that reconcile them.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from planner.report.data import RunData
from planner.report.md import cell, fmt, table, truth_label


def margin_lines(run: RunData) -> list[str]:
    """The controller's margin figures (tilt section), with what they include."""
    tilt = run.tilt
    if tilt is None or not tilt.has("min_margin_deg"):
        return []
    t, m = tilt.col("t_s"), tilt.col("min_margin_deg")
    dt = np.diff(t, append=t[-1])
    neg = np.isfinite(m) & (m < 0)
    total = float(np.nansum(dt[np.isfinite(m)]))
    smallest = float(np.nanmin(m)) if np.isfinite(m).any() else float("nan")
    text = (f"Controller's view (tilt.csv): smallest shadow margin {fmt(smallest, 'deg')}; the loop had a tracked "
            f"shadow outside the field of view for {float(dt[neg].sum()):.1f} s of the {total:.1f} s it tracked "
            "any target. This is the pitch loop's own margin over every target it tracks: also those nearer than "
            "the counted zone (the near band, and targets closer than 2 altitudes ahead as the vehicle passes over "
            "them, still tracked from memory), those at the fan's edges or beyond the window, and those still "
            "settling. It is not the judge's figure: the Shadows in view ratio counts only target-frames in the "
            "counted zone, and its table gives each target's seconds there.")
    return [text, ""]


def _per_target(summary: Mapping[str, Any]) -> list[str]:
    per = summary.get("shadow_time_by_target")
    if not isinstance(per, dict) or not per:
        return []
    rows = []
    for tid, v in per.items():
        if not isinstance(v, dict):
            continue
        rows.append([cell(truth_label(str(tid))), fmt(v.get("within_range_s"), "s"), fmt(v.get("out_of_view_s"), "s"),
                     fmt(v.get("near_band_s"), "s")])
    lines = table(["true target", "in the counted zone", "of which out of view", "in the near band (not counted)"],
                  rows)
    return lines + ["Seconds of survey frames per true target (simulator truth). In the counted zone: the target "
                    "is where one tilt can hold its whole shadow and the window's end; out of view: its whole "
                    "shadow was not in the vertical field of view there. In the near band: nearer or taller than "
                    "the counted zone, where the loop follows it with a lower weight and the ratio does not count "
                    "it. The first second of each pass and of each target entering the zone (the loop settling) "
                    "is left out of the ratio but not of these seconds.", ""]


def shadows_section(run: RunData, shadows_figure: Path | None = None) -> list[str]:
    """``## Shadows in view``: the judge's ratio, its definition, per-target seconds, second figures."""
    del shadows_figure
    lines = ["## Shadows in view", ""]
    s = run.summary or {}
    if "shadow_in_fov_ratio" not in s:
        return lines + ["_No simulator truth (a real dive): only the controller's own margins are known (Tilt and "
                        "shadow margins)._", ""]
    counted = s.get("shadow_frames_within_range")
    lines += [f"**{fmt(s.get('shadow_in_fov_ratio'), 'percent')}** of {fmt(counted, 'count')} counted target-frames "
              "had the whole shadow inside the vertical field of view (summary.json `shadow_in_fov_ratio`).", ""]
    if s.get("shadow_in_fov_definition"):
        lines += [f"What is counted: {cell(s['shadow_in_fov_definition'])}.", ""]
    lines += _per_target(s)
    second = []
    if "shadow_in_fov_ratio_2alt" in s:
        second.append(["from 2 altitudes ahead", fmt(s.get("shadow_in_fov_ratio_2alt"), "percent"),
                       fmt(s.get("shadow_frames_within_range_2alt"), "count"),
                       "every target from 2 altitudes ahead that some tilt could show whole, near band included "
                       "(up to the most one tilt could show where they conflict)"])
    if "shadow_in_fov_ratio_all" in s:
        second.append(["counted zone, settling included", fmt(s.get("shadow_in_fov_ratio_all"), "percent"), "–",
                       "the counted zone without leaving out the loop's first second"])
    if "shadow_fov_model_agreement" in s:
        second.append(["judge's geometry agrees with the simulator", fmt(s.get("shadow_fov_model_agreement"),
                                                                          "percent"), "–",
                       "share of frames where the judge's own in-view geometry gives the simulator's flag"])
    if second:
        lines += table(["second figure", "value", "target-frames", "what it counts"], second)
    sh = run.shadows
    if sh is not None and sh.n_rows and sh.has("within_range"):
        near = sh.col("within_range") > 0.5
        settled = "settled" in sh.numbers
        counted_rows = near & (sh.col("settled") > 0.5) if settled else near
        inside = sh.col("in_fov") > 0.5
        if counted_rows.any():
            lines += [f"shadows.csv (one row per frame and target) gives the same: whole shadow in view in "
                      f"{100 * float(inside[counted_rows].mean()):.1f} % of {int(counted_rows.sum())} counted rows.",
                      ""]
    return lines
