"""Where a shadow starts: at the target's far top edge, or at its near foot.

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
with altitude, not on each frame's shadow ratio), so it replaces Eq. 2 only where the
shadow is seen to start at the near foot (:func:`check_start`).
Units: metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: Sigmas by which Eq. 2's heights must fall short of the ends' height for a near foot.
SHORT_SIGMAS = 2.0
#: The foot's ground place may move this much between frames beyond its noise, m (it is
#: a mean over the beams, of a face that may run oblique to them).
FOOT_SLACK_M = 0.01
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
    """Whether the shadow starts at the near foot, from the ends over altitudes.

    Attributes
    ----------
    use_ends : bool
        True when the shadow starts at the near foot (:func:`check_start`): the height
        is then the ends' triangulation's.
    label : str
        ``"near foot"`` or ``"far top edge"``.
    fit : EndFit
    """

    use_ends: bool
    label: str
    fit: EndFit


def check_start(frames: Sequence[EndFrame], eq2_heights: Sequence[tuple[float, float]]) -> StartCheck | None:
    """Whether the shadow starts at the near foot in every frame (module docstring).

    The three signs: the ground under the shadow's start stays put from frame to frame
    (a foot; a far top edge's apparent ground place moves by ``h dH / g``); the far top
    edge the ends imply lies nearer than the shadow's start in every frame (hidden in the
    layover); and every frame's Eq. 2 height falls short of the ends' by more than the noise.

    Parameters
    ----------
    frames : sequence of EndFrame
        The target's frames (two or more altitudes).
    eq2_heights : sequence of (float, float)
        Each frame's Eq. 2 height and its 1-sigma, m.

    Returns
    -------
    StartCheck or None
        None when the ends do not determine the height.
    """
    fit = end_triangulation(frames)
    if fit is None or not (math.isfinite(fit.height_m) and fit.height_m > 0):
        return None
    plain = StartCheck(False, "far top edge", fit)
    feet = []
    for f in frames:
        r_top = math.hypot(fit.g_far_m - f.offset_m, f.altitude_m - fit.height_m)
        if r_top > f.r_start_m + SLACK_SIGMAS * math.hypot(f.sigma_r_m, fit.g_far_std_m):
            return plain
        g_foot, var = _ground(f, f.r_start_m)
        if not math.isfinite(g_foot) or g_foot > fit.g_far_m:
            return plain
        feet.append((g_foot, var))
    g = [v for v, _ in feet]
    if max(g) - min(g) > SLACK_SIGMAS * math.sqrt(2.0 * max(var for _, var in feet)) + FOOT_SLACK_M:
        return plain
    if not all(h + SHORT_SIGMAS * math.hypot(s, fit.height_std_m) < fit.height_m for h, s in eq2_heights):
        return plain
    return StartCheck(True, "near foot", fit)
