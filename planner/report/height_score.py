"""Scoring estimated target heights against simulator truth.

Estimated targets are matched to true ones by their seabed position (local NED
``north_m``, ``east_m``): one-to-one, minimising the summed distance, never farther apart
than a radius. Pure functions; used by the dive report and the whole-loop tests.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np


class Placed(Protocol):
    """Anything with a seabed position (local NED, m)."""

    @property
    def north_m(self) -> float: ...

    @property
    def east_m(self) -> float: ...


class Estimate(Placed, Protocol):
    """An estimated target: position, height and its 1-sigma (m; NaN = none)."""

    @property
    def height_m(self) -> float: ...

    @property
    def height_std_m(self) -> float: ...


class Truth(Placed, Protocol):
    """A true target: position and height (m)."""

    @property
    def height_m(self) -> float: ...


@dataclass(frozen=True)
class TargetMatch:
    """Estimated target ``estimated`` matched to true target ``truth`` (indices), ``distance_m`` apart."""

    estimated: int
    truth: int
    distance_m: float


@dataclass(frozen=True)
class Matching:
    """Result of :func:`match_targets`: pairs (by truth index) and the indices left over."""

    pairs: tuple[TargetMatch, ...]
    unmatched_estimated: tuple[int, ...]
    unmatched_truth: tuple[int, ...]


def match_targets(estimated: Sequence[Placed], truth: Sequence[Placed], radius_m: float) -> Matching:
    """Match estimated to true targets by nearest seabed position, one to one.

    Parameters
    ----------
    estimated, truth : sequences of objects with ``north_m``, ``east_m`` (local NED, m)
    radius_m : float
        Largest distance of a match, m (> 0).

    Returns
    -------
    Matching
        The assignment that minimises the summed distance among pairs closer than
        ``radius_m``; pairs sorted by truth index.

    Raises
    ------
    ValueError
        For a radius that is not a positive finite number.
    """
    if not (math.isfinite(radius_m) and radius_m > 0):
        raise ValueError(f"radius_m must be a positive finite number of metres, got {radius_m}")
    est = np.array([[t.north_m, t.east_m] for t in estimated], dtype=float).reshape(-1, 2)
    tru = np.array([[t.north_m, t.east_m] for t in truth], dtype=float).reshape(-1, 2)
    pairs: list[TargetMatch] = []
    if len(est) and len(tru):
        dist = np.hypot(est[:, None, 0] - tru[None, :, 0], est[:, None, 1] - tru[None, :, 1])
        usable = np.isfinite(dist) & (dist <= radius_m)
        # Forbidden pairs cost more than any all-allowed assignment could.
        big = radius_m * (min(len(est), len(tru)) + 1) * 10.0
        from scipy.optimize import linear_sum_assignment  # scipy.optimize: only when matching

        rows, cols = linear_sum_assignment(np.where(usable, dist, big))
        pairs = [TargetMatch(int(r), int(c), float(dist[r, c])) for r, c in zip(rows, cols, strict=True)
                 if usable[r, c]]
    pairs.sort(key=lambda m: m.truth)
    used_e = {m.estimated for m in pairs}
    used_t = {m.truth for m in pairs}
    return Matching(tuple(pairs), tuple(i for i in range(len(est)) if i not in used_e),
                    tuple(i for i in range(len(tru)) if i not in used_t))


@dataclass(frozen=True)
class HeightError:
    """One matched target: estimated minus true height (m); ``z`` = error / std (NaN if no std)."""

    estimated: int
    truth: int
    distance_m: float
    true_height_m: float
    height_m: float
    height_std_m: float

    @property
    def error_m(self) -> float:
        """Estimated minus true height, m."""
        return self.height_m - self.true_height_m

    @property
    def z(self) -> float:
        """Error in units of the estimate's 1-sigma (NaN when the sigma is unknown or 0)."""
        ok = math.isfinite(self.height_std_m) and self.height_std_m > 0
        return self.error_m / self.height_std_m if ok else math.nan


@dataclass(frozen=True)
class HeightScore:
    """Heights against truth.

    ``errors`` covers matched targets with an estimated height; ``no_height`` lists the
    matches whose estimate has none (truth index, estimated index). Statistics are NaN
    when ``errors`` is empty.
    """

    errors: tuple[HeightError, ...]
    no_height: tuple[TargetMatch, ...]
    unmatched_estimated: tuple[int, ...]
    unmatched_truth: tuple[int, ...]
    radius_m: float

    @property
    def mean_abs_error_m(self) -> float:
        """Mean |error|, m."""
        return float(np.mean([abs(e.error_m) for e in self.errors])) if self.errors else math.nan

    @property
    def max_abs_error_m(self) -> float:
        """Largest |error|, m."""
        return float(max(abs(e.error_m) for e in self.errors)) if self.errors else math.nan

    @property
    def rms_error_m(self) -> float:
        """Root-mean-square error, m."""
        return float(math.sqrt(np.mean([e.error_m ** 2 for e in self.errors]))) if self.errors else math.nan

    @property
    def mean_error_m(self) -> float:
        """Mean signed error (bias), m."""
        return float(np.mean([e.error_m for e in self.errors])) if self.errors else math.nan


def score_heights(estimated: Sequence[Estimate], truth: Sequence[Truth], *, radius_m: float = 1.0) -> HeightScore:
    """Match estimates to truth and measure the height errors.

    Estimates with a height are matched first (:func:`match_targets`), so an estimate
    without one never takes a true target from one with a height; the true targets left
    over are then matched to the estimates without a height (``no_height``).

    Parameters
    ----------
    estimated : sequence of objects with ``north_m``, ``east_m``, ``height_m``, ``height_std_m``
        Estimated targets (local NED, m); ``height_m`` NaN where none was solved.
    truth : sequence of objects with ``north_m``, ``east_m``, ``height_m``
        True targets (local NED, m).
    radius_m : float
        Largest distance of a match, m.
    """
    solved = [i for i, e in enumerate(estimated) if math.isfinite(e.height_m)]
    unsolved = [i for i, e in enumerate(estimated) if not math.isfinite(e.height_m)]
    first = match_targets([estimated[i] for i in solved], truth, radius_m)
    errors = []
    for m in first.pairs:
        e, t = estimated[solved[m.estimated]], truth[m.truth]
        errors.append(HeightError(solved[m.estimated], m.truth, m.distance_m, float(t.height_m), float(e.height_m),
                                  float(e.height_std_m)))
    left = list(first.unmatched_truth)
    second = match_targets([estimated[i] for i in unsolved], [truth[j] for j in left], radius_m)
    no_height = tuple(TargetMatch(unsolved[m.estimated], left[m.truth], m.distance_m) for m in second.pairs)
    used = {e.estimated for e in errors} | {m.estimated for m in no_height}
    found = {e.truth for e in errors} | {m.truth for m in no_height}
    return HeightScore(tuple(errors), tuple(sorted(no_height, key=lambda m: m.truth)),
                       tuple(i for i in range(len(estimated)) if i not in used),
                       tuple(j for j in range(len(truth)) if j not in found), float(radius_m))
