"""Before arming: would arming lead to a failsafe the companion caused? (pure judgement)

The facts (:class:`PreflightFacts`) are read from the vehicle by the executor; the
judgement (:func:`judge`) is a pure function of them and of the executor's ``topside``
setting, and refuses to arm, with the reason, where ArduSub 4.5 would disarm or lose its
failsafe because of this computer:

- **SYSID_MYGCS is this computer's system id.** ArduSub takes MANUAL_CONTROL and counts
  GCS heartbeats only from system SYSID_MYGCS, any component (GCS_Mavlink.cpp,
  ``GCS_MAVLINK::handle_heartbeat``): our heartbeats would feed its GCS failsafe, and it
  would disarm when this computer stops, not when the topside does.
- **SYSID_MYGCS is the vehicle's own system id (1).** BlueOS's services (mavlink2rest,
  system 1 component 194) heartbeat all the time: the GCS failsafe could never fire.
- **No topside heartbeat** (topside required). If the vehicle has seen its GCS since boot
  and lost it, its GCS failsafe (FS_GCS_ENABLE, default 2 = disarm) acts at the first
  check after arming (``Sub::failsafe_gcs_check`` acts only when armed).
- **No joystick** (topside required): the pilot could not take over.
- **A latched failsafe** (HEARTBEAT system_status CRITICAL) other than the pilot-input
  failsafe of a sub without a joystick (which latched once, 3 s after boot, and does not
  act again at arming).
- **No position** (EKF without a horizontal position): GUIDED is refused.
- **No mount** (MNT1_TYPE with no known frame): the tilt cannot be commanded.

Warnings (not refusals) name what the pilot should know: the pilot-input failsafe
disarms 3 s after the joystick stops (that is the topside's own failsafe), the GCS
failsafe's action, a bench test without a topside.
"""

from __future__ import annotations

from dataclasses import dataclass

MAV_STATE_CRITICAL = 5
FS_GCS_ACTIONS = {0: "disabled", 1: "warn only", 2: "disarm", 3: "depth hold", 4: "surface"}
FS_PILOT_ACTIONS = {0: "disabled", 1: "warn only", 2: "disarm"}


@dataclass(frozen=True)
class PreflightFacts:
    """What the executor read from the vehicle before arming."""

    our_system_id: int
    vehicle_system_id: int
    sysid_my_gcs: int
    fs_gcs_enable: int
    fs_pilot_input: int
    fs_pilot_timeout_s: float
    topside_heartbeat: bool  # a HEARTBEAT from system SYSID_MYGCS in the last few seconds
    topside_joystick: bool  # MANUAL_CONTROL from system SYSID_MYGCS in the last second
    system_status: int
    position_ok: bool
    mount_frame: str | None


@dataclass(frozen=True)
class PreflightReport:
    """The judgement: ``refusal`` is None when arming may go ahead."""

    refusal: str | None
    warnings: tuple[str, ...]
    notes: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """True when nothing refuses arming."""
        return self.refusal is None

    def lines(self) -> list[str]:
        """Everything, one line each, for the log and the ARM prompt."""
        out = [f"REFUSED: {self.refusal}"] if self.refusal else []
        return out + [f"warning: {w}" for w in self.warnings] + list(self.notes)


def judge(facts: PreflightFacts, *, topside_required: bool) -> PreflightReport:
    """Refuse arming where a failsafe caused by this computer would follow (module docstring)."""
    f = facts
    warnings: list[str] = []
    notes = [f"SYSID_MYGCS {f.sysid_my_gcs}; FS_GCS_ENABLE {f.fs_gcs_enable} "
             f"({FS_GCS_ACTIONS.get(f.fs_gcs_enable, '?')}); FS_PILOT_INPUT {f.fs_pilot_input} "
             f"({FS_PILOT_ACTIONS.get(f.fs_pilot_input, '?')}, {f.fs_pilot_timeout_s:g} s); "
             f"mount angles in the {f.mount_frame} frame"]

    def refuse(why: str) -> PreflightReport:
        return PreflightReport(why, tuple(warnings), tuple(notes))

    if f.sysid_my_gcs == f.our_system_id:
        return refuse(f"SYSID_MYGCS is {f.sysid_my_gcs}, this computer's system id: the vehicle would count our "
                      "heartbeats as the topside's and disarm when this computer stops; set SYSID_MYGCS back to "
                      "the topside's (255 by default)")
    if f.sysid_my_gcs == f.vehicle_system_id:
        return refuse(f"SYSID_MYGCS is {f.sysid_my_gcs}, the vehicle's own system id: BlueOS's services heartbeat "
                      "as that system all the time, so the GCS failsafe could never fire; set it to the topside's")
    pilot_latched = f.system_status == MAV_STATE_CRITICAL and not f.topside_joystick and f.fs_pilot_input != 0
    if f.system_status == MAV_STATE_CRITICAL and not pilot_latched:
        return refuse("the vehicle reports a failsafe (HEARTBEAT system_status CRITICAL) with the joystick "
                      "connected: clear it before arming")
    if topside_required:
        if not f.topside_heartbeat:
            return refuse(f"no heartbeat from the topside (system {f.sysid_my_gcs}): if the vehicle saw it "
                          f"since boot, its GCS failsafe ({FS_GCS_ACTIONS.get(f.fs_gcs_enable, '?')}) acts as soon "
                          "as it is armed; connect the topside, or pass --no-topside for a bench test")
        if not f.topside_joystick:
            return refuse(f"no joystick input (MANUAL_CONTROL) from the topside (system {f.sysid_my_gcs}): the "
                          "pilot could not take over; enable the joystick, or pass --no-topside for a bench test")
    else:
        warnings.append("no topside required (bench test or dry run): nobody can take over, and the vehicle's "
                        "GCS failsafe watches only system SYSID_MYGCS")
    if pilot_latched:
        notes.append("the pilot-input failsafe has latched (no joystick since boot): it acted once and will not "
                     "act at arming")
    elif f.fs_pilot_input == 2:
        warnings.append(f"FS_PILOT_INPUT disarms the vehicle {f.fs_pilot_timeout_s:g} s after the topside's "
                        "joystick stops (the topside's own failsafe)")
    if not f.position_ok:
        return refuse("the vehicle has no horizontal position (EKF: DVL bottom lock?): GUIDED needs one")
    if f.mount_frame is None:
        return refuse("MNT1_TYPE gives no known mount (1 servo, stabilised; 7 brushless PWM): the tilt cannot be "
                      "commanded")
    return PreflightReport(None, tuple(warnings), tuple(notes))
