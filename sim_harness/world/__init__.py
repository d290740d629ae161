"""The simulated seabed world: seabed, relief, texture and target solids."""

from sim_harness.world.errors import PoseError, SceneError, SonarConfigError, WorldError
from sim_harness.world.materials import MATERIALS, SPECULAR_GAIN, SPECULAR_WIDTH_RAD, Material
from sim_harness.world.relief import Relief
from sim_harness.world.shapes import (
    BoxSolid,
    CompositeSolid,
    CylinderSolid,
    EllipsoidSolid,
    intersect_batch,
    solid_kinds,
)
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import SHAPES, PlacedTarget, Seabed, TargetSpec, World

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
