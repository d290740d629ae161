"""Regrouping the beams a shadow region received into targets (:mod:`perception.shadows.pairing.pair`).

Neighbouring targets can merge into one shadow region: runs of neighbouring beams along
which the shadow's first and last rows change smoothly are one target each. A jump in
either (larger than ``JUMP_MIN_M`` of range and than ``JUMP_FRACTION`` of the shorter
shadow) or a beam step wider than ``MAX_BEAM_STEP`` starts a new target.
"""

from __future__ import annotations

from collections.abc import Sequence

#: A shadow's first or last row jumping by more than this (and JUMP_FRACTION) between
#: neighbouring beams separates two targets, m of range.
JUMP_MIN_M = 0.04

#: ... and by more than this fraction of the shorter of the two shadow lengths.
JUMP_FRACTION = 0.2

#: Fewest beams of a regrouped target (when its shadow region holds more than one).
MIN_RUN_BEAMS = 4

#: Neighbouring beams of one target may be this far apart (beams without its highlight).
MAX_BEAM_STEP = 3


def split_runs(
    cols: Sequence[int], first: Sequence[int], last: Sequence[int], *, jump_rows: float,
    min_beams: int = 5,
) -> list[tuple[int, int]]:
    """The beams a shadow region received, split into targets (see the module docstring).

    ``cols`` are the beams (increasing), ``first`` and ``last`` the shadow's first and last
    row in them, ``jump_rows`` :data:`JUMP_MIN_M` in rows of the frame. Returns each run as
    (start, stop) positions in ``cols``; when there are several, runs of fewer than
    ``min_beams`` beams are dropped. Plain Python: a region holds a few dozen beams,
    fewer than numpy's call overhead pays for.
    """
    n = len(cols)
    # The beam steps' excess over 1 sums to cols[-1] - cols[0] - (n - 1): below
    # MAX_BEAM_STEP, no single step exceeds it.
    wide_steps = cols[-1] - cols[0] - (n - 1) >= MAX_BEAM_STEP
    # Only a few beams need the test of a jump. The median of three values lies between
    # any two of them, so the running medians at k - 1 and k both lie between the raw rows
    # at k - 1 and k (the kept ends too): they differ by at most that raw step, while a
    # jump exceeds at least jump_rows. (One plain loop over the beams: cheaper here
    # than chains of map and compress, whose objects cost more than a few dozen steps.)
    starts = []
    f0, l0 = first[0], last[0]
    for k in range(1, n):
        f1, l1 = first[k], last[k]
        if (wide_steps and cols[k] - cols[k - 1] > MAX_BEAM_STEP) or (
            (f1 - f0 > jump_rows or f0 - f1 > jump_rows or l1 - l0 > jump_rows
             or l0 - l1 > jump_rows)
            and _jumps_at(first, last, k, jump_rows)
        ):
            starts.append(k)
        f0, l0 = f1, l1
    if not starts:
        return [(0, n)]
    return [(p0, p1) for p0, p1 in zip([0, *starts], [*starts, n], strict=True) if p1 - p0 >= min_beams]


def _jumps_at(first: Sequence[int], last: Sequence[int], k: int, jump_rows: float) -> bool:
    """Whether the running median of three of the first or the last rows jumps from beam
    ``k - 1`` to beam ``k`` (positions, ``k >= 1``; the ends of the sequence kept: a single
    odd beam is not a jump)."""
    n = len(first)
    # The median of three lies between any two of them: both medians lie between the raw
    # values at k - 1 and k, each the third value of its window clamped to them (at an end
    # the kept value, already between them). Inline, without helpers' calls or min/max:
    # this runs for every raw step above jump_rows.
    a, b = first[k - 1], first[k]
    lo, hi = (a, b) if a <= b else (b, a)
    x = first[k - 2] if k > 1 else a
    f0 = lo if x < lo else (hi if x > hi else x)
    x = first[k + 1] if k < n - 1 else b
    f1 = lo if x < lo else (hi if x > hi else x)
    a, b = last[k - 1], last[k]
    lo, hi = (a, b) if a <= b else (b, a)
    x = last[k - 2] if k > 1 else a
    l0 = lo if x < lo else (hi if x > hi else x)
    x = last[k + 1] if k < n - 1 else b
    l1 = lo if x < lo else (hi if x > hi else x)
    # max(jump_rows, JUMP_FRACTION * (the shorter shadow) + 1)
    limit = JUMP_FRACTION * (l0 - f0 if l0 - f0 < l1 - f1 else l1 - f1) + 1
    if limit <= jump_rows:
        limit = jump_rows
    return f1 - f0 > limit or f0 - f1 > limit or l1 - l0 > limit or l0 - l1 > limit
