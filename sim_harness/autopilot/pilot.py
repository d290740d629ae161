"""The topside pilot's input: MANUAL_CONTROL and RC_CHANNELS_OVERRIDE as ArduSub 4.5 takes them.

- **Who may fly.** MANUAL_CONTROL is taken only from system ``SYSID_MYGCS`` and only if
  ``target == SYSID_THISMAV`` (target 0 is refused); RC_CHANNELS_OVERRIDE only from
  ``SYSID_MYGCS`` (``GCS_MAVLINK_Sub::handle_message``, ArduSub/GCS_Mavlink.cpp). Each
  accepted message refreshes the pilot-input time and counts as the GCS being seen
  (``gcs().sysid_myggcs_seen``).
- **Sticks.** ``Sub::transform_manual_control_to_rc_override`` (ArduSub/joystick.cpp):
  x, y, r in [-1000, 1000] scaled by 0.4 * gain, z in [0, 1000] (500 neutral) by
  0.8 * gain * JS_THR_GAIN, clamped to 1100..1900 us; a channel's value is
  ``(pwm - 1500) / 400``. The overrides keep their last value when MANUAL_CONTROL stops
  (``RC_Channel::update``); only the pilot-input failsafe neutralises them
  (``Sub::set_neutral_controls``).
- **Buttons** (``default_js_buttons``): 1 MANUAL, 2 ALT_HOLD, 3 STABILIZE (set_mode with
  reason RC_COMMAND), 4 disarm, 6 arm, 7 mount centre, 9 tilt down and 10 tilt up (RC8
  at 1100 / 1900 while held). Acted on for every message in which they are pressed
  (``handle_jsbutton_press``).
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

RC_NEUTRAL_US = 1500
RC_MIN_US, RC_MAX_US = 1100, 1900
#: Default joystick button functions (ArduSub joystick.cpp ``default_js_buttons``).
BUTTON_MODES = {1: 19, 2: 2, 3: 0}  # MANUAL, ALT_HOLD, STABILIZE
BUTTON_DISARM, BUTTON_ARM, BUTTON_MOUNT_CENTRE = 4, 6, 7
BUTTON_TILT_DOWN, BUTTON_TILT_UP = 9, 10


@dataclass(frozen=True)
class Sticks:
    """Pilot channels, each (pwm - 1500) / 400 in [-1, 1]: forward, lateral, climb, yaw."""

    forward: float = 0.0
    lateral: float = 0.0
    climb: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class ButtonActions:
    """What the buttons of one MANUAL_CONTROL ask for."""

    mode: int | None = None
    arm: bool = False
    disarm: bool = False
    mount_centre: bool = False


def _norm(pwm: float) -> float:
    clamped = min(max(pwm, RC_MIN_US), RC_MAX_US)
    return (clamped - RC_NEUTRAL_US) / 400.0


class PilotInput:
    """The latest pilot channels, the tilt channel and when the pilot last spoke."""

    def __init__(self) -> None:
        self.sticks = Sticks()
        self.rc8_us: int | None = None  # the mount tilt channel; None until any RC input
        self.last_input_s: float | None = None

    def neutral(self) -> None:
        """``Sub::set_neutral_controls``: every channel back to 1500 us."""
        self.sticks = Sticks()
        if self.rc8_us is not None:
            self.rc8_us = RC_NEUTRAL_US

    def manual_control(self, msg: mavlink.MAVLink_message, now_s: float, *, my_gcs: int,
                       this_mav: int, gain: float, throttle_gain: float) -> ButtonActions | None:
        """Take a MANUAL_CONTROL; None if ArduSub would ignore it (sender or target)."""
        if msg.get_srcSystem() != my_gcs or msg.target != this_mav:
            return None
        rpy = 0.4 * gain
        thr = 0.8 * gain * throttle_gain
        self.sticks = Sticks(
            forward=_norm(msg.x * rpy + RC_NEUTRAL_US),
            lateral=_norm(msg.y * rpy + RC_NEUTRAL_US),
            climb=_norm(msg.z * thr + (RC_NEUTRAL_US - 500 * thr)),
            yaw=_norm(msg.r * rpy + RC_NEUTRAL_US),
        )
        buttons = int(msg.buttons) | (int(getattr(msg, "buttons2", 0)) << 16)
        pressed = {i for i in range(32) if buttons & (1 << i)}
        tilt = RC_NEUTRAL_US
        if BUTTON_TILT_UP in pressed:
            tilt = RC_MAX_US
        elif BUTTON_TILT_DOWN in pressed:
            tilt = RC_MIN_US
        self.rc8_us = tilt
        self.last_input_s = now_s
        mode = next((BUTTON_MODES[b] for b in sorted(pressed) if b in BUTTON_MODES), None)
        return ButtonActions(mode=mode, arm=BUTTON_ARM in pressed, disarm=BUTTON_DISARM in pressed,
                             mount_centre=BUTTON_MOUNT_CENTRE in pressed)

    def rc_override(self, msg: mavlink.MAVLink_message, now_s: float, *, my_gcs: int) -> bool:
        """Take an RC_CHANNELS_OVERRIDE (channels 3 throttle, 4 yaw, 5 forward, 6 lateral,
        8 tilt; 0 and 65535 leave a channel alone); False if ignored (sender)."""
        if msg.get_srcSystem() != my_gcs:
            return False

        def ch(value: int, old: float) -> float:
            return old if value in (0, 65535) else _norm(value)

        s = self.sticks
        self.sticks = Sticks(forward=ch(msg.chan5_raw, s.forward), lateral=ch(msg.chan6_raw, s.lateral),
                             climb=ch(msg.chan3_raw, s.climb), yaw=ch(msg.chan4_raw, s.yaw))
        if msg.chan8_raw not in (0, 65535):
            self.rc8_us = int(min(max(msg.chan8_raw, RC_MIN_US), RC_MAX_US))
        self.last_input_s = now_s
        return True
