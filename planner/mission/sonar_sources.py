"""Sonar sources for a real vehicle: what a sonar driver gives the executor.

The executor asks ``poll(now_s)`` each control cycle for the frames pinged since the last
call. On a real ROV the ARIS is read by its own driver process (Sound Metrics' SDK, or a
ROS node); :class:`DirectorySonarSource` is the bridge: the driver writes each frame as a
``.npz`` (``docs/frame-format.md``) into a folder, atomically (temporary name, then rename),
and the executor picks them up in name order.

The clock: ``timestamp_s`` must be the ping time on the clock the executor runs on, which
on a real vehicle is this computer's monotonic clock (Python ``time.monotonic()``, Linux
``CLOCK_MONOTONIC``: seconds since boot), the clock every MAVLink record is stamped with
when it arrives. A frame is placed with the navigation at its timestamp, so a frame
stamped on another clock (Unix time, the sonar's own) could never be placed: frames more
than :data:`CLOCK_TOLERANCE_S` away from ``now_s`` are refused with a warning naming the
clock, and counted (:attr:`DirectorySonarSource.frames_off_clock`).
"""

from __future__ import annotations

import logging
from pathlib import Path

from perception.errors import FrameFormatError
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import load_frames

_log = logging.getLogger(__name__)

#: A frame stamped further than this from the executor's clock is on another clock, s.
CLOCK_TOLERANCE_S = 30.0


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
        self.frames_off_clock = 0

    def poll(self, now_s: float) -> list[SonarFrame]:
        """Frames in files not read yet; unreadable files and frames stamped on another clock
        are skipped, counted and logged."""
        frames: list[SonarFrame] = []
        for path in sorted(self.folder.glob("*.npz")):
            if path.name in self._seen or path.name.startswith("."):
                continue
            self._seen.add(path.name)
            try:
                loaded = load_frames(path)
            except (FrameFormatError, OSError) as exc:
                self.files_rejected += 1
                _log.warning("sonar frame file skipped: %s", exc)
                continue
            for frame in loaded:
                if abs(frame.timestamp_s - now_s) > CLOCK_TOLERANCE_S:
                    self.frames_off_clock += 1
                    _log.warning("%s: frame stamped t=%.3f s, but this computer's monotonic clock reads %.3f s: "
                                 "stamp frames with time.monotonic() of the companion computer "
                                 "(docs/frame-format.md); frame skipped", path, frame.timestamp_s, now_s)
                    continue
                frames.append(frame)
            if self.delete_after_read:
                path.unlink(missing_ok=True)
        self.frames_read += len(frames)
        return frames
