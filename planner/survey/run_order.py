"""Order of the lane runs of one pass: boustrophedon cells, lawnmower inside each.

Works in the lane frame ``(u, v)`` of :mod:`planner.survey.lawnmower` (lanes along ``u``). A
:class:`Piece` is ground ``[a, b]`` of lane ``k`` to cover; an :class:`Option` is one way
to fly it (its runs in flying order). :func:`order_runs` picks one option per piece and
their order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Piece:
    """Ground ``[a, b]`` (u) of lane ``k`` (at ``v``) to cover."""

    k: int
    v: float
    a: float
    b: float


@dataclass(frozen=True)
class Option:
    """One way to fly a piece: its runs in flying order, the lane length (m) it leaves
    unseen beyond what the piece's best option leaves, and the length (m) it flies, runs
    and the hops between them, beyond one pass over the piece (a run back over ground
    that one direction misses, :mod:`planner.survey.lane_options`)."""

    piece: int
    runs: tuple[tuple[FloatArray, FloatArray], ...]  # (start_uv, end_uv) in flying order
    extra_loss_m: float
    extra_run_m: float = 0.0


#: Metres of transit that one metre of lane left unseen is worth when ordering runs.
LOSS_PENALTY = 5.0


def _cells(pieces: list[Piece]) -> list[list[int]]:
    """Boustrophedon cells: chains of pieces on consecutive lanes that overlap one to one.

    A piece joins the cell of the piece below it when each is the other's only overlapping
    neighbour; where a lane splits or merges (at an obstacle or a notch) a new cell
    begins. Returns piece indices per cell, in lane order.
    """
    by_lane: dict[int, list[int]] = {}
    for i, p in enumerate(pieces):
        by_lane.setdefault(p.k, []).append(i)

    def touching(i: int, lane: int) -> list[int]:
        a, b = pieces[i].a, pieces[i].b
        return [j for j in by_lane.get(lane, []) if pieces[j].a < b and a < pieces[j].b]

    cell_of: dict[int, int] = {}
    cells: list[list[int]] = []
    for i in sorted(range(len(pieces)), key=lambda i: (pieces[i].k, pieces[i].a)):
        below = touching(i, pieces[i].k - 1)
        if len(below) == 1 and len(touching(below[0], pieces[i].k)) == 1:
            c = cell_of[below[0]]
        else:
            c = len(cells)
            cells.append([])
        cells[c].append(i)
        cell_of[i] = c
    return cells


def _order_cells(options: list[list[Option]], pieces: list[Piece],
                 start_uv: FloatArray | None, loss_budget_m: float) -> list[Option]:
    """Order the runs: cell by cell (the cheapest cell end to enter next), each cell as a
    lawnmower over its lanes. Each piece is flown once, in the direction of cheapest
    start, cost = distance + LOSS_PENALTY x lane length it leaves unseen beyond the
    better direction; such losses are allowed while ``loss_budget_m`` of lane lasts."""
    cells = [c for c in ([i for i in cell if options[i]] for cell in _cells(pieces)) if c]
    if not cells:
        return []
    budget = loss_budget_m
    if start_uv is None:
        starts = [(o.runs[0][0][1], o.runs[0][0][0], i) for i, opts in enumerate(options)
                  for o in opts if o.extra_loss_m <= 1e-6]
        v, u, _ = min(starts)
        here = np.array([u, v])
    else:
        here = np.asarray(start_uv, dtype=float)

    def pick(i: int, here: FloatArray) -> tuple[float, Option]:
        best: tuple[float, Option] | None = None
        for o in options[i]:
            if o.extra_loss_m > 1e-6 and o.extra_loss_m > budget:
                continue
            cost = float(np.hypot(*(o.runs[0][0] - here))) + LOSS_PENALTY * o.extra_loss_m + o.extra_run_m
            if best is None or cost < best[0]:
                best = (cost, o)
        if best is None:  # the better direction always loses nothing extra
            o = min(options[i], key=lambda o: o.extra_loss_m)
            best = (float(np.hypot(*(o.runs[0][0] - here))), o)
        return best

    order: list[Option] = []
    remaining = set(range(len(cells)))
    while remaining:
        entries = [(pick(seq[0], here)[0], c, seq) for c in sorted(remaining)
                   for seq in (cells[c], cells[c][::-1])]
        _, c, seq = min(entries, key=lambda e: e[0])
        remaining.discard(c)
        for i in seq:
            _, opt = pick(i, here)
            order.append(opt)
            budget -= max(opt.extra_loss_m, 0.0)
            here = opt.runs[-1][1]
    return order


def _order_greedy(options: list[list[Option]], start_uv: FloatArray | None,
                  loss_budget_m: float) -> list[Option]:
    """Nearest-next order over all pieces (same costs as :func:`_order_cells`)."""
    flat = [(i, o) for i, opts in enumerate(options) for o in opts]
    if not flat:
        return []
    starts = np.array([o.runs[0][0] for _, o in flat])
    owner = np.array([i for i, _ in flat])
    loss = np.array([o.extra_loss_m for _, o in flat])
    extra_run = np.array([o.extra_run_m for _, o in flat])
    free = loss <= 1e-6
    done = np.zeros(len(options), dtype=bool)
    if start_uv is None:
        cand = np.where(free)[0]
        j = int(cand[np.lexsort((starts[cand, 0], starts[cand, 1]))[0]])
    else:
        j = int(np.argmin(np.hypot(*(starts - start_uv).T) + np.where(free, 0.0, np.inf)))
    order = []
    budget = loss_budget_m
    while True:
        i, opt = flat[j]
        order.append(opt)
        done[i] = True
        budget -= max(opt.extra_loss_m, 0.0)
        here = opt.runs[-1][1]
        cost = np.hypot(*(starts - here).T) + LOSS_PENALTY * loss + extra_run
        cost[done[owner] | (loss > budget + 1e-9)] = np.inf
        j = int(np.argmin(cost))
        if not np.isfinite(cost[j]):
            return order


def _order_cost(order: list[Option], start_uv: FloatArray | None, n_pieces: int) -> float:
    """Straight-hop length between the options of an order plus their extra runs and loss
    penalty (one pass over each piece is common to all orders); infinite for an order that
    misses a piece."""
    if len({o.piece for o in order}) != n_pieces:
        return float("inf")
    if not order:
        return 0.0
    ends = np.array([o.runs[-1][1] for o in order])
    starts = np.array([o.runs[0][0] for o in order])
    hops = float(np.hypot(*(starts[1:] - ends[:-1]).T).sum())
    if start_uv is not None:
        hops += float(np.hypot(*(order[0].runs[0][0] - np.asarray(start_uv, dtype=float))))
    return hops + sum(LOSS_PENALTY * o.extra_loss_m + o.extra_run_m for o in order)


def order_runs(options: list[list[Option]], pieces: list[Piece], start_uv: FloatArray | None,
               loss_budget_m: float) -> list[Option]:
    """The cheaper of the cell-by-cell and the nearest-next orders."""
    cands = [_order_cells(options, pieces, start_uv, loss_budget_m),
             _order_greedy(options, start_uv, loss_budget_m)]
    n_pieces = sum(1 for opts in options if opts)
    best = min(cands, key=lambda o: _order_cost(o, start_uv, n_pieces))
    if len({o.piece for o in best}) != n_pieces:
        raise RuntimeError("run ordering missed a piece")  # a bug, not bad input
    return best
