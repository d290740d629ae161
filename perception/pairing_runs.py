"""Regrouping the beams a shadow region received into targets (:mod:`perception.pairing`).

Neighbouring targets can merge into one shadow region: runs of neighbouring beams along
which the shadow's first and last rows change smoothly are one target each. A jump in
either (larger than ``JUMP_MIN_SAMPLES`` and than ``JUMP_FRACTION`` of the shorter
shadow) or a beam step wider than ``MAX_BEAM_STEP`` starts a new target.
"""

from __future__ import annotations

import itertools
import operator
from collections.abc import Sequence

#: A shadow's first or last row jumping by more than this (and JUMP_FRACTION) between
#: neighbouring beams separates two targets, samples.
JUMP_MIN_SAMPLES = 24

#: ... and by more than this fraction of the shorter of the two shadow lengths.
JUMP_FRACTION = 0.2

#: Fewest beams of a regrouped target (when its shadow region holds more than one), and
#: of a second pairing of one highlight.
MIN_RUN_BEAMS = 5

#: Neighbouring beams of one target may be this far apart (beams without its highlight).
MAX_BEAM_STEP = 3


def split_runs(cols: Sequence[int], first: Sequence[int], last: Sequence[int]) -> list[tuple[int, int]]:
    """The beams a shadow region received, split into targets (see the module docstring).

    ``cols`` are the beams (increasing), ``first`` and ``last`` the shadow's first and last
    row in them. Returns each run as (start, stop) positions in ``cols``. Plain Python: a
    region holds a few dozen beams, fewer than numpy's call overhead pays for.
    """
    n = len(cols)
    # Only a few beams need the test of a run's start. The median of three values lies
    # between any two of them, so the running medians at k - 1 and k both lie between the
    # raw rows at k - 1 and k (the kept ends too): they differ by at most that raw step,
    # while a jump exceeds at least JUMP_MIN_SAMPLES. A run can start only at such a raw
    # step or after a wide beam step. (The steps are found in C loops: map and compress.)
    maybe: set[int] = set()
    for values in (first, last):
        # Many regions have no such step, which their spread settles at once.
        if max(values) - min(values) > JUMP_MIN_SAMPLES:
            steps = map(abs, map(operator.sub, values[1:], values))
            maybe.update(itertools.compress(range(1, n), map(JUMP_MIN_SAMPLES.__lt__, steps)))
    # The beam steps' excess over 1 sums to cols[-1] - cols[0] - (n - 1): below
    # MAX_BEAM_STEP, no single step exceeds it.
    if cols[-1] - cols[0] - (n - 1) >= MAX_BEAM_STEP:
        steps = map(operator.sub, cols[1:], cols)
        maybe.update(itertools.compress(range(1, n), map(MAX_BEAM_STEP.__lt__, steps)))
    if not maybe:
        return [(0, n)]
    starts = [k for k in sorted(maybe) if _starts_run(cols, first, last, k)]
    if not starts:
        return [(0, n)]
    return [(p0, p1) for p0, p1 in zip([0, *starts], [*starts, n], strict=True) if p1 - p0 >= MIN_RUN_BEAMS]


def _starts_run(cols: Sequence[int], first: Sequence[int], last: Sequence[int], k: int) -> bool:
    """Whether beam ``k`` (a position in ``cols``) starts a new target: a wide beam step from
    the beam before, or a jump of the first or last row's running median of three there
    (the ends of the sequence kept: a single odd beam is not a jump)."""
    if cols[k] - cols[k - 1] > MAX_BEAM_STEP:
        return True
    f0, f1 = _medians3_at(first, k)
    l0, l1 = _medians3_at(last, k)
    limit = max(JUMP_MIN_SAMPLES, JUMP_FRACTION * min(l0 - f0, l1 - f1) + 1)
    return abs(f1 - f0) > limit or abs(l1 - l0) > limit


def _medians3_at(values: Sequence[int], k: int) -> tuple[int, int]:
    """The running medians of three of ``values`` at ``k - 1`` and ``k`` (``k >= 1``), the
    ends kept."""
    a, b = values[k - 1], values[k]
    # The median of three lies between any two of them: both medians lie between a and b,
    # each the third value of its window clamped to [lo, hi].
    lo, hi = (a, b) if a <= b else (b, a)
    if k == 1:
        before = a
    else:
        x = values[k - 2]
        before = lo if x < lo else (hi if x > hi else x)
    if k == len(values) - 1:
        here = b
    else:
        x = values[k + 1]
        here = lo if x < lo else (hi if x > hi else x)
    return before, here
