"""SimClock: lockstep participants, predicate waits, stop, pacing, determinism."""

from __future__ import annotations

import threading

import pytest

from sim_harness.autopilot.autopilot import AutopilotConfig
from sim_harness.clock import SimClock
from sim_harness.errors import ClockStopped, LockstepStall, SimConfigError
from sim_harness.simulator import VehicleConfig, VehicleSimulator

STEP_S = 0.01
#: Wall seconds we watch a blocked simulator to see that it does not advance.
OBSERVE_WALL_S = 0.2


def _run_sim(clock: SimClock, until_s: float) -> threading.Thread:
    def loop() -> None:
        t = clock.now_s()
        try:
            while t < until_s:
                t = round(t + STEP_S, 9)
                clock.advance_to(t)
        except ClockStopped:
            pass

    th = threading.Thread(target=loop, daemon=True)
    th.start()
    return th


def test_participant_sees_exactly_the_time_it_slept():
    clock = SimClock()
    seen = []
    with clock.participant("controller"):
        sim = _run_sim(clock, 100.0)
        for _ in range(50):
            before = clock.now_s()
            clock.sleep_s(0.05)
            seen.append(clock.now_s() - before)
    clock.stop()
    sim.join(5.0)
    # Lockstep: the simulator never runs past the sleeper's deadline by more than one step.
    assert all(0.05 - 1e-9 <= d <= 0.05 + STEP_S + 1e-9 for d in seen)


def test_simulator_waits_while_a_participant_works():
    clock = SimClock()
    clock.register("worker")
    sim = _run_sim(clock, 100.0)
    t0 = clock.now_s()
    # While registered and not waiting, no simulated time passes, however long we take.
    done = threading.Event()
    done.wait(OBSERVE_WALL_S)
    assert clock.now_s() == t0
    clock.unregister()
    assert clock.wait_for(lambda: clock.now_s() >= 1.0, timeout_s=10.0)
    clock.stop()
    sim.join(5.0)


def test_wait_for_wakes_on_notify_before_its_timeout():
    # The setter is a participant too: a non-participant is not waited for, so on a busy
    # host the simulator could run to the waiter's timeout before the setter is scheduled.
    clock = SimClock()
    flag = {"set": False}
    result = {}
    registered = threading.Event()

    def setter() -> None:
        with clock.participant("setter"):
            registered.set()
            clock.sleep_until(2.0)
            flag["set"] = True
            clock.notify()

    th = threading.Thread(target=setter, daemon=True)
    th.start()
    assert registered.wait(5.0)
    with clock.participant("controller"):
        sim = _run_sim(clock, 1000.0)
        result["ok"] = clock.wait_for(lambda: flag["set"], timeout_s=50.0)
        result["t"] = clock.now_s()
    clock.stop()
    sim.join(5.0)
    th.join(5.0)
    assert result["ok"] is True
    assert 2.0 <= result["t"] < 2.0 + STEP_S + 1e-9


def test_wait_for_times_out_in_simulated_time():
    clock = SimClock()
    with clock.participant():
        sim = _run_sim(clock, 100.0)
        assert clock.wait_for(lambda: False, timeout_s=3.0) is False
        assert 3.0 <= clock.now_s() <= 3.0 + STEP_S + 1e-9
    clock.stop()
    sim.join(5.0)


def test_stop_wakes_waiters_with_clock_stopped():
    clock = SimClock()
    errors = []

    def waiter() -> None:
        try:
            clock.sleep_s(10.0)
        except ClockStopped as exc:
            errors.append(exc)

    th = threading.Thread(target=waiter, daemon=True)
    th.start()
    clock.stop()
    th.join(5.0)
    assert len(errors) == 1
    with pytest.raises(ClockStopped):
        clock.advance_to(1.0)


def test_stall_is_reported_with_the_participant_name():
    clock = SimClock(stall_timeout_s=0.05)
    clock.register("busy-controller")
    with pytest.raises(LockstepStall) as info:
        clock.advance_to(0.01)
    assert info.value.participants == ("busy-controller",)
    clock.unregister()


def test_bad_arguments_are_refused():
    with pytest.raises(SimConfigError):
        SimClock(speedup=0.0)
    clock = SimClock(start_s=5.0)
    with pytest.raises(ValueError):
        clock.advance_to(4.0)
    with pytest.raises(ValueError):
        clock.sleep_s(-1.0)


def test_paced_clock_still_advances_to_the_target():
    clock = SimClock(speedup=200.0)
    for k in range(1, 6):
        clock.advance_to(k * 0.02)
    assert clock.now_s() == pytest.approx(0.1)


def test_same_seed_same_trajectory():
    def trajectory(seed: int) -> list[tuple[float, ...]]:
        # No joystick on this bench: the pilot-input failsafe (FS_PILOT_INPUT) is off.
        sim = VehicleSimulator(config=VehicleConfig(seed=seed, start_depth_m=3.0,
                                                    autopilot=AutopilotConfig(params={"FS_PILOT_INPUT": 0})))
        ap = sim.autopilot
        sim.run_for(0.1)
        ap.arm(force=True)
        ap.set_mode(4)  # GUIDED
        assert ap.set_guided_target(6.0, -3.0, 5.0)
        out = []
        for _ in range(20):
            sim.run_for(1.0)
            t = sim.truth()
            out.append((t.north_m, t.east_m, t.depth_m, t.yaw_rad))
        return out

    a, b, c = trajectory(7), trajectory(7), trajectory(8)
    assert a == b
    assert a != c


def test_a_gcs_driven_dive_is_repeatable_in_lockstep():
    import math

    from sim_harness.autopilot.autopilot import Mode
    from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle

    def dive() -> tuple[list[tuple[float, ...]], list[tuple[str, float]]]:
        with running_vehicle(config=VehicleConfig(start_depth_m=2.0, seed=5)) as (sim, gcs):
            gcs.set_mode(int(Mode.GUIDED))
            gcs.arm()
            gcs.mav.set_position_target_local_ned_send(
                0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0b100111111000, 5.0, 3.0, 4.0, 0, 0, 0, 0, 0,
                0, math.radians(30.0), 0)
            msgs = gcs.run_for(10.0)
            received = [(m.get_type(), m.time_boot_ms / 1000.0) for m in msgs
                        if m.get_type() == "ATTITUDE"]
            truth = [(t.time_s, t.north_m, t.east_m, t.depth_m, t.yaw_rad)
                     for t in sim.truth_history()]
        return truth, received

    first, second = dive(), dive()
    assert first == second


def test_polling_wait_sees_a_condition_within_one_poll_interval():
    clock = SimClock()
    with clock.participant():
        sim = _run_sim(clock, 100.0)
        got = clock.wait_for(lambda: clock.now_s() >= 1.234, timeout_s=10.0, poll_s=0.05)
        t = clock.now_s()
        assert got is True
        assert 1.234 <= t <= 1.234 + 0.05 + STEP_S + 1e-9
        with pytest.raises(ValueError, match="poll_s"):
            clock.wait_for(lambda: True, 1.0, poll_s=0.0)
    clock.stop()
    sim.join(5.0)


def test_a_reader_of_lower_rank_runs_first_in_every_step():
    """Two participants due in the same step: the reader (rank -1, a link's socket reader)
    is let go and waits again before the controller (rank 0) is let go, so the controller
    always sees what the reader stored in this step, however slow the reader is to be
    scheduled (here it dawdles 1 ms of wall time before storing). Without the ranks the
    controller would see the last step's value whenever it ran first."""
    import time

    from sim_harness.clock import RANK_READER

    clock = SimClock()
    stored = {"t": -1.0}
    joined = threading.Event()

    def reader() -> None:
        with clock.participant("reader", rank=RANK_READER):
            joined.set()
            try:
                while True:
                    clock.sleep_s(0.02)
                    time.sleep(0.001)
                    stored["t"] = clock.now_s()
            except ClockStopped:
                return  # the clock stopped: the test is over

    seen = []
    with clock.participant("controller"):
        th = threading.Thread(target=reader, daemon=True)
        th.start()
        assert joined.wait(5.0)
        sim = _run_sim(clock, 100.0)
        for _ in range(40):
            clock.sleep_s(0.02)
            seen.append((clock.now_s(), stored["t"]))
    clock.stop()
    sim.join(5.0)
    th.join(5.0)
    assert [t for t, _ in seen] == [s for _, s in seen]


def test_a_poller_runs_in_the_simulators_thread_before_the_step_is_let_go():
    """A poller (a link's socket read, :meth:`SimClock.add_poller`) runs every period in the
    thread that advances the clock, once per due step, before any participant sees that
    step: the controller always sees what it stored in this step, as with a rank -1 reader."""
    clock = SimClock()
    stored = {"t": -1.0}
    threads, runs = set(), []

    def poll() -> None:
        threads.add(threading.get_ident())
        runs.append(clock.now_s())
        stored["t"] = clock.now_s()

    poller = clock.add_poller("reader", 0.02, poll)
    seen = []
    with clock.participant("controller"):
        sim = _run_sim(clock, 100.0)
        for _ in range(40):
            clock.sleep_s(0.02)
            seen.append((clock.now_s(), stored["t"]))
        poller.remove()
        n_runs = len(runs)
        clock.sleep_s(0.2)
    clock.stop()
    sim.join(5.0)
    assert [t for t, _ in seen] == [s for _, s in seen]
    assert threads == {sim.ident}
    # every 0.02 s of simulated time from when it was added (the clock steps 0.01 s)
    assert runs[:5] == pytest.approx([0.02, 0.04, 0.06, 0.08, 0.10])
    assert len(runs) == n_runs  # never again once removed
    with pytest.raises(SimConfigError, match="positive"):
        clock.add_poller("bad", 0.0, poll)


def test_removing_a_poller_waits_for_its_pass_under_way():
    """``remove()`` from another thread returns only once a pass under way has ended (so a
    link that closes its socket after it never has a pass read a closed socket); from the
    poller's own pass it does not wait for itself."""
    import time

    clock = SimClock()
    entered, events = threading.Event(), []

    def slow() -> None:
        entered.set()
        time.sleep(0.2)
        events.append("pass ended")

    poller = clock.add_poller("slow", 0.01, slow)
    sim = _run_sim(clock, 0.05)
    assert entered.wait(5.0)
    poller.remove()
    events.append("removed")
    sim.join(5.0)
    assert events == ["pass ended", "removed"]

    clock2, runs = SimClock(), []

    def once() -> None:
        runs.append(clock2.now_s())
        me.remove()

    me = clock2.add_poller("once", 0.01, once)
    _run_sim(clock2, 0.1).join(5.0)
    assert runs == pytest.approx([0.01])
