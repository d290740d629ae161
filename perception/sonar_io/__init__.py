"""Sonar frames and recordings: the frame type, .npz frame files, ARIS recordings, beam tables."""

from perception.sonar_io.beams import TABLES, aris3000_128, load_beam_table
from perception.sonar_io.frame import OPTIONAL_FIELDS, SonarFrame, frame_field_names
from perception.sonar_io.npz import load_frames, save_frame, save_frames
from perception.sonar_io.readers import DESCRIBE_MAX_FRAMES, Recording, RecordingInfo, open_recording

__all__ = [
    "DESCRIBE_MAX_FRAMES",
    "OPTIONAL_FIELDS",
    "Recording",
    "RecordingInfo",
    "SonarFrame",
    "TABLES",
    "aris3000_128",
    "frame_field_names",
    "load_beam_table",
    "load_frames",
    "open_recording",
    "save_frame",
    "save_frames",
]
