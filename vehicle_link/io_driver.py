"""What runs a link's I/O passes: a thread of its own, or a lockstep clock's poller.

:class:`vehicle_link.link_core.LinkCore` does one I/O pass at a time (drain the socket,
dispatch, heartbeat and link-health timers); :class:`IoDriver` decides where the passes run:

- On a wall clock (the vehicle): a thread that loops, each pass waiting for bytes at most
  ``io_poll_s`` real seconds.
- On a lockstep simulation clock (:class:`sim_harness.clock.SimClock`), which advances only
  while every participant waits on it: a pass every ``io_poll_s`` of simulated time, first in
  each time step, so no reply of the simulated vehicle is missed or late in simulated time.
  A clock that takes pollers (:meth:`~sim_harness.clock.SimClock.add_poller`) runs the pass
  in the simulator's own thread; one that does not gets a thread that joins it as a
  participant of rank -1 (let go before the controller in each step). The passes, and their
  order against everything else, are the same either way; the poller spares the two
  thread hand-offs a step that the thread costs.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from vehicle_link.clock import Clock

#: The name of the I/O thread, or of the clock's poller.
IO_NAME = "vehicle_link-io"


class IoDriver:
    """Runs ``service_pass(wait_s)`` until stopped (see the module docstring)."""

    def __init__(self, clock: Clock, service_pass: Callable[[float], None], io_poll_s: float) -> None:
        self._clock = clock
        self._service_pass = service_pass
        self._io_poll_s = io_poll_s
        self._thread: threading.Thread | None = None
        self._poller: Any = None
        self._pass_thread: int | None = None  # the thread in a pass the poller runs
        self._stop = threading.Event()
        self._running = threading.Event()  # the thread is in its loop (a participant, in lockstep)

    def start(self) -> None:
        """Start the passes; back once the first has run (poller) or the thread holds a
        lockstep clock (else time could move on without it and the first replies come a
        scheduler-dependent step late)."""
        self._stop.clear()
        add_poller = getattr(self._clock, "add_poller", None)
        if add_poller is not None:
            self._poll_pass()  # the thread's first pass at once, then one every io_poll_s
            self._poller = add_poller(IO_NAME, self._io_poll_s, self._poll_pass)
            return
        self._thread = threading.Thread(target=self._run, name=IO_NAME, daemon=True)
        self._running.clear()
        self._thread.start()
        self._running.wait(timeout=5.0)

    def stop(self) -> None:
        """No pass runs once this returns (one under way is waited for)."""
        self._stop.set()
        if self._poller is not None:
            self._poller.remove()
            self._poller = None
        notify = getattr(self._clock, "notify", None)
        if notify is not None:
            notify()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    def in_pass(self) -> bool:
        """Whether the calling thread is running a pass (the I/O thread, or the poller's)."""
        ident = threading.get_ident()
        return ident == self._pass_thread or (self._thread is not None and ident == self._thread.ident)

    def _poll_pass(self) -> None:
        self._pass_thread = threading.get_ident()
        try:
            self._service_pass(0.0)
        finally:
            self._pass_thread = None

    def _run(self) -> None:
        participant = getattr(self._clock, "participant", None)
        wait_for = getattr(self._clock, "wait_for", None)
        if participant is None or wait_for is None:
            self._running.set()
            while not self._stop.is_set():
                self._service_pass(self._io_poll_s)
            return
        try:
            joined = participant(IO_NAME, rank=-1)
        except TypeError:  # a lockstep clock without ranks
            joined = participant(IO_NAME)
        with joined:
            self._running.set()
            while not self._stop.is_set():
                self._service_pass(0.0)
                try:
                    wait_for(self._stop.is_set, self._io_poll_s)
                except Exception:  # the clock was stopped: the simulation is over
                    return
