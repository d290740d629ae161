"""benchmarks/bench_dive.py: the dive's tree of processes and their CPU by name (Linux /proc)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchmarks.bench_dive import cpu_by_process, process_cpu, tree_pids

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(),
                                reason="bench_dive reads each process's CPU time from Linux /proc; others have none")


def test_a_helper_of_the_dive_is_named_by_its_module_and_its_cpu_counted() -> None:
    # A stand-in dive: a process that burns CPU, with a helper started as the dive starts
    # them (python -m MODULE, waiting on its stdin).
    dive = subprocess.Popen([sys.executable, "-c", (
        "import subprocess, sys, time\n"
        "h = subprocess.Popen([sys.executable, '-m', 'sim_harness.render_worker'], stdin=subprocess.PIPE)\n"
        "t = time.process_time()\n"
        "while time.process_time() - t < 0.5: pass\n"
        "sys.stdout.write('ready\\n'); sys.stdout.flush(); time.sleep(30)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert dive.stdout is not None and dive.stdout.readline() == "ready\n"
        time.sleep(0.5)  # the helper's own imports
        pids = tree_pids(dive.pid)
        assert pids[0] == dive.pid and len(pids) == 2
        cpu = {p: got for p in pids if (got := process_cpu(p, dive.pid)) is not None}
        split = cpu_by_process(cpu)
        assert set(split) == {"dive", "render"}
        assert split["dive"] >= 0.45  # the half second it burnt, to a clock tick
        assert split["render"] > 0.0
    finally:
        for p in tree_pids(dive.pid)[1:]:
            subprocess.run(["kill", "-9", str(p)], check=False)
        dive.kill()
        dive.wait()
        assert dive.stdout is not None
        dive.stdout.close()
    assert process_cpu(dive.pid, dive.pid) is None  # gone
