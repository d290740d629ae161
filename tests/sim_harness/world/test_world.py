"""The seabed world: depth, slope, relief, materials, target placement and ray hits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_harness.world.errors import WorldError
from sim_harness.world.materials import MATERIALS, Material
from sim_harness.world.relief import Relief
from sim_harness.world.shapes import BoxSolid, CompositeSolid, CylinderSolid, EllipsoidSolid, intersect_batch
from sim_harness.world.world import Seabed, TargetSpec, World


def test_sloped_seabed_deepens_towards_its_direction() -> None:
    world = World(Seabed(10.0, slope_rad=math.radians(5.0), slope_direction_rad=math.radians(90.0)))
    assert world.seabed_depth_m(0.0, 0.0) == pytest.approx(10.0)
    assert world.seabed_depth_m(0.0, 10.0) == pytest.approx(10.0 + 10.0 * math.tan(math.radians(5.0)))
    assert world.seabed_depth_m(7.0, 0.0) == pytest.approx(10.0, abs=1e-12)
    normal = world.seabed_normal_ned(3.0, 4.0)
    assert np.linalg.norm(normal) == pytest.approx(1.0)
    assert normal[2] == pytest.approx(-math.cos(math.radians(5.0)))  # points up
    assert normal[1] > 0  # tilted towards the deeper side


def test_relief_stays_within_its_amplitude_and_is_gentle() -> None:
    relief = Relief(0.05, 5.0, seed=3)
    n, e = np.meshgrid(np.linspace(-20, 20, 201), np.linspace(-20, 20, 201))
    h = relief.height_m(n, e)
    assert np.max(np.abs(h)) <= 0.05 + 1e-12
    assert np.std(h) > 0.005  # it is really there
    gn, ge = relief.gradient(n, e)
    # the analytic gradient matches finite differences
    eps = 1e-6
    fd = (relief.height_m(n + eps, e) - relief.height_m(n - eps, e)) / (2 * eps)
    np.testing.assert_allclose(gn, fd, atol=1e-7)
    assert np.max(np.hypot(gn, ge)) <= 0.25


def test_steep_relief_is_refused() -> None:
    with pytest.raises(WorldError, match="gentle"):
        Relief(0.5, 1.0)


def test_world_rejects_unknown_material_and_duplicate_ids() -> None:
    with pytest.raises(WorldError, match="unknown material 'unobtainium'"):
        World(Seabed(5.0, material="unobtainium"))
    spec = TargetSpec("a", "box", 1.0, 0.0, 0.1, 0.1, 0.05)
    with pytest.raises(WorldError, match="duplicate target id 'a'"):
        World(Seabed(5.0), (spec, spec))
    with pytest.raises(WorldError, match="height_m"):
        TargetSpec("b", "box", 1.0, 0.0, 0.1, 0.1, -0.05)
    with pytest.raises(WorldError, match="unknown shape"):
        TargetSpec("c", "pyramid", 1.0, 0.0, 0.1, 0.1, 0.05)


def test_targets_rest_on_the_seabed_under_their_centre() -> None:
    seabed = Seabed(8.0, slope_rad=math.radians(3.0), slope_direction_rad=0.0, relief=Relief(0.02, 4.0, seed=1))
    world = World(seabed, (TargetSpec("t", "box", 5.0, 2.0, 0.3, 0.2, 0.1),))
    placed = world.target("t")
    assert placed.base_depth_m == pytest.approx(world.seabed_depth_m(5.0, 2.0))
    assert placed.top_depth_m == pytest.approx(placed.base_depth_m - 0.1)


def test_material_scattering_lambert_and_specular() -> None:
    sand = MATERIALS["sand"]
    mu = 10 ** (sand.backscatter_db / 10)
    # Lambert: sigma = mu cos^2, so sigma / cos = mu cos
    np.testing.assert_allclose(sand.sigma_over_cos([1.0, 0.5, 0.0]), [mu, mu * 0.5, 0.0])
    smooth = Material("mirror", -20.0, 0.0)
    values = smooth.sigma_over_cos(np.cos(np.radians([0.0, 10.0, 40.0])))
    assert values[0] > values[1] > values[2] > 0
    assert values[2] < 1e-3 * values[0]  # the specular lobe is narrow


def test_box_hit_from_above_known_answer() -> None:
    box = BoxSolid(0.0, 0.0, 10.0, 1.0, 0.5, 0.2, 0.0, 0.05)
    origin = np.array([0.1, 0.1, 5.0])
    t, n = box.intersect(origin, np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]))
    assert t[0] == pytest.approx(10.0 - 0.2 - 5.0)
    np.testing.assert_allclose(n[0], [0.0, 0.0, -1.0])
    assert math.isinf(t[1])


def test_cylinder_side_and_cap_hits() -> None:
    cyl = CylinderSolid(0.0, 0.0, 2.0, 0.5, 0.4, 0.05)
    origin = np.array([-3.0, 0.0, 1.8])
    t, n = cyl.intersect(origin, np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    assert t[0] == pytest.approx(2.5)
    np.testing.assert_allclose(n[0], [-1.0, 0.0, 0.0], atol=1e-12)
    assert math.isinf(t[1])
    t2, n2 = cyl.intersect(np.array([0.2, 0.0, 0.0]), np.array([[0.0, 0.0, 1.0]]))
    assert t2[0] == pytest.approx(1.6)
    np.testing.assert_allclose(n2[0], [0.0, 0.0, -1.0])


unit = st.floats(-1.0, 1.0)


@settings(max_examples=60, deadline=None)
@given(unit, unit, unit, st.floats(0.0, math.pi))
def test_ellipsoid_hits_lie_on_its_surface(dx: float, dy: float, dz: float, yaw: float) -> None:
    d = np.array([[dx, dy, abs(dz) + 0.3]])
    d /= np.linalg.norm(d)
    ell = EllipsoidSolid(0.0, 0.0, 3.0, 0.6, 0.3, 0.2, yaw)
    origin = np.array([0.0, 0.0, 3.0]) - 2.0 * d[0]
    t, n = ell.intersect(origin, d)
    assert np.isfinite(t[0])  # aimed at the centre: always a hit
    p = origin + t[0] * d[0] - np.array([0.0, 0.0, 3.0])
    c, s = math.cos(yaw), math.sin(yaw)
    u, v = c * p[0] + s * p[1], -s * p[0] + c * p[1]
    assert (u / 0.3) ** 2 + (v / 0.15) ** 2 + (p[2] / 0.2) ** 2 == pytest.approx(1.0, abs=1e-9)
    assert float(n[0] @ d[0]) < 0  # the normal faces the ray


@settings(max_examples=60, deadline=None)
@given(unit, unit, unit, unit, unit, st.floats(0.0, math.pi))
def test_box_first_hit_is_on_the_surface_and_nothing_is_skipped(
    ox: float, oy: float, dx: float, dy: float, dz: float, yaw: float
) -> None:
    box = BoxSolid(0.0, 0.0, 2.0, 0.8, 0.4, 0.3, yaw, 0.05)
    origin = np.array([2.0 * ox, 2.0 * oy, 0.5])
    d = np.array([[dx, dy, dz]])
    if np.linalg.norm(d) < 1e-3:
        return
    d /= np.linalg.norm(d)
    t, _ = box.intersect(origin, d)
    c, s = math.cos(yaw), math.sin(yaw)

    def inside(p: np.ndarray, tol: float = 0.0) -> np.ndarray:
        q = p - np.array([0.0, 0.0, 2.0])
        u = c * q[:, 0] + s * q[:, 1]
        v = -s * q[:, 0] + c * q[:, 1]
        return (
            (np.abs(u) <= 0.4 + tol) & (np.abs(v) <= 0.2 + tol) & (q[:, 2] >= -0.3 - tol) & (q[:, 2] <= 0.05 + tol)
        )

    ts = np.linspace(0.0, 6.0, 6001)
    samples = origin + ts[:, None] * d[0]
    inn = inside(samples)
    if math.isfinite(t[0]):  # a reported hit lies on the box (within rounding)
        assert inside((origin + t[0] * d[0])[None], tol=1e-9)[0]
    if not np.any(inn):  # the samples may only miss a sliver thinner than their spacing
        assert math.isinf(t[0]) or t[0] <= 6.0
        return
    first = ts[np.argmax(inn)]
    assert t[0] == pytest.approx(first, abs=1.5e-3)


def _scattered_rays(world: World, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origin, solid index per ray, unit directions) aimed near the world's targets."""
    origin = np.array([-2.0, 0.3, 4.0]) + rng.normal(0.0, 0.2, 3)
    which = rng.integers(0, len(world.placed), n)
    centres = np.array([[p.spec.north_m, p.spec.east_m, p.base_depth_m - 0.1] for p in world.placed])[which]
    d = centres - origin + rng.normal(0.0, 0.15, (n, 3))
    return origin, which, d / np.linalg.norm(d, axis=1)[:, None]


@settings(max_examples=15, deadline=None)
@given(st.lists(st.sampled_from(["box", "cylinder", "stone", "rock"]), min_size=1, max_size=7), st.integers(0, 2**31))
def test_batched_intersections_equal_each_solids_own(shapes: list[str], seed: int) -> None:
    rng = np.random.default_rng(seed)
    specs = tuple(
        TargetSpec(f"t{i}", shape, rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.1, 0.5), rng.uniform(0.1, 0.5),
                   rng.uniform(0.05, 0.4), yaw_rad=rng.uniform(-3, 3), seed=i)
        for i, shape in enumerate(shapes)
    )
    world = World(Seabed(5.0), specs)
    solids = [p.solid for p in world.placed]
    origin, which, d = _scattered_rays(world, rng, 3000)
    for normals in (True, False):
        t, n = intersect_batch(solids, which, origin, d, normals=normals)
        for i, solid in enumerate(solids):
            idx = np.flatnonzero(which == i)
            t_i, n_i = solid.intersect(origin, d[idx], normals=normals)
            np.testing.assert_array_equal(t[idx], t_i)  # bit for bit, misses (inf) included
            if normals:
                np.testing.assert_array_equal(n[idx], n_i)
    assert np.any(np.isfinite(t))  # the rays do meet the solids


def test_a_rock_is_hit_where_its_nearest_lobe_is(rng: np.random.Generator) -> None:
    world = World(Seabed(5.0), (TargetSpec("r", "rock", 0.2, -0.1, 0.6, 0.4, 0.3, yaw_rad=0.7, seed=4),))
    rock = world.placed[0].solid
    assert isinstance(rock, CompositeSolid) and len(rock.lobes) >= 3
    origin, _, d = _scattered_rays(world, rng, 4000)
    t, n = rock.intersect(origin, d)
    per_lobe = np.array([lobe.intersect(origin, d)[0] for lobe in rock.lobes])
    np.testing.assert_array_equal(t, per_lobe.min(axis=0))
    hit = np.isfinite(t)
    assert 0.1 < hit.mean() < 0.9
    win = np.argmin(per_lobe, axis=0)
    for i, lobe in enumerate(rock.lobes):
        idx = np.flatnonzero(hit & (win == i))
        if idx.size:
            np.testing.assert_allclose(n[idx], lobe.intersect(origin, d[idx])[1], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(n[hit], axis=1), 1.0)


def test_relief_in_float32_stays_within_a_micrometre(rng: np.random.Generator) -> None:
    relief = Relief(0.05, 5.0, seed=3)
    n, e = rng.uniform(-100, 100, 2000), rng.uniform(-100, 100, 2000)
    h64, gn64, ge64 = relief.height_and_gradient(n, e)
    h32, gn32, ge32 = relief.height_and_gradient(n, e, dtype=np.float32)
    assert h32.dtype == np.float32
    np.testing.assert_allclose(h32, h64, atol=1e-6)
    np.testing.assert_allclose(gn32, gn64, atol=1e-5)
    np.testing.assert_allclose(ge32, ge64, atol=1e-5)
    np.testing.assert_array_equal(relief.height_m(n, e), h64)


@settings(max_examples=40, deadline=None)
@given(
    n_components=st.integers(1, 32),
    rows=st.integers(1, 4),
    cols=st.integers(1, 5),
    seed=st.integers(0, 1000),
    float32=st.booleans(),
)
def test_relief_equals_its_sinusoids_summed_in_order(
    n_components: int, rows: int, cols: int, seed: int, float32: bool
) -> None:
    # every point (broadcast (rows, 1) x (cols,), and a single point) is the sum of the
    # components in their order, bit for bit, as a per-point loop computes it
    relief = Relief(0.002, 20.0, seed=seed, n_components=n_components)
    rng = np.random.default_rng(seed)
    n, e = rng.uniform(-50, 50, (rows, 1)), rng.uniform(-50, 50, cols)
    dtype = np.float32 if float32 else np.float64
    h, gn, ge = relief.height_and_gradient(n, e, dtype=dtype)
    heights = relief.height_m(n, e)
    assert h.shape == gn.shape == ge.shape == heights.shape == (rows, cols)
    assert h.dtype == dtype and heights.dtype == np.float64
    a, k, phase = relief._a, relief._k, relief._phase  # the seeded components
    for i in range(rows):
        for j in range(cols):
            ni, ej = dtype(n[i, 0]), dtype(e[j])
            want = [dtype(0.0)] * 3
            want64 = 0.0
            for c in range(n_components):
                ac, kn, ke, ph = dtype(a[c]), dtype(k[c, 0]), dtype(k[c, 1]), dtype(phase[c])
                arg = ni * kn + ej * ke + ph
                s = -ac * np.sin(arg)
                want = [want[0] + ac * np.cos(arg), want[1] + s * kn, want[2] + s * ke]
                want64 += a[c] * np.cos(n[i, 0] * k[c, 0] + e[j] * k[c, 1] + phase[c])
            assert [h[i, j], gn[i, j], ge[i, j]] == want
            assert heights[i, j] == want64
    assert float(relief.height_m(n[0, 0], e[0])) == heights[0, 0]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), n_components=st.integers(1, 32),
       points=st.lists(st.tuples(st.floats(-2000, 2000), st.floats(-2000, 2000)), min_size=1, max_size=20))
def test_relief_at_one_point_is_the_array_answer_bit_for_bit(seed, n_components, points) -> None:
    """The simulator asks the relief at one point every step (``Relief.height_at_m``, also
    what ``height_m`` answers for scalars): the same float64 as the array path, so a
    vehicle's true altitude and the renderer's seabed never disagree in the last bit."""
    relief = Relief(amplitude_m=0.05, wavelength_m=4.0, seed=seed, n_components=n_components)
    north, east = (np.array(c, dtype=np.float64) for c in zip(*points, strict=True))
    expected = relief.height_m(north, east)
    for (n, e), h in zip(points, expected, strict=True):
        assert relief.height_at_m(n, e) == h
        assert relief.height_m(n, e) == h and relief.height_m(np.float64(n), e) == h
