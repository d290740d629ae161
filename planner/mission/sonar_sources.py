"""Sonar sources for a real vehicle: what a sonar driver gives the executor.

The executor asks ``poll(now_s)`` each control cycle for the frames pinged since the last
call. On a real ROV the ARIS is read by its own driver process (Sound Metrics' SDK, or a
ROS node); :class:`DirectorySonarSource` is the bridge: the driver writes each frame as a
``.npz`` (``frame-format.md``) into a folder, atomically (temporary name, then rename),
and the executor picks them up in name order.
"""

from __future__ import annotations

import logging
from pathlib import Path

from perception.errors import FrameFormatError
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import load_frames

_log = logging.getLogger(__name__)


class DirectorySonarSource:
    """Frames dropped into a folder as ``.npz`` files, oldest name first.

    Parameters
    ----------
    folder : Path
        Watched folder; it must exist.
    delete_after_read : bool
        Remove each file once read (a driver's spool folder) or leave it (a recording).
    """

    def __init__(self, folder: Path, *, delete_after_read: bool = False):
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise FileNotFoundError(f"{self.folder}: sonar frame folder does not exist")
        self.delete_after_read = delete_after_read
        self._seen: set[str] = set()
        self.frames_read = 0
        self.files_rejected = 0

    def poll(self, now_s: float) -> list[SonarFrame]:
        """Frames in files not read yet; unreadable files are skipped and counted."""
        del now_s
        frames: list[SonarFrame] = []
        for path in sorted(self.folder.glob("*.npz")):
            if path.name in self._seen or path.name.startswith("."):
                continue
            self._seen.add(path.name)
            try:
                frames.extend(load_frames(path))
            except (FrameFormatError, OSError) as exc:
                self.files_rejected += 1
                _log.warning("sonar frame file skipped: %s", exc)
                continue
            if self.delete_after_read:
                path.unlink(missing_ok=True)
        self.frames_read += len(frames)
        return frames
