"""Where a shadow starts: at the target's far top edge, at its near foot, or at its near edge.

Eq. 2 rests on the shadow starting at the target's far top edge, slant range
``r_top = sqrt(g_far^2 + (H - h)^2)`` (``g`` ground distances from below the sonar). But the
seabed in front of the target is seen too, at the same slant ranges, and it is hidden
only from the target's near foot on, ``r_foot = sqrt(g_near^2 + H^2)``. So the image's
shadow starts at ``max(r_top, r_foot)``: for a target short along the beam and tall
(``g_far - g_near`` below about ``h tan(depression)``) the far top edge lies in the echo of
the seabed in front of the target (layover) and the shadow starts at the near foot; Eq. 2
then reads the height low (by 3-30 % in such scenes), and lower the higher the sonar.

The shadow's END is always cast by the far top edge: ``g_end = g_far H / (H - h)``. With
the sonar at two or more altitudes over the same ground (a vertical climb, or positions
known in the frames), the ends alone give ``(g_far, h)`` by linear least squares:

    g_end_i H_i = g_far H_i + g_end_i h,   g_end_i = sqrt(r_end_i^2 - H_i^2)

(:func:`end_triangulation`). It needs the absolute altitudes (an altitude error shifts
``g_end`` by ``H / g_end`` of it) and is noisier than Eq. 2 (it rests on the ends' change
with altitude, not on each frame's shadow ratio), so it replaces Eq. 2 only where the two
disagree beyond their noise and the far top edge the ends imply tells what the shadow's
start was instead (:func:`check_start`): before it in every frame -- the near foot -- or
after it in every frame -- a target whose top is as dark as its shadow (a smooth top seen
at grazing incidence), so that the "shadow" seemed to start at the target's near edge and
Eq. 2 read it high -- and always between the target's near edge and the shadow's end.
Units: metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: Sigmas by which Eq. 2's heights must fall short of the ends' height for a near foot.
SHORT_SIGMAS = 3.0
#: Slack, in sigmas of the ranges, in the near foot's geometric tests.
SLACK_SIGMAS = 3.0


@dataclass(frozen=True)
class EndFrame:
    """One frame's view of a target for the ends' triangulation.

    Attributes
    ----------
    r_start_m, r_end_m, sigma_r_m : float
        The shadow's start and end slant ranges and their 1-sigma, m.
    altitude_m, altitude_std_m : float
        The sonar's altitude and its 1-sigma, m (the ends depend on it).
    offset_m : float
        The sonar's displacement towards the target since the reference frame, m (0 for a
        vertical climb): ground distances are counted from the reference frame's sonar.
    """

    r_start_m: float
    r_end_m: float
    sigma_r_m: float
    altitude_m: float
    altitude_std_m: float = 0.0
    offset_m: float = 0.0


@dataclass(frozen=True)
class EndFit:
    """The ends' triangulation: the far top edge's ground distance and the target's height.

    Attributes
    ----------
    height_m, height_std_m : float
    g_far_m, g_far_std_m : float
        Ground distance of the far top edge from the reference frame's sonar, m.
    chi2 : float
        Weighted residual of the fit (0 for two frames).
    """

    height_m: float
    height_std_m: float
    g_far_m: float
    g_far_std_m: float
    chi2: float


def _ground(frame: EndFrame, r_m: float) -> tuple[float, float]:
    """Ground distance (from the reference sonar) of a seabed point at slant range ``r_m`` and its variance."""
    g2 = r_m * r_m - frame.altitude_m * frame.altitude_m
    if not g2 > 0:
        return math.nan, math.nan
    g = math.sqrt(g2)
    var = (r_m / g) ** 2 * frame.sigma_r_m**2 + (frame.altitude_m / g) ** 2 * frame.altitude_std_m**2
    return g + frame.offset_m, var


def end_triangulation(frames: Sequence[EndFrame]) -> EndFit | None:
    """``(g_far, h)`` from the shadow's ends over altitudes (module docstring); None when the
    frames do not determine them (fewer than two altitudes, an end nearer than the altitude)."""
    rows, targets, variances = [], [], []
    for f in frames:
        g_end, var = _ground(f, f.r_end_m)
        if not math.isfinite(g_end):
            return None
        # g_end (H - h) = g_far H, shifted to ground from the reference sonar.
        rows.append((f.altitude_m, g_end))
        targets.append(g_end * f.altitude_m)
        variances.append(var)
    a = np.array(rows)
    if a.shape[0] < 2 or np.ptp(a[:, 0]) <= 1e-6:
        return None
    y = np.array(targets)
    # Weights from the ends' variances at a first solve, then once more at its height.
    h = 0.0
    w = np.ones(len(rows))
    for _ in range(2):
        aw = a * w[:, None]
        normal = aw.T @ a
        if abs(np.linalg.det(normal)) < 1e-18:
            return None
        g_far, h = np.linalg.solve(normal, aw.T @ y)
        w = 1.0 / np.maximum(np.array([(f.altitude_m - h) ** 2 for f in frames]) * np.array(variances), 1e-18)
    aw = a * w[:, None]
    normal = aw.T @ a
    cov = np.linalg.inv(normal)
    residual = y - a @ np.array([g_far, h])
    chi2 = float(np.sum(w * residual**2))
    return EndFit(float(h), float(math.sqrt(max(cov[1, 1], 0.0))), float(g_far), float(math.sqrt(max(cov[0, 0], 0.0))),
                  chi2)


@dataclass(frozen=True)
class StartCheck:
    """Whether the shadow's start is the far top edge, from the ends over altitudes.

    Attributes
    ----------
    use_ends : bool
        True when Eq. 2's height disagrees with the ends' beyond both their sigmas (and
        ``DISAGREE_FRACTION`` of the height) while the far top edge the ends imply lies
        between the target's near edge and the shadow's end in every frame: then the
        shadow's start was not the far top edge.
    label : str
        ``"far top edge"``, ``"near foot"`` (the implied far top edge lies before the
        shadow's start: layover) or ``"dim top"`` (it lies after it: the target's top
        is as dark as its shadow, so the shadow seemed to start at the target's near edge).
    fit : EndFit
    """

    use_ends: bool
    label: str
    fit: EndFit


#: Eq. 2 and the ends must differ by this fraction of the height, besides their sigmas.
DISAGREE_FRACTION = 0.05
#: ... and by this many sigmas.
DISAGREE_SIGMAS = 3.0


def check_start(
    frames: Sequence[EndFrame], eq2_height: tuple[float, float], near_m: Sequence[float]
) -> StartCheck | None:
    """Eq. 2's height against the ends' triangulation (module docstring).

    Parameters
    ----------
    frames : sequence of EndFrame
        The target's frames (two or more altitudes).
    eq2_height : (float, float)
        Eq. 2's height over those frames and its 1-sigma, m.
    near_m : sequence of float
        Each frame's slant range where the target's echo starts, m (NaN: unknown; the
        shadow's start is the bound then).

    Returns
    -------
    StartCheck or None
        None when the ends do not determine the height.
    """
    fit = end_triangulation(frames)
    if fit is None or not (math.isfinite(fit.height_m) and fit.height_m > 0):
        return None
    h, h_std = eq2_height
    before = after = 0
    inside = True
    for f, near in zip(frames, near_m, strict=True):
        r_top = math.hypot(fit.g_far_m - f.offset_m, f.altitude_m - fit.height_m)
        slack = SLACK_SIGMAS * math.hypot(f.sigma_r_m, fit.g_far_std_m)
        lower = near if math.isfinite(near) else f.r_start_m
        inside &= lower - slack <= r_top <= f.r_end_m + slack
        before += r_top < f.r_start_m
        after += r_top > f.r_start_m
    label = "near foot" if before == len(frames) else ("dim top" if after == len(frames) else "far top edge")
    gap = abs(h - fit.height_m)
    disagree = gap > max(DISAGREE_SIGMAS * math.hypot(h_std, fit.height_std_m), DISAGREE_FRACTION * fit.height_m)
    use = bool(disagree and inside and label != "far top edge")
    return StartCheck(use, label if use else "far top edge", fit)
