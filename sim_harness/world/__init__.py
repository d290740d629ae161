"""The simulated seabed world: seabed, relief, texture and target solids."""

from sim_harness.world.errors import PoseError, SceneError, SonarConfigError, WorldError
from sim_harness.world.shapes import (
    BoxSolid,
    CompositeSolid,
    CylinderSolid,
    EllipsoidSolid,
    intersect_batch,
    solid_kinds,
)
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import (
    MATERIALS,
    SHAPES,
    SPECULAR_GAIN,
    SPECULAR_WIDTH_RAD,
    Material,
    PlacedTarget,
    Relief,
    Seabed,
    TargetSpec,
    World,
)

__all__ = [
    "BoxSolid",
    "CompositeSolid",
    "CylinderSolid",
    "EllipsoidSolid",
    "MATERIALS",
    "Material",
    "PlacedTarget",
    "PoseError",
    "Relief",
    "SHAPES",
    "SPECULAR_GAIN",
    "SPECULAR_WIDTH_RAD",
    "SceneError",
    "Seabed",
    "SeabedTexture",
    "SonarConfigError",
    "TargetSpec",
    "World",
    "WorldError",
    "intersect_batch",
    "solid_kinds",
]
