"""A helper process: a fresh interpreter running ``python -m MODULE`` that takes messages on
its stdin and answers, in order, on its stdout; each message a length-prefixed pickle.

A fresh interpreter, not a fork (the dry run has threads running and a forked copy of their
locks could hang it) and not multiprocessing's spawn (which re-runs the parent's main
script). A reader thread takes each reply off the pipe as soon as it is written, so the
child never waits on a full pipe with a finished answer (a sonar frame is larger than a
pipe's buffer) and works on while the parent does. A child that dies ends the wait for its
next reply with an error naming its exit code, never a wait forever; a Ctrl-C reaches the
parent only (the child ignores SIGINT: the parent decides what stops).

Used by :mod:`sim_harness.render_worker` (the simulator's sonar pings),
:mod:`perception.mapping.map_process` (the on-board frame-to-map chain) and
:mod:`planner.report.figure_worker` (the dry run's pictures). :func:`start_early` starts a
child before it is needed, so that its start overlaps the parent's own.
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import IO, Any

try:
    import fcntl
except ImportError:  # not on Windows
    fcntl = None  # type: ignore[assignment]

_HEADER = struct.Struct("<Q")


class ChildProcessGone(RuntimeError):
    """The helper process died or sent something it should not."""


def write_message(stream: IO[bytes], obj: Any) -> None:
    """One length-prefixed pickle, flushed."""
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data)))
    stream.write(data)
    stream.flush()


def read_message(stream: IO[bytes]) -> Any:
    """The next length-prefixed pickle; EOFError at the end of the stream."""
    header = _read_exactly(stream, _HEADER.size)
    return pickle.loads(_read_exactly(stream, _HEADER.unpack(header)[0]))


def answer_each(messages: IO[bytes], replies: IO[bytes], answer: Callable[[Any], Any], *,
                after: Callable[[], None] | None = None) -> None:
    """A child's loop: ``answer(message)`` written back for every message, in order, until
    ``None`` or the end of the stream; ``after()`` once each answer is written (work the
    parent need not wait for). Ends quietly when the parent is gone (a broken pipe)."""
    while True:
        try:
            message = read_message(messages)
        except EOFError:
            return
        if message is None:
            return
        try:
            write_message(replies, answer(message))
        except (BrokenPipeError, OSError):
            return
        if after is not None:
            after()


def _read_exactly(stream: IO[bytes], n: int) -> bytes:
    chunks, remaining = [], n
    while remaining:
        chunk = stream.read(remaining)
        if not chunk:
            raise EOFError("the stream ended")
        chunks.append(chunk)
        remaining -= len(chunk)
    return b"".join(chunks)


#: Pipe buffer asked for, bytes (Linux; at most /proc/sys/fs/pipe-max-size, 1 MiB by
#: default): a sonar frame and its truth (0.1-0.3 MB) fit whole, so the child writes its
#: reply and goes on to the next job instead of waiting, 64 KiB at a time, for the parent's
#: reader thread to get the interpreter (about a tenth of the render process's time).
PIPE_BYTES = 1 << 20


def _widen_pipe(fd: int) -> None:
    """Ask for :data:`PIPE_BYTES` of pipe buffer (nothing where the system cannot)."""
    set_size = getattr(fcntl, "F_SETPIPE_SZ", None) if fcntl is not None else None
    if set_size is None:
        return
    try:
        fcntl.fcntl(fd, set_size, PIPE_BYTES)
    except OSError:
        pass  # a lower limit (pipe-max-size) or another system: the default buffer works, only slower


def child_streams() -> tuple[IO[bytes], IO[bytes]]:
    """In the child: (its messages, its replies), with SIGINT ignored and anything the child
    prints sent to stderr, away from the replies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # C-level prints too
    return sys.stdin.buffer, replies


def _spawn(module: str) -> subprocess.Popen[bytes]:
    process = subprocess.Popen(
        [sys.executable, "-m", module], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        env={**os.environ, "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "1")})
    assert process.stdin is not None and process.stdout is not None
    for stream in (process.stdin, process.stdout):
        _widen_pipe(stream.fileno())
    return process


#: Children started ahead (:func:`start_early`), by module, not yet taken by a ChildProcess.
_EARLY: dict[str, list[subprocess.Popen[bytes]]] = {}
_EARLY_LOCK = threading.Lock()


def start_early(module: str) -> subprocess.Popen[bytes]:
    """Start ``python -m module`` now for the next :class:`ChildProcess` of ``module`` to
    take, so that the child's start (a fresh interpreter importing numpy, OpenCV and its
    modules: about half a second) overlaps what this process does meanwhile. One not taken
    is stopped by :func:`stop_early` (:func:`started_early` does both), at the latest when
    this process exits."""
    process = _spawn(module)
    with _EARLY_LOCK:
        if not _EARLY:
            atexit.register(_stop_early)
        _EARLY.setdefault(module, []).append(process)
    return process


@contextlib.contextmanager
def started_early(*modules: str) -> Iterator[None]:
    """Each module's child started ahead (:func:`start_early`) for the block; those the block
    did not take are stopped when it ends, however it ends (a refused input, an error)."""
    started = [start_early(module) for module in modules]
    try:
        yield
    finally:
        stop_early(started)


def stop_early(processes: Sequence[subprocess.Popen[bytes]]) -> None:
    """Stop those of ``processes`` started ahead that no ChildProcess took (:func:`_stop_early`)."""
    with _EARLY_LOCK:
        left = [p for p in processes if any(p in waiting for waiting in _EARLY.values())]
        for waiting in _EARLY.values():
            waiting[:] = [p for p in waiting if p not in left]
    _kill_all(left)


def _take_early(module: str) -> subprocess.Popen[bytes] | None:
    with _EARLY_LOCK:
        waiting = _EARLY.get(module, [])
        while waiting:
            process = waiting.pop(0)
            if process.poll() is None:
                return process
            _close_pipes(process)  # died while it waited (killed): start another
    return None


def _close_pipes(process: subprocess.Popen[bytes]) -> None:
    for stream in (process.stdin, process.stdout):
        if stream is not None:
            with contextlib.suppress(OSError):  # already broken: nothing left to close
                stream.close()


def _stop_early() -> None:
    """Stop every child started ahead and never taken: killed, as they hold nothing (no
    message reached them), so that an early exit (a refused input) does not wait for their
    imports."""
    with _EARLY_LOCK:
        left = [p for waiting in _EARLY.values() for p in waiting]
        _EARLY.clear()
    _kill_all(left)


def _kill_all(processes: Sequence[subprocess.Popen[bytes]]) -> None:
    for process in processes:
        process.kill()
        process.wait()
        _close_pipes(process)


class ChildProcess:
    """``python -m module`` with messages to it (:meth:`send`) and its replies in order
    (:meth:`receive`); ``what`` names it in errors ("the sonar render process"). It takes a
    child started ahead for ``module`` (:func:`start_early`) when there is one."""

    def __init__(self, module: str, *, what: str, error: type[RuntimeError] = ChildProcessGone) -> None:
        self._what = what
        self._error = error
        self._process = _take_early(module) or _spawn(module)
        assert self._process.stdin is not None and self._process.stdout is not None
        self._to_child = self._process.stdin
        self._from_child = self._process.stdout
        self._replies: collections.deque[Any] = collections.deque()
        self._arrived = threading.Condition()
        self._ended: str | None = None  # why the replies stopped, once they have
        self._closed = False
        self._reader = threading.Thread(target=self._read_replies, name=f"{module}-reader", daemon=True)
        self._reader.start()

    def _read_replies(self) -> None:
        while True:
            try:
                reply = read_message(self._from_child)
            except (EOFError, OSError) as exc:
                with self._arrived:
                    self._ended = f"{self._what} ended (exit code {self._process.wait()}): {exc}"
                    self._arrived.notify_all()
                return
            except Exception as exc:  # a reply that does not unpickle: stop the child, say so
                self._process.kill()
                with self._arrived:
                    self._ended = f"{self._what} sent a reply that cannot be read: {exc!r}"
                    self._arrived.notify_all()
                return
            with self._arrived:
                self._replies.append(reply)
                self._arrived.notify_all()

    @property
    def process(self) -> subprocess.Popen[bytes]:
        """The child (tests kill it to see the death reported)."""
        return self._process

    def send(self, obj: Any) -> None:
        """One message to the child."""
        try:
            write_message(self._to_child, obj)
        except (BrokenPipeError, OSError) as exc:
            raise self._error(f"{self._what} is gone (exit code {self._process.poll()})") from exc

    def receive(self) -> Any:
        """The child's next reply, waiting for it."""
        with self._arrived:
            while not self._replies:
                if self._ended is not None:
                    raise self._error(self._ended)
                self._arrived.wait()
            return self._replies.popleft()

    def close(self) -> None:
        """Ask the child to stop (``None``; it finishes what it is on) and close the pipes."""
        if self._closed:
            return
        self._closed = True
        try:
            write_message(self._to_child, None)
        except (BrokenPipeError, OSError):
            pass
        try:
            self._to_child.close()
        except (BrokenPipeError, OSError):  # what was left to flush cannot be: close the pipe itself
            getattr(self._to_child, "raw", self._to_child).close()
        try:
            self._process.wait(2.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._reader.join(2.0)
        if not self._reader.is_alive():
            self._from_child.close()
