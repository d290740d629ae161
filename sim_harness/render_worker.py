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
from collections.abc import Callable
from typing import IO, Any

from perception.child_process import ChildProcess, answer_each, child_streams, read_message


class RenderWorkerError(RuntimeError):
    """The render process died or sent something it should not."""


def strip_label_images(truth: Any) -> Any:
    """The frame truth without its two label images (small enough to keep for a whole dive)."""
    if not hasattr(truth, "labels"):
        return truth
    return dataclasses.replace(truth, labels=truth.labels[:0, :0], owner=truth.owner[:0, :0])


def serve(jobs: IO[bytes], results: IO[bytes]) -> None:
    """The child's loop: the set-up message, then render every job in order until ``None``
    (a child started ahead and never used ends at once: no set-up message)."""
    try:
        renderer, pose_factory, keep_label_images = read_message(jobs)
    except EOFError:
        return

    def render(job: tuple[int, float, dict[str, float]]) -> tuple[Any, ...]:
        seq, t_s, pose_fields = job
        try:
            frame, truth = renderer.render(pose_factory(**pose_fields), t_s)
        except Exception as exc:  # sent back and raised in the parent, where it belongs
            return seq, "error", exc, None
        return seq, "ok", frame, truth if keep_label_images else strip_label_images(truth)

    answer_each(jobs, results, render)


class RenderWorker:
    """A renderer in a child process (:class:`perception.child_process.ChildProcess`):
    :meth:`submit` pings, :meth:`result` them in order.

    ``submit`` is called from the simulator's thread and ``result`` from the controller's;
    the child renders on while the controller works.
    """

    def __init__(self, renderer: Any, pose_factory: Callable[..., Any], *, keep_label_images: bool) -> None:
        self._child = ChildProcess("sim_harness.render_worker", what="the sonar render process",
                                   error=RenderWorkerError)
        self._next_seq = 0
        self._child.send((renderer, pose_factory, keep_label_images))

    @property
    def process(self) -> Any:
        """The child process (:attr:`perception.child_process.ChildProcess.process`)."""
        return self._child.process

    def submit(self, t_s: float, pose_fields: dict[str, float]) -> int:
        """Queue one ping; its sequence number (results come back in this order)."""
        seq = self._next_seq
        self._next_seq += 1
        self._child.send((seq, float(t_s), dict(pose_fields)))
        return seq

    def result(self, seq: int) -> tuple[Any, Any]:
        """(frame, truth) of ping ``seq``, waiting for it; raises what its render raised.

        Asked in increasing ``seq``; results of earlier pings never asked for (frames the
        driver's buffer lost) are dropped."""
        while True:
            got, kind, frame, truth = self._child.receive()
            if got >= seq:
                break
        if got != seq:
            raise RenderWorkerError(f"the sonar render process answered ping {got} for ping {seq}")
        if kind == "error":
            raise frame
        return frame, truth

    def close(self) -> None:
        """Stop the child (it finishes the ping it is on) and close the pipes."""
        self._child.close()


#: OpenCV threads in the render process. The process is the parallelism (it renders while
#: the controller works); OpenCV's own pool splitting one small filter or remap over the
#: cores costs more CPU in waking and syncing its threads than it saves (about 0.3-0.5 ms
#: a ping on 2 cores), CPU the controller and the map process then lack. Frames are the
#: same with any number of threads.
RENDER_OPENCV_THREADS = 1


def main() -> None:
    """The child process (:func:`perception.child_process.child_streams`)."""
    import cv2  # the renderer's; only this process is set to one thread

    import sim_harness.sonar.renderer  # noqa: F401  (the set-up message's classes: imported while it comes)

    cv2.setNumThreads(RENDER_OPENCV_THREADS)
    serve(*child_streams())


if __name__ == "__main__":
    # Through the module's own name, so that what it pickles names its classes there, not
    # in ``__main__``.
    from sim_harness.render_worker import main as _main

    _main()
