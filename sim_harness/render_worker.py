"""Pings rendered in a child process, in order, so the next ping renders on another core
while the controller works on the last one.

A frame depends only on its pose, its ping time and the renderer's seed (the noise is
drawn from ``seed`` and ``timestamp_s``: :meth:`sim_harness.sonar.renderer.SonarRenderer.render`),
so where it is rendered changes nothing in it. The child is a fresh interpreter,
``python -m sim_harness.render_worker`` (not a fork: the dry run has threads running and a
forked copy of their locks could hang it; not multiprocessing's spawn, which re-runs the
parent's main script). It reads the renderer pickled once from its stdin, then jobs, and
writes results in job order to its stdout, each message a length-prefixed pickle. A
render error (a pose under the seabed) comes back and is raised by
:meth:`RenderWorker.result`, as an in-thread render would raise it; a child that dies
ends the read with an error naming its exit code, never a wait forever.
"""

from __future__ import annotations

import dataclasses
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
from collections.abc import Callable
from typing import IO, Any

_HEADER = struct.Struct("<Q")


class RenderWorkerError(RuntimeError):
    """The render process died or sent something it should not."""


def strip_label_images(truth: Any) -> Any:
    """The frame truth without its two label images (small enough to keep for a whole dive)."""
    if not hasattr(truth, "labels"):
        return truth
    return dataclasses.replace(truth, labels=truth.labels[:0, :0], owner=truth.owner[:0, :0])


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


def _read_exactly(stream: IO[bytes], n: int) -> bytes:
    chunks, remaining = [], n
    while remaining:
        chunk = stream.read(remaining)
        if not chunk:
            raise EOFError("the stream ended")
        chunks.append(chunk)
        remaining -= len(chunk)
    return b"".join(chunks)


def serve(jobs: IO[bytes], results: IO[bytes]) -> None:
    """The child's loop: the set-up message, then render every job in order until ``None``."""
    renderer, pose_factory, keep_label_images = read_message(jobs)
    while True:
        try:
            job = read_message(jobs)
        except EOFError:
            return
        if job is None:
            return
        seq, t_s, pose_fields = job
        try:
            frame, truth = renderer.render(pose_factory(**pose_fields), t_s)
            if not keep_label_images:
                truth = strip_label_images(truth)
            reply: tuple[Any, ...] = (seq, "ok", frame, truth)
        except Exception as exc:  # sent back and raised in the parent, where it belongs
            reply = (seq, "error", exc, None)
        try:
            write_message(results, reply)
        except (BrokenPipeError, OSError):
            return


class RenderWorker:
    """A renderer in a child process: :meth:`submit` pings, :meth:`result` them in order.

    ``submit`` is called from the simulator's thread and ``result`` from the controller's.
    A reader thread takes each result off the pipe as soon as it is written, so the child
    never waits with a finished frame (a frame is larger than a pipe's buffer) and renders
    on while the controller works.
    """

    def __init__(self, renderer: Any, pose_factory: Callable[..., Any], *, keep_label_images: bool) -> None:
        self._process = subprocess.Popen(
            [sys.executable, "-m", "sim_harness.render_worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            env={**os.environ, "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "1")})
        assert self._process.stdin is not None and self._process.stdout is not None
        self._jobs = self._process.stdin
        self._results = self._process.stdout
        self._next_seq = 0
        self._received: dict[int, tuple[Any, ...]] = {}
        self._arrived = threading.Condition()
        self._ended: str | None = None  # why the results stopped, once they have
        self._closed = False
        self._send((renderer, pose_factory, keep_label_images))
        self._reader = threading.Thread(target=self._read_results, name="sonar-render-reader", daemon=True)
        self._reader.start()

    def _read_results(self) -> None:
        while True:
            try:
                reply = read_message(self._results)
            except (EOFError, OSError, pickle.UnpicklingError) as exc:
                with self._arrived:
                    self._ended = f"the sonar render process ended (exit code {self._process.wait()}): {exc}"
                    self._arrived.notify_all()
                return
            with self._arrived:
                self._received[reply[0]] = reply
                self._arrived.notify_all()

    def _send(self, obj: Any) -> None:
        try:
            write_message(self._jobs, obj)
        except (BrokenPipeError, OSError) as exc:
            raise RenderWorkerError(f"the sonar render process is gone (exit code {self._process.poll()})") from exc

    def submit(self, t_s: float, pose_fields: dict[str, float]) -> int:
        """Queue one ping; its sequence number (results come back in this order)."""
        seq = self._next_seq
        self._next_seq += 1
        self._send((seq, float(t_s), dict(pose_fields)))
        return seq

    def result(self, seq: int) -> tuple[Any, Any]:
        """(frame, truth) of ping ``seq``, waiting for it; raises what its render raised.

        Asked in increasing ``seq``; results of earlier pings never asked for (frames the
        driver's buffer lost) are dropped."""
        with self._arrived:
            while seq not in self._received:
                if self._ended is not None:
                    raise RenderWorkerError(self._ended)
                self._arrived.wait()
            _, kind, frame, truth = self._received.pop(seq)
            for older in [k for k in self._received if k < seq]:
                del self._received[older]
        if kind == "error":
            raise frame
        return frame, truth

    def close(self) -> None:
        """Stop the child (it finishes the ping it is on) and close the pipes."""
        if self._closed:
            return
        self._closed = True
        try:
            write_message(self._jobs, None)
        except (BrokenPipeError, OSError):
            pass
        try:
            self._jobs.close()
        except (BrokenPipeError, OSError):  # what was left to flush cannot be: close the pipe itself
            self._jobs.raw.close()
        try:
            self._process.wait(2.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._reader.join(2.0)
        if not self._reader.is_alive():
            self._results.close()


def main() -> None:
    """The child process: results on the real stdout, anything printed goes to stderr; a
    Ctrl-C at the terminal is the parent's to handle (the child ends when its stdin does)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    results = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    serve(sys.stdin.buffer, results)


if __name__ == "__main__":
    main()
