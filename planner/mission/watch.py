"""What the vehicle says about itself that decides how the executor lets go.

ArduSub 4.5 announces each failsafe with a STATUSTEXT before (or as) it acts
(ArduSub/failsafe.cpp): "MYGCS: N, heartbeat lost" (GCS), "Lost manual control" (pilot
input), "Failsafe terrain triggered", "Leak Detected", "Depth sensor error!", "EKF
bad", "Crash detected". A mode change that follows such a text within
``FAILSAFE_TEXT_WINDOW_S`` is the vehicle's own; any other mode change the executor did
not ask for is the pilot's (a joystick button or the topside's mode menu). Either way
the executor stops commanding at once and never changes the mode back.
"""

from __future__ import annotations

import threading
from collections import deque

from vehicle_link.telemetry import StatusText

#: Phrases of ArduSub 4.5's failsafe STATUSTEXTs (ArduSub/failsafe.cpp).
FAILSAFE_PHRASES = ("heartbeat lost", "Lost manual control", "Failsafe terrain", "Leak Detected",
                    "Depth sensor error", "EKF bad", "Crash detected", "Battery")
FAILSAFE_TEXT_WINDOW_S = 3.0
MAX_TEXTS = 50


class VehicleWatch:
    """Recent STATUSTEXTs from the vehicle (a link listener feeds it from the I/O thread)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._texts: deque[tuple[float, str]] = deque(maxlen=MAX_TEXTS)

    def listener(self, record: object) -> None:
        """Link listener: keep STATUSTEXTs."""
        if isinstance(record, StatusText):
            with self._lock:
                self._texts.append((record.time_s, record.text))

    def texts_since(self, since_s: float) -> list[str]:
        """Every STATUSTEXT received at or after ``since_s``."""
        with self._lock:
            return [text for t, text in self._texts if t >= since_s]

    def failsafe_text(self, now_s: float) -> str | None:
        """The newest failsafe STATUSTEXT of the last ``FAILSAFE_TEXT_WINDOW_S``, or None."""
        for text in reversed(self.texts_since(now_s - FAILSAFE_TEXT_WINDOW_S)):
            if any(phrase.lower() in text.lower() for phrase in FAILSAFE_PHRASES):
                return text
        return None
