"""The forward-looking sonar renderer, scene files and viewpoints, and each rendered frame's truth."""

from sim_harness.sonar.physics import SonarPhysics
from sim_harness.sonar.receiver import power_to_image, power_to_uint8
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import Scene, builtin_scenes, load_scene
from sim_harness.sonar.seabed import arccos01_f32, seabed_branches
from sim_harness.sonar.truth import FrameTruth, Label, TargetTruth
from sim_harness.sonar.viewpoint import choose_tilt_rad, scene_pose

__all__ = [
    "FrameTruth",
    "Label",
    "Scene",
    "SonarConfig",
    "SonarPhysics",
    "SonarPose",
    "SonarRenderer",
    "TargetTruth",
    "arccos01_f32",
    "builtin_scenes",
    "choose_tilt_rad",
    "load_scene",
    "power_to_image",
    "power_to_uint8",
    "scene_pose",
    "seabed_branches",
]
