"""Sound Metrics ARIS recordings (.aris): the file layout, reading and writing."""

from perception.sonar_io.aris.format import beams_from_ping_mode, describe_sonar, pose_from_header, window_edges_m
from perception.sonar_io.aris.reader import ArisRecording
from perception.sonar_io.aris.writer import aris_grid, write_aris

__all__ = [
    "ArisRecording",
    "aris_grid",
    "beams_from_ping_mode",
    "describe_sonar",
    "pose_from_header",
    "window_edges_m",
    "write_aris",
]
