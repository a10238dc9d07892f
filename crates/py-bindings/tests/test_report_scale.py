"""Reports that scale (issue 12): bounded plots, per-row output only on request, progress and
cancellation through the report. Small data: the point budget is lowered instead of the data
raised, and nothing is timed."""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from robot_stiffness import _cli_context, _core, cli, csjm, report, vjm
from robot_stiffness._interrupt import Cancelled, cancel


@pytest.fixture(scope="module")
def panda():
    return vjm.Robot.bundled()


@pytest.fixture(scope="module")
def campaign(panda):
    tilt = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 5e-5}
    return vjm.simulate(panda, [tilt], n_poses=40, wrenches_per_pose=4, seed=2)


@pytest.fixture(scope="module")
def diagnosis(panda, campaign):
    return vjm.diagnose(panda, campaign.measurements)


def _points(ax) -> int:
    """Points drawn on one panel: segment ends, line vertices, polygon vertices, patches."""
    n = sum(len(line.get_xdata()) for line in ax.lines)
    for c in ax.collections:
        if isinstance(c, LineCollection):
            n += sum(len(s) for s in c.get_segments())
        else:
            n += sum(len(p.vertices) for p in c.get_paths())
    return n + 4 * len(ax.patches)


VJM_PLOTS = ("residuals.png", "errors_per_pose.png", "effects.png", "verdict.png")
CSJM_PLOTS = ("residuals.png", "effects.png")


@pytest.fixture
def drawn(monkeypatch):
    """Points per panel of every figure saved, in drawing order (a report draws its plots in
    the order of VJM_PLOTS / CSJM_PLOTS)."""
    seen: list = []
    save = Figure.savefig

    def counting(self, fname, *args, **kwargs):
        seen.append([_points(ax) for ax in self.axes])
        return save(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", counting)
    return seen


def test_small_reports_draw_every_row(diagnosis, tmp_path, drawn):
    report.render_report(diagnosis, tmp_path)
    n = len(diagnosis.rows)
    # Each panel: one segment (2 points) per row.
    assert dict(zip(VJM_PLOTS, drawn))["residuals.png"] == [2 * n, 2 * n]


@pytest.mark.parametrize("budget", [60, 120])
def test_plots_stay_within_the_point_budget(diagnosis, tmp_path, drawn, monkeypatch, budget):
    monkeypatch.setattr(report, "MAX_POINTS", budget)
    assert 2 * len(diagnosis.rows) > budget and 4 * len(diagnosis.per_pose) > budget  # binning kicks in
    report.render_report(diagnosis, tmp_path)
    assert len(drawn) == len(VJM_PLOTS)
    points = dict(zip(VJM_PLOTS, drawn))
    for name in ("residuals.png", "errors_per_pose.png"):
        assert points[name] and max(points[name]) <= budget, (name, points[name])
        assert min(points[name]) > budget // 4, (name, points[name])  # binned, not emptied
    assert {p.name for p in tmp_path.iterdir()} == set(report.REPORT_FILES)


def test_binned_plots_keep_the_worst_row(diagnosis, tmp_path, monkeypatch):
    # The largest residual of every bin is drawn, so the worst row of the campaign is too.
    monkeypatch.setattr(report, "MAX_POINTS", 60)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    rows = diagnosis.rows
    err = np.linalg.norm(rows.baseline - rows.measured, axis=1)
    report._row_panel(ax, err, rows.held_out)
    tops = [s[1][1] for c in ax.collections if isinstance(c, LineCollection) for s in c.get_segments()]
    plt.close(fig)
    assert max(tops) == pytest.approx(err.max(), rel=1e-12)


def test_binned_report_is_deterministic(diagnosis, tmp_path, monkeypatch):
    monkeypatch.setattr(report, "MAX_POINTS", 60)
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    report.render_report(diagnosis, a)
    report.render_report(diagnosis, b)
    for name in report.REPORT_FILES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_csjm_report_within_budget(tmp_path, drawn, monkeypatch):
    path = tmp_path / "c.csv"
    path.write_text(_core.csjm_simulate([], seed=1).csv)
    d = csjm.diagnose(path)
    monkeypatch.setattr(report, "MAX_POINTS", 30)
    out = tmp_path / "rep"
    out.mkdir()
    report.render_report(d, out)
    assert len(drawn) == len(CSJM_PLOTS)
    assert max(dict(zip(CSJM_PLOTS, drawn))["residuals.png"]) <= 30
    assert {p.name for p in out.iterdir()} == set(report.CSJM_REPORT_FILES)


def test_progress_runs_to_the_end_of_the_report(diagnosis, tmp_path):
    seen = []
    report.render_report(diagnosis, tmp_path, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert seen[-1] == ("report: done", 5, 5)
    assert [s[1] for s in seen] == [0, 1, 2, 3, 4, 5]


def test_cancel_stops_the_report_between_plots(diagnosis, tmp_path):
    # The CLI's progress callback raises Cancelled once Ctrl-C was seen: the report stops before
    # its next plot, and nothing is written (plots are drawn in memory, written at the end).
    progress = _cli_context.progress_reporter(False, "report")
    calls = []

    def cancel_after_first(stage, done, total):
        calls.append(stage)
        if done == 1:
            cancel.set()
        progress(stage, done, total)

    try:
        with pytest.raises(Cancelled):
            report.render_report(diagnosis, tmp_path, progress=cancel_after_first)
    finally:
        cancel.clear()
    assert calls == ["report: residuals plot", "report: per-pose plot"]
    assert list(tmp_path.iterdir()) == []


def test_cli_writes_rows_only_on_request(campaign, tmp_path):
    data = tmp_path / "data.csv"
    data.write_text(campaign.csv)
    assert cli.main(["diagnose", "vjm", str(data), "--json", str(tmp_path / "d.json"), "--quiet"]) == 0
    doc = json.loads((tmp_path / "d.json").read_text())
    assert "rows" not in doc and {"baseline", "findings", "extended", "unexplained"} <= set(doc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json", "data.csv"]

    assert cli.main(["diagnose", "vjm", str(data), "--json", str(tmp_path / "e.json"), "--rows",
                     str(tmp_path / "rows.csv"), "--report", str(tmp_path / "rep"), "--quiet"]) == 0
    lines = (tmp_path / "rows.csv").read_text().splitlines()
    assert lines[0] == ("pose,set,measured_x,measured_y,measured_z,baseline_x,baseline_y,baseline_z,"
                        "extended_x,extended_y,extended_z")
    assert len(lines) == 1 + len(campaign.measurements)
    first = lines[1].split(",")
    assert first[1] in ("train", "test")
    np.testing.assert_array_equal([float(v) for v in first[2:5]], campaign.measurements.displacement[0])
    assert {p.name for p in (tmp_path / "rep").iterdir()} >= set(report.REPORT_FILES)


def test_csjm_rows_csv(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text(_core.csjm_simulate([], seed=1).csv)
    d = csjm.diagnose(path)
    out = tmp_path / "rows.csv"
    assert cli.main(["diagnose", "csjm", str(path), "--rows", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("row,set,dzeta_x,dzeta_y,dzeta_z,dtau_x,")
    assert lines[0].endswith("extended_residual_x,extended_residual_y,extended_residual_z")
    assert len(lines) == 1 + len(d.rows)
    cells = lines[1].split(",")
    assert int(cells[0]) == d.rows.row[0] and cells[1] == ("test" if d.rows.held_out[0] else "train")
    np.testing.assert_array_equal([float(v) for v in cells[2:5]], d.rows.dzeta[0])
    # Chunked writing gives the same text as one piece.
    assert "".join(d.rows.csv_chunks(rows_per_chunk=7)) == d.rows.csv_text()


# A CLI run whose residuals plot never finishes on its own: Ctrl-C must end it, during the
# report phase, with status 130 and nothing written (the report is drawn in the worker thread
# while the main thread waits for signals).
_STUCK_REPORT = """
import sys, threading
from robot_stiffness import cli, report

def stuck(result, target):
    print("in report", flush=True)
    threading.Event().wait()

report._plot_rows = stuck
sys.exit(cli.main(sys.argv[1:]))
"""


def test_ctrl_c_during_the_report(campaign, tmp_path):
    import os
    import signal
    import subprocess
    import sys

    data = tmp_path / "data.csv"
    data.write_text(campaign.csv)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.Popen(
        [sys.executable, "-c", _STUCK_REPORT, "diagnose", "vjm", str(data), "--quiet", "--json",
         str(tmp_path / "d.json"), "--report", str(tmp_path / "rep")],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        # A shell running the tests in the background ignores SIGINT in its children.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline() == "in report\n"
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=60)  # the plot never ends: only Ctrl-C ends the run
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, stderr
    assert stderr.strip() == "robot-stiffness: interrupted; no output was written"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data.csv"]
