"""Obstacle-free transits: straight when possible, else the shortest visibility-graph path.

The free region is a shapely (Multi)Polygon in plane coordinates ``(east_m, north_m)``;
its rings (the grown outer boundary and the holes/keep-outs) are barriers that no
transit segment may cross. Graph nodes are the corners of the free region shrunk by a
margin, so paths bend at that distance from obstacle corners. Where a passage is
narrower than twice the margin the shrunk region parts there; a transit the graph
cannot make is then sought again with the nodes a quarter of the margin, and then 1 cm,
from the boundary, before it is declared infeasible.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse.csgraph import shortest_path

from planner.errors import InfeasibleError

FloatArray = NDArray[np.float64]

#: Orientation values smaller than this (m^2) count as collinear.
_EPS = 1e-9


def _pt(p: tuple[float, float] | FloatArray) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _ring_edges(geom: shapely.Geometry) -> FloatArray:
    """All ring edges of a (Multi)Polygon, shape (k, 2, 2)."""
    edges = []
    for poly in shapely.get_parts(geom):
        for ring in [poly.exterior, *poly.interiors]:
            c = np.asarray(ring.coords)[:, :2]
            edges.append(np.stack([c[:-1], c[1:]], axis=1))
    return np.concatenate(edges) if edges else np.zeros((0, 2, 2))


def _ring_vertices(geom: shapely.Geometry) -> FloatArray:
    pts = []
    for poly in shapely.get_parts(geom):
        for ring in [poly.exterior, *poly.interiors]:
            pts.append(np.asarray(ring.coords)[:-1, :2])
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def segments_cross(a: FloatArray, b: FloatArray, edges: FloatArray) -> NDArray[np.bool_]:
    """Which segments ``a[i]-b[i]`` properly cross any of ``edges``; shape (n,).

    ``a``, ``b`` shape (n, 2); ``edges`` shape (k, 2, 2). Touching at an end point does not
    count as crossing.
    """
    if len(edges) == 0 or len(a) == 0:
        return np.zeros(len(a), dtype=bool)
    p1, p2 = a[:, None, :], b[:, None, :]
    q1, q2 = edges[None, :, 0, :], edges[None, :, 1, :]

    def orient(o: FloatArray, u: FloatArray, w: FloatArray) -> FloatArray:
        return (u[..., 0] - o[..., 0]) * (w[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (
            w[..., 0] - o[..., 0]
        )

    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    cross = ((d1 > _EPS) & (d2 < -_EPS) | (d1 < -_EPS) & (d2 > _EPS)) & (
        (d3 > _EPS) & (d4 < -_EPS) | (d3 < -_EPS) & (d4 > _EPS)
    )
    return np.asarray(cross.any(axis=1))


def _touches_vertex(a: FloatArray, b: FloatArray, vertices: FloatArray) -> NDArray[np.bool_]:
    """Which segments ``a[i]-b[i]`` pass through a ring vertex strictly between their ends."""
    if len(vertices) == 0 or len(a) == 0:
        return np.zeros(len(a), dtype=bool)
    d = (b - a)[:, None, :]
    rel = vertices[None, :, :] - a[:, None, :]
    length = np.maximum(1.0, np.hypot(d[..., 0], d[..., 1]))
    on_line = np.abs(d[..., 0] * rel[..., 1] - d[..., 1] * rel[..., 0]) <= _EPS * length
    t = (rel * d).sum(axis=-1) / np.maximum((d * d).sum(axis=-1), 1e-300)
    return np.asarray((on_line & (t > 0.0) & (t < 1.0)).any(axis=1))


@dataclass
class Router:
    """Shortest obstacle-free paths inside a free region (builds its graph on first need).

    Parameters
    ----------
    free : shapely (Multi)Polygon
        Where the vehicle may be, plane coordinates.
    margin_m : float
        Distance of the graph's corners from the region's boundary.
    """

    free: shapely.Geometry
    margin_m: float = 1.0
    _edges: FloatArray = field(init=False, repr=False)
    _vertices: FloatArray = field(init=False, repr=False)
    _graphs: dict[float, tuple[FloatArray, FloatArray, NDArray[np.int32]]] = field(
        init=False, default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self._edges = _ring_edges(self.free)
        self._vertices = _ring_vertices(self.free)
        shapely.prepare(self.free)

    def visible(self, a: FloatArray, b: FloatArray) -> NDArray[np.bool_]:
        """Which straight hops ``a[i] -> b[i]`` (shape (n, 2) each) stay in the free region."""
        return self._visible(np.asarray(a, dtype=float).reshape(-1, 2),
                             np.asarray(b, dtype=float).reshape(-1, 2))

    def _visible(self, a: FloatArray, b: FloatArray) -> NDArray[np.bool_]:
        ok = ~segments_cross(a, b, self._edges)
        mid = 0.5 * (a + b)
        ok &= shapely.intersects_xy(self.free, mid[:, 0], mid[:, 1])
        # A hop that meets the boundary only at ring vertices (a diagonal through a box's
        # two corners) crosses no edge properly, and its midpoint may lie outside the
        # obstacle: between two such touches it is wholly inside or outside the free
        # region, so the middle of every piece between touches decides.
        for i in np.flatnonzero(ok & _touches_vertex(a, b, self._vertices)):
            ok[i] = self._pieces_free(a[i], b[i])
        return np.asarray(ok)

    def _pieces_free(self, a: FloatArray, b: FloatArray) -> bool:
        """Whether every piece of ``a-b`` between its vertex touches lies in the free region."""
        d = b - a
        rel = self._vertices - a
        on = np.abs(d[0] * rel[:, 1] - d[1] * rel[:, 0]) <= _EPS * max(1.0, float(np.hypot(*d)))
        t = rel[on] @ d / float(d @ d)
        cuts = np.unique(np.concatenate([[0.0, 1.0], t[(t > 0.0) & (t < 1.0)]]))
        mids = a + np.outer(0.5 * (cuts[:-1] + cuts[1:]), d)
        return bool(np.all(shapely.intersects_xy(self.free, mids[:, 0], mids[:, 1])))

    def _insets_m(self) -> tuple[float, ...]:
        """The node insets tried in turn, m (see the module docstring)."""
        return tuple(dict.fromkeys((self.margin_m, self.margin_m / 4, 0.01)))

    def _graph(self, inset_m: float) -> tuple[FloatArray, FloatArray, NDArray[np.int32]]:
        """Nodes (corners of the free region shrunk by ``inset_m``, or of the first inset
        after it that leaves something), shortest distances and predecessors (cached)."""
        if inset_m in self._graphs:
            return self._graphs[inset_m]
        nodes = np.zeros((0, 2))
        insets = self._insets_m()
        for m in insets[insets.index(inset_m):]:
            inner = self.free.buffer(-m, quad_segs=1, join_style="mitre", mitre_limit=2.0)
            if not inner.is_empty:
                nodes = _ring_vertices(inner)
                nodes = nodes[shapely.intersects_xy(self.free, nodes[:, 0], nodes[:, 1])]
                break
        n = len(nodes)
        ii, jj = np.triu_indices(n, k=1)
        vis = self._visible(nodes[ii], nodes[jj]) if n > 1 else np.zeros(0, dtype=bool)
        w = np.zeros((n, n))
        d = np.hypot(*(nodes[ii] - nodes[jj]).T) if n > 1 else np.zeros(0)
        w[ii[vis], jj[vis]] = d[vis]
        w[jj[vis], ii[vis]] = d[vis]
        dist, pred = shortest_path(w, method="D", directed=False, return_predecessors=True)
        self._graphs[inset_m] = (nodes, dist, pred)
        return self._graphs[inset_m]

    def route(self, start: tuple[float, float], goal: tuple[float, float]) -> list[tuple[float, float]]:
        """Points from ``start`` to ``goal`` (both included) along free straight segments.

        Raises
        ------
        InfeasibleError
            When the two points are not connected inside the free region.
        """
        a = np.asarray([start], dtype=float)
        b = np.asarray([goal], dtype=float)
        if self._visible(a, b)[0]:
            return [_pt(start), _pt(goal)]
        for inset in self._insets_m():
            nodes, dist, pred = self._graph(inset)
            n = len(nodes)
            if n == 0:
                continue
            vis_a = self._visible(np.repeat(a, n, axis=0), nodes)
            vis_b = self._visible(nodes, np.repeat(b, n, axis=0))
            da = np.where(vis_a, np.hypot(*(nodes - a).T), np.inf)
            db = np.where(vis_b, np.hypot(*(nodes - b).T), np.inf)
            total = da[:, None] + dist + db[None, :]
            i, j = np.unravel_index(int(np.argmin(total)), total.shape)
            if np.isfinite(total[i, j]):
                chain = [int(j)]
                while chain[-1] != i:
                    chain.append(int(pred[i, chain[-1]]))
                chain.reverse()
                return [_pt(start)] + [_pt(nodes[k]) for k in chain] + [_pt(goal)]
        raise InfeasibleError(
            f"no obstacle-free transit from ({start[0]:.1f}, {start[1]:.1f}) to "
            f"({goal[0]:.1f}, {goal[1]:.1f}) m: they lie in separate parts of the free region"
        )
