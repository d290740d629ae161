"""Helper processes started ahead (perception.child_process.start_early): taken by the next
ChildProcess of their module, and stopped cleanly when never taken."""

from __future__ import annotations

import subprocess

import perception.child_process as cp
from perception.mapping.map_process import SurveyMapProcess
from perception.mapping.survey_map import SurveyMap

MODULE = "perception.mapping.map_process"


def test_a_child_started_ahead_is_the_one_taken(monkeypatch) -> None:
    monkeypatch.setattr(cp, "_EARLY", {})
    cp.start_early(MODULE)
    early = cp._EARLY[MODULE][0]
    worker = SurveyMapProcess(SurveyMap())
    try:
        assert worker.process is early
        assert cp._EARLY[MODULE] == []
        assert worker.query("targets") == []  # it answers as a child started then would
    finally:
        worker.close()
    assert early.wait(5.0) == 0
    # None left ahead: the next one starts now.
    again = SurveyMapProcess(SurveyMap())
    try:
        assert again.process is not early and again.query("targets") == []
    finally:
        again.close()


def test_a_child_started_ahead_and_never_taken_is_stopped(monkeypatch) -> None:
    monkeypatch.setattr(cp, "_EARLY", {})
    cp.start_early("sim_harness.render_worker")
    cp.start_early(MODULE)
    left = [p for waiting in cp._EARLY.values() for p in waiting]
    dead = left[1]
    dead.kill()
    dead.wait()
    cp._stop_early()
    assert cp._EARLY == {}
    assert left[0].poll() is not None, "the unused child is stopped"
    assert all(p.stdin.closed and p.stdout.closed for p in left)


def test_a_dead_child_started_ahead_is_not_taken(monkeypatch) -> None:
    monkeypatch.setattr(cp, "_EARLY", {})
    cp.start_early(MODULE)
    dead = cp._EARLY[MODULE][0]
    dead.kill()
    dead.wait()
    worker = SurveyMapProcess(SurveyMap())
    try:
        assert worker.process is not dead and worker.query("targets") == []
    finally:
        worker.close()
    assert isinstance(worker.process, subprocess.Popen)


def test_children_started_early_for_a_block_are_stopped_with_it_unless_taken(monkeypatch) -> None:
    monkeypatch.setattr(cp, "_EARLY", {})
    with cp.started_early(MODULE, "sim_harness.render_worker"):
        unused = cp._EARLY["sim_harness.render_worker"][0]
        worker = SurveyMapProcess(SurveyMap())  # takes the map process's
    try:
        assert unused.poll() is not None, "the block's unused child is stopped when it ends"
        assert worker.query("targets") == [] and worker.process.poll() is None, "the taken one lives on"
    finally:
        worker.close()
    assert all(not waiting for waiting in cp._EARLY.values())
