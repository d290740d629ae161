"""A pipe section lying on the seabed: ray hits against the geometry worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim_harness.world.pipe import PipeSolid
from sim_harness.world.world import Seabed, TargetSpec, World

PIPE = PipeSolid(north_m=5.0, east_m=0.0, base_depth_m=10.0, length_m=2.0, radius_m=0.15, yaw_rad=math.pi / 2)


def _ray(origin, target):
    d = np.asarray(target, dtype=float) - np.asarray(origin, dtype=float)
    return np.asarray(origin, dtype=float), (d / np.linalg.norm(d))[None, :]


def test_a_ray_down_onto_the_crown_hits_its_top() -> None:
    origin, d = _ray((5.0, 0.3, 8.0), (5.0, 0.3, 11.0))
    t, n = PIPE.intersect(origin, d)
    assert t[0] == pytest.approx(2.0 - 0.3)  # the crown is 0.3 m above the 10 m seabed
    np.testing.assert_allclose(n[0], (0.0, 0.0, -1.0), atol=1e-12)


def test_a_grazing_ray_across_the_pipe_meets_its_near_side() -> None:
    # from the south, at the axis depth: the near side is 0.15 m south of the axis
    origin, d = _ray((3.0, 0.5, 9.85), (7.0, 0.5, 9.85))
    t, n = PIPE.intersect(origin, d)
    assert t[0] == pytest.approx(5.0 - 0.15 - 3.0)
    np.testing.assert_allclose(n[0], (-1.0, 0.0, 0.0), atol=1e-12)


def test_rays_past_the_ends_or_above_miss_and_the_end_disc_is_hit() -> None:
    origin, d = _ray((5.0, 3.0, 8.0), (5.0, 3.0, 11.0))  # past the east end (the pipe runs east)
    assert np.isinf(PIPE.intersect(origin, d)[0][0])
    origin, d = _ray((5.0, 4.0, 9.85), (5.0, -4.0, 9.85))  # along the axis from the east
    t, n = PIPE.intersect(origin, d)
    assert t[0] == pytest.approx(3.0)
    np.testing.assert_allclose(n[0], (0.0, 1.0, 0.0), atol=1e-12)


def test_a_scene_pipe_stands_its_diameter_tall_on_the_seabed() -> None:
    world = World(Seabed(depth_m=10.0), (TargetSpec("P", "pipe", 5.0, 0.0, 2.0, 0.3, 0.3, yaw_rad=math.pi / 2),))
    (placed,) = world.placed
    origin, d = _ray((5.0, 0.0, 8.0), (5.0, 0.0, 11.0))
    t, _ = placed.solid.intersect(origin, d)
    assert t[0] == pytest.approx(2.0 - 0.3)
