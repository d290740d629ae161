"""The dive report (planner.report.markdown) built from synthetic run folders in the agreed format."""

from __future__ import annotations

import csv
import json
import math
import re
import struct
from pathlib import Path

import cv2
import numpy as np
import pytest

from planner.cli import main as cli_main
from planner.report.data import Event, RunFolderError, load_run
from planner.report.markdown import FIGURE_DIR, REPORT_NAME, generate_report
from planner.report.timeline import state_at, state_spans
from tests.planner.report.report_run import ESTIMATES, PASSES, TRUE_TARGETS, write_run

SECTIONS = ("# Dive report:", "## Track against plan", "## Altitude and the altitude filter",
            "## Tilt and shadow margins", "## Shadows in view",
            "## Target heights", "### Heights against truth", "## States and events",
            "## Maps", "## Data files")


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG from its IHDR chunk, after checking the signature and decoding it."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None and image.shape[:2] == (height, width)
    assert float(image.std()) > 10.0, f"{path} is nearly blank"
    return width, height


def table_rows(text: str, first_header: str) -> list[list[str]]:
    """The body rows of the Markdown table whose header starts with ``| first_header |``."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {first_header} |"))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]])
    return rows


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture
def sim_run(tmp_path: Path, rng: np.random.Generator) -> Path:
    root = tmp_path / "dive_sim"
    write_run(root, rng)
    return root


def test_simulated_run_report_has_every_section_and_real_figures(sim_run: Path) -> None:
    report = generate_report(sim_run)
    assert report == sim_run / REPORT_NAME
    text = report.read_text(encoding="utf-8")
    for heading in SECTIONS:
        assert heading in text, heading
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert sorted(links) == sorted(f"{FIGURE_DIR}/{n}.png" for n in ("track", "altitude", "tilt", "heights"))
    for link in links:
        width, height = png_size(sim_run / link)
        assert 700 <= width <= 2000 and 400 <= height <= 2000, (link, width, height)
    assert "**Status: ✅ COMPLETED** — survey finished" in text


def test_key_figures_equal_what_the_files_say(sim_run: Path) -> None:
    text = generate_report(sim_run).read_text(encoding="utf-8")
    rows = table_rows(text, "key figure")
    figures = dict((r[0], r[1]) for r in rows)
    summary = json.loads((sim_run / "summary.json").read_text())
    assert figures["lowest altitude above the seabed (simulator truth)"] == f"{summary['min_clearance_m']:.2f} m"
    assert figures["dive duration (simulated clock)"].startswith(f"{summary['sim_duration_s']:.1f} s")
    assert figures["target shadows inside the vertical FOV"] == f"{100 * summary['shadow_in_fov_ratio']:.1f} %"
    assert figures["sonar frames measured"] == "4071"
    # every figure shown is explained; fields the report does not know are named, never shown bare
    assert all(len(r) == 3 and r[2] for r in rows)
    assert "controller" not in figures and "states" not in figures and "filter_counters" not in figures
    assert "summary.json holds 1 more field(s) this report does not explain (controller)" in text
    nav = read_csv(sim_run / "nav.csv")
    ne = np.array([[float(r["north_m"]), float(r["east_m"])] for r in nav])
    flown = float(np.hypot(*np.diff(ne, axis=0).T).sum())
    assert figures["distance flown (telemetry)"] == f"{flown:.2f} m"
    assert figures["deepest (telemetry)"] == f"{max(float(r['depth_m']) for r in nav):.2f} m"
    solved = sum(math.isfinite(e[3]) for e in ESTIMATES)
    assert figures["targets (on the map)"] == f"{len(ESTIMATES)} ({solved} with a height)"
    assert figures["warnings / failsafes"] == "1 / 0"
    rejected = int(read_csv(sim_run / "filter.csv")[-1]["rejected_total"])
    assert f"Altimeter readings rejected by the filter: {rejected}." in text
    plan_rows = table_rows(text, "planned pass")
    assert [(r[0], r[1], r[2]) for r in plan_rows] == [(n, f"{a:.2f} m", f"{t:.1f} deg") for n, a, t in PASSES]


def test_heights_table_matches_truth_and_estimates(sim_run: Path) -> None:
    text = generate_report(sim_run).read_text(encoding="utf-8")
    rows = {r[0]: r for r in table_rows(text, "true target")}
    est = {e[0]: e for e in ESTIMATES}
    expected_pairs = {"1": "a", "2": "b", "3": "c", "4": "d"}  # by position; 5 has no estimate, 9 no truth
    for tid, _, _, true_h, shape in TRUE_TARGETS:
        row = rows[tid]
        assert row[1] == shape and row[2] == f"{100 * true_h:.2f}"
        if tid not in expected_pairs:
            assert row[3] == "not found"
            continue
        _, n, e, h, s = est[expected_pairs[tid]]
        assert row[3] == expected_pairs[tid]
        if math.isnan(h):
            assert row[4].startswith("no height")
            continue
        assert row[4] == f"{100 * h:.2f} ± {100 * s:.2f}"
        assert row[5] == f"{100 * (h - true_h):+.2f}"
        truth_ne = next((t[1], t[2]) for t in TRUE_TARGETS if t[0] == tid)
        assert row[7] == f"{math.hypot(n - truth_ne[0], e - truth_ne[1]):.2f}"
    errors = [abs(est[expected_pairs[t[0]]][3] - t[3]) for t in TRUE_TARGETS
              if t[0] in expected_pairs and math.isfinite(est[expected_pairs[t[0]]][3])]
    assert f"Mean \\|error\\| {100 * np.mean(errors):.2f} cm, max {100 * max(errors):.2f} cm" in text
    assert "(false detections?): 9." in text
    assert "True targets with no estimate within 1 m: 5." in text


def test_real_vehicle_run_without_truth_says_so(tmp_path: Path, rng: np.random.Generator) -> None:
    root = tmp_path / "dive_real"
    write_run(root, rng, simulated=False)
    text = generate_report(root).read_text(encoding="utf-8")
    assert "_No truth.json: not a simulation run, heights cannot be scored._" in text
    assert "no simulator truth" in text
    assert not (root / FIGURE_DIR / "heights.png").exists()
    for name in ("track", "altitude", "tilt"):
        png_size(root / FIGURE_DIR / f"{name}.png")
    assert "height error against truth" not in text


def test_run_aborted_early_with_few_rows(tmp_path: Path, rng: np.random.Generator) -> None:
    root = tmp_path / "dive_abort"
    written = write_run(root, rng, abort_at_s=5.0, full_plan=False)
    assert written.n_nav_rows <= 12
    text = generate_report(root).read_text(encoding="utf-8")
    assert "**Status: ⛔ ABORTED** — failsafe: leak detected (in PREFLIGHT at 5.0 s)" in text
    events = table_rows(text, "t (s)")
    assert [r[:3] for r in events] == [["4.5", "**failsafe**", "PREFLIGHT"], ["5.0", "**ABORT**", "PREFLIGHT"]]
    for name in ("track", "altitude", "tilt"):
        png_size(root / FIGURE_DIR / f"{name}.png")


def test_run_with_only_an_event_log(tmp_path: Path) -> None:
    root = tmp_path / "dive_started"
    root.mkdir()
    (root / "events.jsonl").write_text(
        json.dumps({"t_s": 0.0, "kind": "state", "message": "connecting", "state": "CONNECT"}) + "\n")
    text = generate_report(root).read_text(encoding="utf-8")
    assert "**Status: ⚠️ UNKNOWN** — no summary.json" in text and "last state CONNECT at 0.0 s" in text
    assert "_No track or plan data" in text and "_No targets.csv" in text and "_No tilt data" in text
    files = dict((r[0], r[1]) for r in table_rows(text, "file"))
    assert files["nav.csv"] == "missing" and files["events.jsonl"] == "1 events"
    assert not list((root / FIGURE_DIR).glob("*.png"))


def test_truncated_last_lines_are_dropped_with_a_note(sim_run: Path) -> None:
    rows_before = len(read_csv(sim_run / "nav.csv"))
    with (sim_run / "nav.csv").open("a", encoding="utf-8") as handle:
        handle.write("999.5,1.0,2")  # the line being written when the run stopped
    with (sim_run / "events.jsonl").open("a", encoding="utf-8") as handle:
        handle.write('{"t_s": 999.5, "kind": "warn')
    run = load_run(sim_run)
    assert run.nav is not None and run.nav.n_rows == rows_before
    text = generate_report(sim_run).read_text(encoding="utf-8")
    assert f"nav.csv: dropped line {rows_before + 2}, cut short when the run stopped" in text
    assert "events.jsonl: dropped line" in text


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("nav.csv", "t_s,north_m\n0.0,1.0\nabc,2.0\n1.0,3.0\n", r"nav\.csv:3: column 't_s': 'abc' is not a number"),
        ("nav.csv", "t_s,north_m\n0.0,1.0,5\n1.0,2.0\n", r"nav\.csv:2: 3 cells, header has 2"),
        ("tilt.csv", "time,tilt_cmd_deg\n0.0,20\n", r"tilt\.csv:1: header lacks column\(s\) \['t_s'\]"),
        ("events.jsonl", '{"t_s": 0, "kind": "state"}\nnot json\n{"t_s": 1, "kind": "x"}\n',
         r"events\.jsonl:2: not JSON"),
        ("events.jsonl", '{"t_s": "soon", "kind": "state"}\n', r"events\.jsonl:1: 't_s' must be a finite number"),
        ("summary.json", '{"status": "completed",', r"summary\.json:1: not JSON"),
        ("truth.json", '{"objects": []}', r"truth\.json: no 'targets' list"),
        ("plan/plan.json", '{"passes": [{"name": "p", "waypoints": [{"north_m": 1}]}]}',
         r"plan\.json: passes\[0\]: unreadable waypoints"),
        ("targets.csv", "id,north_m,east_m\n1,0,0\n", r"targets\.csv:1: header lacks column\(s\) \['height_m'\]"),
    ],
)
def test_malformed_files_raise_naming_the_file(sim_run: Path, name: str, content: str, message: str) -> None:
    (sim_run / name).write_text(content, encoding="utf-8")
    with pytest.raises(RunFolderError, match=message) as info:
        generate_report(sim_run)
    assert info.value.path == sim_run / name


def test_cli_writes_the_report_and_exits_2_on_bad_input(sim_run: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["report", str(sim_run), "--match-radius-m", "0.3"]) == 0
    assert capsys.readouterr().out.strip() == str(sim_run / REPORT_NAME)
    text = (sim_run / REPORT_NAME).read_text(encoding="utf-8")
    assert "within 0.3 m" in text  # the radius reached the scorer: fewer matches than at 1 m
    far = [t[0] for t in TRUE_TARGETS if min(math.hypot(t[1] - e[1], t[2] - e[2]) for e in ESTIMATES) > 0.3]
    assert 0 < len(far) < len(TRUE_TARGETS) - 1
    assert f"True targets with no estimate within 0.3 m: {', '.join(far)}." in text
    (sim_run / "filter.csv").write_text("t_s,altimeter_m\nx,1\n0,1\n", encoding="utf-8")
    assert cli_main(["report", str(sim_run)]) == 2
    err = capsys.readouterr().err
    assert "filter.csv:2" in err and "'x' is not a number" in err
    assert cli_main(["report", str(tmp_path / "nowhere")]) == 2
    assert "not a run folder" in capsys.readouterr().err


def test_maps_are_included_when_present(sim_run: Path) -> None:
    image = np.zeros((40, 60, 3), np.uint8)
    image[10:30, 20:40] = (40, 120, 200)
    for name in ("mosaic.png", "mosaic_heights.png"):
        cv2.imwrite(str(sim_run / name), image)
    text = generate_report(sim_run).read_text(encoding="utf-8")
    assert "![Seabed mosaic](mosaic.png)" in text
    assert "![2.5D map: mosaic with target heights](mosaic_heights.png)" in text


def test_short_plan_form_is_read(tmp_path: Path, rng: np.random.Generator) -> None:
    root = tmp_path / "dive_short_plan"
    write_run(root, rng, full_plan=False)
    run = load_run(root)
    assert run.plan is not None and [p.name for p in run.plan] == [p[0] for p in PASSES]
    assert [math.degrees(p.tilt_rad) for p in run.plan] == pytest.approx([p[2] for p in PASSES])
    assert all(p.path_ne_m.shape == (8, 2) and p.lanes_ne_m.shape == (0, 2, 2) for p in run.plan)


def test_state_spans_and_state_at_known_answer() -> None:
    events = [Event(10.0, "state", "", {"state": "descend"}), Event(0.0, "state", "CONNECT"),
              Event(5.0, "warning", "x"), Event(30.0, "state", "", {"state": "ABORTED"})]
    spans = state_spans(events, 40.0)
    assert [(s.state, s.start_s, s.end_s) for s in spans] == [("CONNECT", 0.0, 10.0), ("DESCEND", 10.0, 30.0),
                                                               ("ABORTED", 30.0, 40.0)]
    assert state_at(spans, np.array([-1.0, 0.0, 9.9, 10.0, 35.0])) == ["", "CONNECT", "CONNECT", "DESCEND", "ABORTED"]


def test_clock_not_starting_at_zero_and_long_dive_in_minutes(tmp_path: Path) -> None:
    """A run whose clock starts at 5000 s and lasts 25 min: figures drawn, durations right."""
    root = tmp_path / "dive_late_clock"
    root.mkdir()
    t = np.arange(5000.0, 6501.0, 30.0)
    lines = ["t_s,north_m,east_m,depth_m,altitude_m,heading_deg,pitch_deg,roll_deg,mode,armed"]
    lines += [f"{x},{0.01 * (x - 5000)},0,{5 + 0.001 * (x - 5000)},2.0,0,0,0,ALT_HOLD,True" for x in t]
    (root / "nav.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    events = [{"t_s": 5000.0, "kind": "state", "message": "", "state": "PASS_1"},
              {"t_s": 6500.0, "kind": "state", "message": "done", "state": "COMPLETED"}]
    (root / "events.jsonl").write_text("".join(json.dumps(e) + "\n" for e in events), encoding="utf-8")
    run = load_run(root)
    assert (run.start_s(), run.end_s()) == (5000.0, 6500.0)
    assert run.nav is not None and run.nav.col("armed").tolist() == [1.0] * len(t)
    text = generate_report(root).read_text(encoding="utf-8")
    assert "**Status: ✅ COMPLETED** — done (no summary.json)" in text
    assert table_rows(text, "state | entered at (s)")[0][:3] == ["PASS_1", "5000.0", "1500.0"]
    flown = float(t[-1] - t[0]) * 0.01
    assert dict((r[0], r[1]) for r in table_rows(text, "key figure"))["distance flown (telemetry)"] == f"{flown:.2f} m"
    for name in ("track", "altitude"):
        png_size(root / FIGURE_DIR / f"{name}.png")
