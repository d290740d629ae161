"""The sonar's tilt mount: how its angle moves, and its two frames.

A mount angle is named with its frame (architecture.md):

- *body frame*: the sonar's depression below the vehicle's x axis (``tilt_rad``, positive
  down), what an unstabilised mount holds and what the frame format's ``tilt_deg`` is;
- *earth frame*: the boresight's depression below the horizontal, what a stabilised mount
  (ArduSub's default servo mount, MNT1_TYPE 1) holds and reports.

With the vehicle's pitch ``theta`` (nose up positive) and roll ignored:
``earth = body - theta``. Convert once, where the mount's type is known.
"""

from __future__ import annotations


def slew_toward(current_rad: float, target_rad: float, *, max_rate_rad_s: float, dt_s: float) -> float:
    """The mount angle after ``dt_s`` moving from ``current_rad`` toward ``target_rad`` at
    most ``max_rate_rad_s`` (a rate-limited servo), rad."""
    step = max_rate_rad_s * max(dt_s, 0.0)
    return current_rad + min(max(target_rad - current_rad, -step), step)


def earth_from_body_tilt_rad(body_tilt_rad: float, pitch_rad: float) -> float:
    """Boresight depression below the horizontal of a body-frame mount angle, rad."""
    return body_tilt_rad - pitch_rad


def body_from_earth_tilt_rad(earth_tilt_rad: float, pitch_rad: float) -> float:
    """Body-frame mount angle that points the boresight ``earth_tilt_rad`` below the horizontal, rad."""
    return earth_tilt_rad + pitch_rad


