"""Whole dry-run dives: simulated seconds per wall second and per CPU second, peak memory.

Each dive runs as ``shadowsurvey sim SCENARIO --out TMP --no-progress`` in a child
process, so its wall time, its CPU time (user + system, every thread and any process it
starts) and its peak resident memory are its own. A fixed reference workload (numpy sorts
and a Python loop, single-threaded) is timed before and after each dive in this process:
on a shared host a slow minute shows as a slow reference.

``python -m benchmarks.bench_dive [--scenarios NAME ...] [--repeats N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from pathlib import Path

import numpy as np

#: The dives measured by default: the shipped default dive, the field-scale site and the
#: same site over a quarter of its area (the same floor, lanes half as long and half as
#: many: whole-dive time against dive length).
SCENARIOS = ("paper-targets", "harbour-field-quarter", "harbour-field")
QUARTER = "harbour-field-quarter"


def quarter_site(folder: Path) -> Path:
    """harbour-field with its area halved east and north about its first corner, in ``folder``."""
    from planner.dryrun.scenario import load_scenario

    source = load_scenario("harbour-field").scene_path.parent
    site = folder / QUARTER
    shutil.copytree(source, site)
    area = json.loads((site / "area.geojson").read_text(encoding="utf-8"))
    for feature in area["features"]:
        rings = feature["geometry"]["coordinates"]
        lon0, lat0 = rings[0][0]
        feature["geometry"]["coordinates"] = [[[lon0 + 0.5 * (lon - lon0), lat0 + 0.5 * (lat - lat0)]
                                               for lon, lat in ring] for ring in rings]
    (site / "area.geojson").write_text(json.dumps(area, indent=1), encoding="utf-8")
    # The targets inside the quarter (the north-east half of each axis goes, and the
    # dive's checks refuse a target the survey never sees); 1 m of margin for their size.
    head, *blocks = (site / "scene.toml").read_text(encoding="utf-8").split("[[targets]]")
    kept = [b for b in blocks if _inside_quarter(tomllib.loads(b))]
    (site / "scene.toml").write_text("[[targets]]".join([head, *kept]), encoding="utf-8")
    return site


def _inside_quarter(target: dict) -> bool:
    return target["north_m"] <= 10.0 - 1.0 and target["east_m"] <= 15.0 - 1.0


def reference_workload_s() -> float:
    """Wall time of a fixed CPU workload (about 0.3 s on the development machine), s."""
    t0 = time.perf_counter()
    values = np.arange(200_000, dtype=np.float64)[::-1].copy()
    for _ in range(20):
        np.sort(values)
    total = 0
    for i in range(1_000_000):
        total += i * i
    return time.perf_counter() - t0


def tree_pids(pid: int) -> list[int]:
    """``pid`` and all its descendants now (Linux /proc; those gone are left out)."""
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/task/{p}/children", encoding="ascii") as children:
                todo.extend(int(c) for c in children.read().split())
        except (OSError, ValueError):
            continue
        found.append(p)
    return found


def tree_rss_kib(pid: int) -> int:
    """Resident memory of ``pid`` and all its descendants now, KiB (0 once gone; Linux /proc)."""
    total = 0
    for p in tree_pids(pid):
        try:
            with open(f"/proc/{p}/status", encoding="ascii") as status:
                total += next((int(line.split()[1]) for line in status if line.startswith("VmRSS:")), 0)
        except (OSError, ValueError):
            continue
    return total


#: The dive's helper processes by the module they run (``python -m MODULE``), as reported.
HELPERS = {"sim_harness.render_worker": "render", "perception.mapping.map_process": "map",
           "planner.report.figure_worker": "figure"}
_CLOCK_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def process_cpu(pid: int, root: int) -> tuple[str, float] | None:
    """(``dive``, a helper's name of :data:`HELPERS` or its command, CPU s: user + system so
    far) of one process of the dive's tree, or None once gone."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            fields = stat.read().rsplit(")", 1)[1].split()
        with open(f"/proc/{pid}/cmdline", "rb") as cmd:
            argv = cmd.read().decode(errors="replace").split("\0")
    except (OSError, IndexError):
        return None
    cpu_s = (int(fields[11]) + int(fields[12])) / _CLOCK_TICKS
    if pid == root:
        return "dive", cpu_s
    module = argv[argv.index("-m") + 1] if "-m" in argv[:-1] else " ".join(argv)[:40]
    return HELPERS.get(module, module), cpu_s


def _sample_tree(pid: int, stop: threading.Event, peak: list[int], cpu: dict[int, tuple[str, float]]) -> None:
    while not stop.wait(0.2):
        peak[0] = max(peak[0], tree_rss_kib(pid))
        for p in tree_pids(pid):
            got = process_cpu(p, pid)
            if got is not None and got[0]:
                cpu[p] = got


def cpu_by_process(cpu: dict[int, tuple[str, float]]) -> dict[str, float]:
    """CPU s per name (the dive's own, each helper's), summed over the processes of a name."""
    out: dict[str, float] = {}
    for name, cpu_s in cpu.values():
        out[name] = out.get(name, 0.0) + cpu_s
    return out


def run_dive(scenario: str) -> dict[str, float | str]:
    """One dive in a child process; its figures."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        source = str(quarter_site(Path(tmp))) if scenario == QUARTER else scenario
        err = Path(tmp) / "stderr.txt"
        t0 = time.perf_counter()
        with err.open("w") as handle:
            proc = subprocess.Popen([sys.executable, "-m", "planner.cli", "sim", source, "--out", str(out),
                                     "--no-progress"], stdout=subprocess.DEVNULL, stderr=handle)
            # The summed memory of the dive's processes, sampled every 0.2 s while it runs.
            stop, tree_peak, cpu = threading.Event(), [0], {}
            sampler = threading.Thread(target=_sample_tree, args=(proc.pid, stop, tree_peak, cpu), daemon=True)
            sampler.start()
            # wait4: this child's own CPU time (its threads and children included) and the
            # largest peak of any one of its processes
            _, status, usage = os.wait4(proc.pid, 0)
            proc.returncode = os.waitstatus_to_exitcode(status)
            stop.set()
            sampler.join()
        wall = time.perf_counter() - t0
        cpu_s = usage.ru_utime + usage.ru_stime
        peak_kib = int(usage.ru_maxrss)
        if proc.returncode != 0:
            return {"scenario": scenario, "error": (err.read_text().strip().splitlines() or ["?"])[-1]}
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    sim_s = float(summary["sim_duration_s"])
    return {"scenario": scenario, "status": summary["status"], "sim_s": sim_s, "wall_s": wall,
            "cpu_s": cpu_s, "sim_per_wall": sim_s / wall, "sim_per_cpu": sim_s / max(cpu_s, 1e-9),
            "peak_mib": peak_kib / 1024.0, "tree_peak_mib": tree_peak[0] / 1024.0,
            "cpu_by_process": cpu_by_process(cpu)}


def measure(scenarios: tuple[str, ...], repeats: int) -> list[str]:
    """Markdown rows of every dive, with the reference workload around each."""
    rows = ["| scenario | status | simulated s | wall s | CPU s | CPU s: dive / render / map / figure "
            "| sim s / wall s | sim s / CPU s | peak RSS MiB, all processes (largest one) "
            "| reference s (before / after) |",
            "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
    for scenario in scenarios:
        for _ in range(repeats):
            before = reference_workload_s()
            r = run_dive(scenario)
            after = reference_workload_s()
            if "error" in r:
                rows.append(f"| {scenario} | failed: {r['error']} | | | | | | | | {before:.3f} / {after:.3f} |")
                continue
            split = r["cpu_by_process"]
            parts = " / ".join(f"{split.get(name, 0.0):.1f}" for name in ("dive", "render", "map", "figure"))
            rows.append(f"| {scenario} | {r['status']} | {r['sim_s']:.0f} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} "
                        f"| {parts} | {r['sim_per_wall']:.1f} | {r['sim_per_cpu']:.1f} | {r['tree_peak_mib']:.0f} "
                        f"({r['peak_mib']:.0f}) "
                        f"| {before:.3f} / {after:.3f} |")
    return rows


def main(argv: list[str] | None = None) -> None:
    """Print the Markdown section."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args(argv)
    print("## Whole dives\n")
    print(f"Machine: {os.uname().machine}, {os.cpu_count()} cores, Python {sys.version.split()[0]}; "
          f"load average {os.getloadavg()[0]:.1f}. CPU s counts the dive's process and its three helper "
          "processes (the sonar render process, the on-board map process and the figure process), and "
          "split by process as sampled from /proc every 0.2 s (a process's last 0.2 s can be missed); peak RSS "
          "is the sum over the four, sampled every 0.2 s, and in brackets the largest peak of any one.\n")
    print("\n".join(measure(tuple(args.scenarios), args.repeats)))


if __name__ == "__main__":
    main()
