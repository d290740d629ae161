"""The ways to fly one lane piece: forward, backward, or one way and then back over what it missed.

Works in the lane frame ``(u, v)`` of :mod:`planner.survey.lawnmower` (lanes along ``+u``).
The forward-looking band sees ground from ``g_near`` ahead, so the vehicle at ``s``
flying ``+u`` has seen the ground up to ``s + g_near`` whole (its near edge has passed
it); covering ``[a, b]`` flying ``+u`` takes the vehicle over ``[a - g_near, b - g_near]``,
flying ``-u`` over ``[a + g_near, b + g_near]``. Those runs are cut to the free region;
a run that starts at an obstacle (its lead-in would be over it) or at the edge of a
stay-inside region misses the ground just past its start.

Each piece gets up to six options (:class:`planner.survey.run_order.Option`): each
direction alone, and, where a direction misses ground that the other can see, that
direction with a short run the other way over just the missed ground (before or after
it: the order picks the cheaper entry and exit). A piece between two obstacles or
between an obstacle and the edge, which loses ground at whichever end it starts, is so
seen whole for the cost of a run about as long as the ground it would lose, not a
second run over the whole piece.
"""

from __future__ import annotations

import math

import numpy as np

from planner.survey.run_order import FloatArray, Option, Piece

Interval = tuple[float, float]

#: Runs shorter than this are dropped (m); less ground won than this is no gain.
MIN_RUN_M = 1e-3


def clip(lo: float, hi: float, free: list[Interval]) -> list[Interval]:
    """The parts of ``[lo, hi]`` inside the ``free`` intervals, each longer than ``MIN_RUN_M``."""
    return [(max(lo, f0), min(hi, f1)) for f0, f1 in free if min(hi, f1) - max(lo, f0) > MIN_RUN_M]


def union(ivs: list[Interval]) -> list[Interval]:
    """Sorted, merged intervals."""
    merged: list[Interval] = []
    for lo, hi in sorted(ivs):
        if merged and lo <= merged[-1][1] + 1e-9:
            merged[-1] = (merged[-1][0], max(merged[-1][1], hi))
        else:
            merged.append((lo, hi))
    return merged


def minus(lo: float, hi: float, ivs: list[Interval]) -> list[Interval]:
    """The parts of ``[lo, hi]`` outside the intervals, each longer than ``MIN_RUN_M``."""
    out, at = [], lo
    for a, b in union(ivs):
        if a - at > MIN_RUN_M:
            out.append((at, min(a, hi)))
        at = max(at, b)
    if hi - at > MIN_RUN_M:
        out.append((at, hi))
    return [(a, b) for a, b in out if b - a > MIN_RUN_M]


def length(ivs: list[Interval]) -> float:
    """Total length the intervals cover (overlaps once)."""
    return float(sum(b - a for a, b in union(ivs)))


def seen_by(runs: tuple[tuple[FloatArray, FloatArray], ...], g_near: float, piece: Piece) -> list[Interval]:
    """The ground of ``piece`` that the near edge of the band passes over on ``runs``."""
    ivs = []
    for start, end in runs:
        s, e = float(start[0]), float(end[0])
        shift = math.copysign(g_near, e - s)
        ivs.append((max(min(s, e) + shift, piece.a), min(max(s, e) + shift, piece.b)))
    return union([(a, b) for a, b in ivs if b > a])


def _runs(ivs: list[Interval], v: float, sign: int) -> tuple[tuple[FloatArray, FloatArray], ...]:
    """Runs over the vehicle positions ``ivs`` in flying order, ``+u`` (sign 1) or ``-u``."""
    ordered = ivs if sign > 0 else [(hi, lo) for lo, hi in reversed(ivs)]
    return tuple((np.array([s, v]), np.array([e, v])) for s, e in ordered)


def _path_m(runs: tuple[tuple[FloatArray, FloatArray], ...]) -> float:
    """Length of the runs along the lane and of the hops between them."""
    us = [float(p[0]) for run in runs for p in run]
    return sum(abs(b - a) for a, b in zip(us, us[1:], strict=False))


def piece_options(pieces: list[Piece], free_iv: list[list[Interval]], g_near: float) -> list[list[Option]]:
    """Every way to fly each piece (see the module docstring). An option's ``extra_loss_m``
    is the ground it leaves unseen beyond the best option of its piece; ``extra_run_m``
    is what it flies (runs and the hops between them) beyond its one direction alone."""
    out: list[list[Option]] = []
    for i, p in enumerate(pieces):
        fr = free_iv[i]
        dirs = {1: clip(p.a - g_near, p.b - g_near, fr), -1: clip(p.a + g_near, p.b + g_near, fr)}
        ways: list[tuple[tuple[tuple[FloatArray, FloatArray], ...], float, float]] = []
        for sign, ivs in dirs.items():
            if not ivs:
                continue
            runs = _runs(ivs, p.v, sign)
            seen = seen_by(runs, g_near, p)
            ways.append((runs, length(seen), 0.0))
            # The other way over what this one misses: positions shifted by the lead-in.
            missing = minus(p.a, p.b, seen)
            back = union([iv for m0, m1 in missing for iv in clip(m0 + sign * g_near, m1 + sign * g_near, fr)])
            if not back:
                continue
            back_runs = _runs(back, p.v, -sign)
            both = length(seen + seen_by(back_runs, g_near, p))
            if both - length(seen) <= MIN_RUN_M:
                continue
            alone = _path_m(runs)
            for combo in (back_runs + runs, runs + back_runs):
                ways.append((combo, both, _path_m(combo) - alone))
        best = max((seen_m for _, seen_m, _ in ways), default=0.0)
        out.append([Option(i, runs, 0.0 if best - seen_m <= 1e-6 else best - seen_m, extra)
                    for runs, seen_m, extra in ways])
    return out


def unseen(piece: Piece, options: list[Option], g_near: float) -> list[Interval]:
    """The ground of ``piece`` that none of its options sees."""
    return minus(piece.a, piece.b, [iv for o in options for iv in seen_by(o.runs, g_near, piece)])
