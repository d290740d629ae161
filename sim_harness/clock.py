"""Simulation time: a lockstep clock shared by the simulator and the code under test.

The simulator owns the clock and moves it forward in fixed steps with
:meth:`SimClock.advance_to`. Other threads read :meth:`SimClock.now_s` and wait on
simulated time with :meth:`SimClock.sleep_s`, :meth:`SimClock.sleep_until` or
:meth:`SimClock.wait_for` (a wait on a predicate with a timeout in simulated seconds).

Lockstep: a thread that registers as a *participant* (``with clock.participant(): ...``)
holds the simulator back while it runs. The simulator only advances time when every
participant is waiting on the clock (sleeping, or waiting on a predicate that is false)
and none of them is due (deadline passed, or poked by :meth:`SimClock.notify`). So a
controller thread sees simulated time pass only while it waits, exactly as much as it
asked for, however slow or fast the machine is; when all participants wait, the simulator
runs as fast as it can (``speedup=None``) or paced to the wall clock (``speedup=1.0`` is
real time, ``speedup=10.0`` ten times real time).

Threads that are not participants may also wait on the clock; they never hold it back.

A *poller* (:meth:`SimClock.add_poller`) is work that only polls (a link's non-blocking
socket read): run by the simulator's own thread in every time step it is due, before any
participant of the step is let go. It does what a rank -1 participant that wakes every
``period_s`` would do, in the same order, without a thread of its own and the two thread
hand-offs a step that such a thread costs (about a tenth of a dry run's own process).

Order within a time step: participants that a step makes due are let go by *rank*, the
lowest first, and each rank runs until it waits again before the next is let go. A link's
I/O thread (rank -1, :data:`RANK_READER`) so reads what the simulator sent at this step
before the controller (rank 0) acts on it: who runs first never depends on the scheduler,
and a dry run repeats step for step. A due participant that is still waiting for its rank
is not poked by :meth:`notify`; it checks its predicate when its rank is let go.

Predicates passed to :meth:`SimClock.wait_for` are evaluated by the waiting thread
outside the clock's lock. A thread that changes what a predicate reads (e.g. a socket
reader that stores a received message) calls :meth:`SimClock.notify` afterwards, without
holding the clock's lock; waiters then re-check their predicates before the simulator
moves on.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from sim_harness.errors import ClockStopped, LockstepStall, SimConfigError

#: Wall seconds the simulator waits for a running participant before it gives up.
DEFAULT_STALL_TIMEOUT_S = 60.0

#: Rank of a thread that reads what the simulator sent (a link's socket reader): let go
#: before the controllers (rank 0) in every time step.
RANK_READER = -1


@dataclass
class _Participant:
    """Lockstep state of one registered thread (guarded by the clock's lock); ``wake`` is
    its own condition on that lock, notified only when it is due, poked or stopped."""

    name: str
    wake: threading.Condition
    rank: int = 0
    waiting: bool = False
    deadline_s: float = float("inf")
    poked: bool = False
    released: bool = False  # let go by advance_to (its rank's turn in the step)

    def due_unreleased(self, now_s: float) -> bool:
        """Due at ``now_s`` but its rank not yet let go."""
        return self.waiting and self.deadline_s <= now_s and not self.released

    def idle(self, now_s: float) -> bool:
        """Waiting on the clock, neither due nor poked."""
        return self.waiting and not self.poked and self.deadline_s > now_s


@dataclass(eq=False)
class Poller:
    """A callback the simulator's thread runs every ``period_s`` simulated seconds
    (:meth:`SimClock.add_poller`); :meth:`remove` stops it."""

    name: str
    period_s: float
    callback: Callable[[], None]
    next_s: float
    clock: SimClock

    def remove(self) -> None:
        """Stop it; once this returns it never runs again (a pass under way is waited for,
        unless this is called from that pass)."""
        self.clock._remove_poller(self)


class SimClock:
    """A simulated clock with lockstep participants and optional wall-clock pacing.

    Parameters
    ----------
    start_s
        Simulated time at creation, seconds.
    speedup
        ``None``: advance as fast as participants allow. A positive number: never run
        faster than that many simulated seconds per wall second (1.0 = real time).
    stall_timeout_s
        Wall seconds :meth:`advance_to` waits for running participants before raising
        :class:`~sim_harness.errors.LockstepStall`.
    """

    def __init__(
        self,
        *,
        start_s: float = 0.0,
        speedup: float | None = None,
        stall_timeout_s: float = DEFAULT_STALL_TIMEOUT_S,
    ) -> None:
        if speedup is not None and not speedup > 0.0:
            raise SimConfigError(f"must be positive or None, got {speedup}", key="speedup")
        if not stall_timeout_s > 0.0:
            raise SimConfigError(f"must be positive, got {stall_timeout_s}", key="stall_timeout_s")
        self._now_s = float(start_s)
        self._speedup = speedup
        self._stall_timeout_s = stall_timeout_s
        # One lock; the simulator waits on ``_cond`` (for participants to go idle),
        # non-participants on ``_tick`` (every time step), each participant on its own
        # ``wake``: a time step wakes only the threads it makes due (no thundering herd
        # of threads that re-check and sleep again 50 times a simulated second).
        self._lock = threading.Lock()
        self._cond = threading.Condition(self._lock)
        self._tick = threading.Condition(self._lock)
        self._participants: dict[int, _Participant] = {}
        self._pollers: list[Poller] = []
        self._polling: tuple[Poller, int] | None = None  # the poller running now, and its thread
        self._stopped = False
        self._generation = 0
        self._pace_origin: tuple[float, float] | None = None  # (wall_s, sim_s)

    # -- reading -------------------------------------------------------------------
    def now_s(self) -> float:
        """Current simulated time, seconds."""
        return self._now_s

    @property
    def speedup(self) -> float | None:
        """Pacing factor (simulated s per wall s), or None when running free."""
        return self._speedup

    @property
    def stopped(self) -> bool:
        """True once :meth:`stop` was called."""
        return self._stopped

    # -- participants --------------------------------------------------------------
    def register(self, name: str | None = None, *, rank: int = 0) -> None:
        """Register the calling thread as a lockstep participant (it starts running);
        ``rank`` orders the participants a time step makes due (lowest first)."""
        ident = threading.get_ident()
        with self._cond:
            if ident in self._participants:
                raise SimConfigError("thread is already a participant", key="register")
            self._participants[ident] = _Participant(name or threading.current_thread().name,
                                                     threading.Condition(self._lock), rank=int(rank))

    def unregister(self) -> None:
        """Remove the calling thread from the participants (no-op if it is not one)."""
        with self._cond:
            self._participants.pop(threading.get_ident(), None)
            self._cond.notify_all()

    @contextmanager
    def participant(self, name: str | None = None, *, rank: int = 0) -> Iterator[SimClock]:
        """Context manager: the calling thread is a lockstep participant inside it."""
        self.register(name, rank=rank)
        try:
            yield self
        finally:
            self.unregister()

    # -- pollers -------------------------------------------------------------------
    def add_poller(self, name: str, period_s: float, callback: Callable[[], None]) -> Poller:
        """Run ``callback()`` in the simulator's thread at every time step at least
        ``period_s`` after its last run (the first: ``period_s`` from now), before the
        step's participants are let go; in the order added. The callback must not wait on
        the clock (it runs while the simulator holds time still) and runs without the
        clock's lock. An exception it raises ends the simulator's step (and run)."""
        if not period_s > 0.0:
            raise SimConfigError(f"must be positive, got {period_s}", key="period_s")
        poller = Poller(name, float(period_s), callback, self._now_s + float(period_s), self)
        with self._cond:
            self._pollers.append(poller)
        return poller

    def _remove_poller(self, poller: Poller) -> None:
        with self._cond:
            if poller in self._pollers:
                self._pollers.remove(poller)
            while self._polling is not None and self._polling[0] is poller \
                    and self._polling[1] != threading.get_ident():
                self._cond.wait()

    def _run_pollers_locked(self, t_s: float) -> None:
        """Every poller due at ``t_s``, in order, each outside the lock (called holding it)."""
        for poller in [p for p in self._pollers if p.next_s <= t_s]:
            if poller not in self._pollers:  # removed by an earlier one
                continue
            poller.next_s = t_s + poller.period_s
            self._polling = (poller, threading.get_ident())
            self._lock.release()
            try:
                poller.callback()
            finally:
                self._lock.acquire()
                self._polling = None
                if poller not in self._pollers:  # removed meanwhile: its remove() waits for this pass
                    self._cond.notify_all()
            if self._stopped:
                raise ClockStopped("simulation clock stopped")

    # -- waiting -------------------------------------------------------------------
    def sleep_s(self, duration_s: float) -> None:
        """Block until simulated time has passed ``now_s() + duration_s``."""
        if duration_s < 0.0:
            raise ValueError(f"sleep duration must be >= 0 s, got {duration_s}")
        self.sleep_until(self._now_s + duration_s)

    def sleep_until(self, deadline_s: float) -> None:
        """Block until simulated time is at or past ``deadline_s``."""
        self.wait_for(_never, deadline_s - self._now_s)

    def wait_for(
        self, predicate: Callable[[], bool], timeout_s: float, *, poll_s: float | None = None
    ) -> bool:
        """Wait until ``predicate()`` is true or ``timeout_s`` simulated seconds pass.

        Returns the last value of the predicate (True: condition met, False: timed out).
        The predicate is re-checked whenever :meth:`notify` is called, every ``poll_s``
        simulated seconds if given (for predicates that poll, e.g. a non-blocking socket
        read: in lockstep this is fully repeatable), and at the deadline. Raises
        :class:`~sim_harness.errors.ClockStopped` if the clock is stopped while waiting.
        """
        if poll_s is not None and not poll_s > 0.0:
            raise ValueError(f"poll_s must be positive, got {poll_s}")
        ident = threading.get_ident()
        with self._cond:
            deadline_s = self._now_s + max(timeout_s, 0.0)
            me = self._participants.get(ident)
            if me is not None:
                me.poked = False
        try:
            while True:
                with self._cond:
                    generation = self._generation
                if predicate():
                    return True
                with self._cond:
                    if self._stopped:
                        raise ClockStopped("simulation clock stopped while waiting")
                    if self._now_s >= deadline_s:
                        break
                    if me is None:
                        # Non-participants re-check after every time step or notify.
                        if generation == self._generation:
                            self._tick.wait()
                        continue
                    if me.poked:
                        me.poked = False
                        continue
                    wake_s = deadline_s if poll_s is None else min(deadline_s, self._now_s + poll_s)
                    me.deadline_s = wake_s
                    me.waiting = True
                    me.released = False
                    self._cond.notify_all()  # the simulator may go on
                    while not self._stopped and not me.released and not me.poked:
                        me.wake.wait()
                    me.waiting = False
                    me.poked = False
                    me.released = False
        finally:
            with self._cond:
                if me is not None:
                    me.waiting = False
                    me.deadline_s = float("inf")
        return bool(predicate())

    def notify(self) -> None:
        """Ask every waiting thread to re-check its predicate before time moves on."""
        with self._cond:
            for p in self._participants.values():
                if p.due_unreleased(self._now_s):
                    continue  # its rank's turn comes; it checks then
                p.poked = True
                p.wake.notify_all()
            self._generation += 1
            self._tick.notify_all()
            self._cond.notify_all()

    # -- advancing (simulator side) ------------------------------------------------
    def _idle_below(self, rank: int | None) -> bool:
        now = self._now_s
        return all(p.idle(now) for p in self._participants.values() if rank is None or p.rank < rank)

    def wait_until_idle(self) -> None:
        """Block until every participant waits on the clock (simulator side).

        The simulator calls this before reading its inputs, so that everything the
        participants sent at the current time is there to read: the run is then the same
        whatever the thread scheduling. Raises ``LockstepStall`` or ``ClockStopped``.
        """
        with self._cond:
            self._wait_idle_locked()
            if self._stopped:
                raise ClockStopped("simulation clock stopped")

    def _wait_idle_locked(self, ranks_below: int | None = None) -> None:
        """Wait until every participant is idle (with ``ranks_below``: those of lower rank)."""
        wall_limit = time.monotonic() + self._stall_timeout_s
        while not self._stopped and not self._idle_below(ranks_below):
            remaining = wall_limit - time.monotonic()
            if remaining <= 0.0:
                running = tuple(
                    p.name for p in self._participants.values() if not p.idle(self._now_s)
                )
                raise LockstepStall(
                    f"participants did not yield within {self._stall_timeout_s} wall s",
                    participants=running,
                )
            self._cond.wait(remaining)

    def advance_to(self, t_s: float) -> None:
        """Move simulated time to ``t_s`` once every participant waits (simulator only).

        Blocks while any participant runs, and, when paced, until the wall clock allows.
        Raises :class:`~sim_harness.errors.LockstepStall` if participants keep running
        for longer than the stall timeout, and ``ClockStopped`` after :meth:`stop`.
        """
        with self._cond:
            if t_s < self._now_s:
                raise ValueError(f"time cannot go back: {t_s} s < now {self._now_s} s")
            self._wait_idle_locked()
            if self._speedup is not None:
                if self._pace_origin is None:
                    self._pace_origin = (time.monotonic(), self._now_s)
                wall0, sim0 = self._pace_origin
                while not self._stopped:
                    lag = wall0 + (t_s - sim0) / self._speedup - time.monotonic()
                    if lag <= 0.0:
                        break
                    self._cond.wait(lag)
            if self._stopped:
                raise ClockStopped("simulation clock stopped")
            self._now_s = t_s
            self._generation += 1
            self._tick.notify_all()
            if self._pollers:
                self._run_pollers_locked(t_s)
            due = [p for p in self._participants.values() if p.waiting and p.deadline_s <= t_s]
            ranks = sorted({p.rank for p in due})
            for i, rank in enumerate(ranks):
                for p in due:
                    if p.rank == rank:
                        p.released = True
                        p.wake.notify_all()
                if i + 1 < len(ranks):  # this rank waits again before the next is let go
                    self._wait_idle_locked(ranks_below=ranks[i + 1])
                    if self._stopped:
                        raise ClockStopped("simulation clock stopped")

    def stop(self) -> None:
        """Stop the clock: every waiter and the simulator get ``ClockStopped``."""
        with self._cond:
            self._stopped = True
            for p in self._participants.values():
                p.wake.notify_all()
            self._tick.notify_all()
            self._cond.notify_all()


def _never() -> bool:
    return False
