"""Issue 14, the console script: nothing lost, nothing hangs, nothing silently wrong.

Output folders never lose a file the tool did not write; every output path is checked before
the computation; temporaries are removed on errors, Ctrl-C and SIGTERM; bad flags and effect
specs give one line naming the flag; a broken pipe is not an error; a bug gives one line.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List

import pytest

from conftest import listing, run_cli

MANIFEST = ".robot-stiffness-manifest.json"


def digest(root: Path) -> Dict[str, str]:
    """SHA-256 of every file under ``root`` (hidden ones included), by relative path."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def leftovers(*roots: Path) -> List[str]:
    return [str(p) for root in roots for p in root.rglob("*") if ".tmp-" in p.name]


def signed(folder: Path, manifest: dict) -> None:
    """Writes ``manifest`` into ``folder`` signed with the session's key, as the tool would have
    written it (an earlier run of another version; forged manifests are test_forged_*)."""
    from robot_stiffness import _outputs

    key = _outputs._manifest_key(create=True)
    manifest["signature"] = _outputs._signature(key, folder, manifest["files"])
    (folder / MANIFEST).write_text(json.dumps(manifest))


def one_error_line(proc: subprocess.CompletedProcess) -> str:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    """A small VJM campaign (fast to diagnose)."""
    d = tmp_path_factory.mktemp("small")
    proc = run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "12", "--seed", "5",
                    "--effect", "joint_tilt:joint=3,axis=x,compliance=5e-5"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d / "c.csv"


@pytest.fixture(scope="module")
def csjm_csv(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("csjm")
    proc = run_cli(["simulate", "csjm", "--out", "m.csv", "--seed", "2"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d / "m.csv"


# ----------------------------------------------------------------------------- output folders


def test_missing_report_folder_is_created_with_a_manifest(small, tmp_path):
    proc = run_cli(["diagnose", "vjm", str(small), "--report", "rep", "--quiet"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((tmp_path / "rep" / MANIFEST).read_text())
    files = digest(tmp_path / "rep")
    assert set(manifest["files"]) == {"report.md", "residuals.png", "errors_per_pose.png", "effects.png", "verdict.png"}
    for name, sha in manifest["files"].items():
        assert files[name] == sha
    assert not leftovers(tmp_path)


def test_empty_report_folder_is_used(csjm_csv, tmp_path):
    (tmp_path / "rep").mkdir()
    proc = run_cli(["diagnose", "csjm", str(csjm_csv), "--report", "rep"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "rep" / "report.md").read_text().startswith("# CSJM")
    assert not leftovers(tmp_path)


@pytest.mark.parametrize("command", ["diagnose", "demo"])
def test_non_empty_folder_is_refused_without_force(small, tmp_path, command):
    """Before the fix the folder (with the user's data in it) was replaced wholesale."""
    shutil.copy(small, tmp_path / "data.csv")
    (tmp_path / "notes.txt").write_text("my notes\n")
    before = digest(tmp_path)
    if command == "diagnose":
        args = ["diagnose", "vjm", "data.csv", "--report", ".", "--json", "d.json"]
        flag = "--report ."
    else:
        args = ["demo", "--out", "."]
        flag = "--out ."
    proc = run_cli(args, cwd=tmp_path)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert flag in line and "--force" in line and "not empty" in line, line
    assert digest(tmp_path) == before and listing(tmp_path) == sorted(before)


def test_force_replaces_only_the_tools_own_files(small, tmp_path):
    shutil.copy(small, tmp_path / "data.csv")
    rep = tmp_path / "rep"
    proc = run_cli(["diagnose", "vjm", "data.csv", "--report", "rep", "--quiet"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    # The user adds files of their own, and an earlier run left a file it no longer writes.
    shutil.copy(small, rep / "data.csv")
    (rep / "notes.txt").write_text("keep me\n")
    (rep / "sub").mkdir()
    (rep / "sub" / "x.bin").write_bytes(bytes(range(256)))
    (rep / "stale.png").write_bytes(b"old plot")
    manifest = json.loads((rep / MANIFEST).read_text())
    manifest["files"]["stale.png"] = hashlib.sha256(b"old plot").hexdigest()
    signed(rep, manifest)
    (rep / "report.md").write_text("an old report\n")  # changed by the user: must be refused
    user = {k: v for k, v in digest(rep).items() if k in ("data.csv", "notes.txt", "sub/x.bin")}

    proc = run_cli(["diagnose", "vjm", "data.csv", "--report", "rep", "--force", "--quiet"], cwd=tmp_path)
    assert proc.returncode == 1
    assert "report.md was changed since robot-stiffness wrote it" in one_error_line(proc)
    assert (rep / "report.md").read_text() == "an old report\n"

    (rep / "report.md").unlink()
    proc = run_cli(["diagnose", "vjm", "data.csv", "--report", "rep", "--force", "--quiet"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    after = digest(rep)
    for name, sha in user.items():
        assert after[name] == sha, f"{name} was touched"
    assert "stale.png" not in after, "a file the tool wrote earlier and no longer writes stays"
    assert "report.md" in after and after["report.md"] != user.get("report.md")
    assert set(json.loads((rep / MANIFEST).read_text())["files"]) == {
        "report.md", "residuals.png", "errors_per_pose.png", "effects.png", "verdict.png"}
    assert not leftovers(tmp_path)


def test_force_refuses_to_overwrite_a_user_file_with_the_tools_name(csjm_csv, tmp_path):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "report.md").write_text("my own report\n")
    before = digest(tmp_path)
    proc = run_cli(["diagnose", "csjm", str(csjm_csv), "--report", "rep", "--force"], cwd=tmp_path)
    assert proc.returncode == 1
    assert "was not written by robot-stiffness" in one_error_line(proc)
    assert digest(tmp_path) == before and not leftovers(tmp_path)


def test_write_report_api_follows_the_same_rules(csjm_csv, tmp_path):
    import robot_stiffness as rs
    from robot_stiffness import csjm
    from robot_stiffness.report import write_report

    result = csjm.diagnose(csjm_csv)
    out = tmp_path / "r"
    out.mkdir()
    (out / "mine.txt").write_text("x")
    with pytest.raises(rs.OutputPathError) as e:
        write_report(result, out)
    assert isinstance(e.value, OSError) and "not empty" in str(e.value)
    write_report(result, out, force=True)
    assert (out / "mine.txt").read_text() == "x" and (out / "report.md").exists()
    assert not leftovers(tmp_path)


def test_a_manifest_never_reaches_outside_its_folder(csjm_csv, tmp_path):
    from robot_stiffness import csjm
    from robot_stiffness.report import write_report

    result = csjm.diagnose(csjm_csv)
    out = tmp_path / "r"
    write_report(result, out)
    outside = tmp_path / "outside.txt"
    outside.write_text("precious\n")
    sha = hashlib.sha256(outside.read_bytes()).hexdigest()
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].update({"../outside.txt": sha, str(outside): sha})
    signed(out, manifest)  # even a manifest the tool signed cannot name a file outside
    write_report(result, out, force=True)
    assert outside.read_text() == "precious\n"
    assert set(json.loads((out / MANIFEST).read_text())["files"]) == {"report.md", "residuals.png", "effects.png"}


def test_a_foreign_manifest_is_refused(csjm_csv, tmp_path):
    import robot_stiffness as rs
    from robot_stiffness import csjm
    from robot_stiffness.report import write_report

    out = tmp_path / "r"
    out.mkdir()
    (out / MANIFEST).write_text("not json")
    before = digest(tmp_path)
    with pytest.raises(rs.OutputPathError) as e:
        write_report(csjm.diagnose(csjm_csv), out, force=True)
    assert "not a manifest written by robot-stiffness" in str(e.value)
    assert digest(tmp_path) == before and not leftovers(tmp_path)


# ----------------------------------------------------------------------------- output paths, up front


def test_json_onto_the_input_file_is_refused(small, tmp_path):
    shutil.copy(small, tmp_path / "data.csv")
    before = digest(tmp_path)
    for cmd in (["identify", "vjm", "data.csv", "--json", "data.csv"],
                ["diagnose", "vjm", "data.csv", "--json", "./data.csv"]):
        proc = run_cli(cmd, cwd=tmp_path)
        assert proc.returncode == 1
        line = one_error_line(proc)
        assert "is an input file" in line and "data.csv" in line, line
        assert digest(tmp_path) == before


def test_unwritable_json_names_the_users_path_and_the_reason(small, tmp_path):
    proc = run_cli(["identify", "vjm", str(small), "--json", "/proc/x.json"], cwd=tmp_path)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "/proc/x.json" in line and ".tmp-" not in line, line
    assert any(r in line for r in ("permission denied", "read-only", "cannot create files")), line

    proc = run_cli(["identify", "vjm", str(small), "--json", "nodir/x.json"], cwd=tmp_path)
    line = one_error_line(proc)
    assert proc.returncode == 1 and "nodir/x.json" in line and "does not exist" in line, line

    (tmp_path / "adir").mkdir()
    proc = run_cli(["identify", "vjm", str(small), "--json", "adir"], cwd=tmp_path)
    line = one_error_line(proc)
    assert proc.returncode == 1 and "--json adir" in line and "folder" in line, line


def test_one_path_for_two_outputs_is_refused(tmp_path):
    proc = run_cli(["simulate", "vjm", "--out", "o.csv", "--poses", "3", "--truth", "./o.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "given as two different outputs" in one_error_line(proc)
    assert list(tmp_path.iterdir()) == []


def test_input_problems_name_the_input(small, tmp_path):
    (tmp_path / "adir").mkdir()
    (tmp_path / "wrong.csv").write_text("a,b\n1,2\n")
    (tmp_path / "empty.csv").write_text("")
    cases = [
        (["identify", "vjm", "adir"], "DATA.csv adir is a folder"),
        (["identify", "vjm", "nope.csv"], "DATA.csv nope.csv: no such file"),
        (["identify", "vjm", "empty.csv"], "DATA.csv empty.csv is empty"),
        (["simulate", "vjm", "--out", "o.csv", "--urdf", "nope.urdf", "--base", "a", "--tip", "b"], "--urdf nope.urdf: no such"),
        (["simulate", "vjm", "--out", "o.csv", "--urdf", "adir", "--base", "a", "--tip", "b"], "--urdf adir is a folder"),
        (["identify", "csjm", "wrong.csv"], "wrong.csv: missing column"),
        (["diagnose", "vjm", "wrong.csv"], "wrong.csv: "),
        (["identify", "vjm", str(small), "--json="], "--json: empty file name"),
        (["diagnose", "vjm", str(small), "--report="], "--report: empty folder name"),
    ]
    before = listing(tmp_path)
    for args, words in cases:
        proc = run_cli(args, cwd=tmp_path)
        line = one_error_line(proc)
        assert proc.returncode == 1 and words in line, (args, line)
        assert listing(tmp_path) == before


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs POSIX permissions, not root")
def test_read_only_folder_is_reported_as_permission_denied(small, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        proc = run_cli(["identify", "vjm", str(small), "--json", "ro/x.json"], cwd=tmp_path)
        line = one_error_line(proc)
        assert proc.returncode == 1 and "ro/x.json" in line and "permission denied" in line, line
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o700)


def test_outputs_are_checked_before_the_data_is_read(small, tmp_path):
    """``--report .`` used to fail only after the whole run: the output check now comes first,
    so it wins over an error the data file would give later."""
    lines = small.read_text().splitlines()
    cells = lines[3].split(",")
    cells[-1] = "nan"  # a data error that would be found while reading
    lines[3] = ",".join(cells)
    (tmp_path / "bad.csv").write_text("\n".join(lines) + "\n")
    proc = run_cli(["diagnose", "vjm", "bad.csv", "--report", "."], cwd=tmp_path)
    assert proc.returncode == 1 and "--report . is not empty" in one_error_line(proc)


# ----------------------------------------------------------------------------- Ctrl-C and SIGTERM


@pytest.fixture(scope="module")
def big(tmp_path_factory) -> Path:
    """A campaign whose diagnosis takes a few seconds of CPU (≈ 3 s on the 2-core dev box)."""
    d = tmp_path_factory.mktemp("big")
    proc = run_cli(["simulate", "vjm", "--out", "big.csv", "--poses", "5000", "--wrenches-per-pose", "8", "--seed", "3",
                    "--effect", "joint_tilt:joint=3,axis=x,compliance=5e-5"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d / "big.csv"


@pytest.mark.parametrize(
    "sig, status, second",
    [
        (signal.SIGINT, 130, None),
        (signal.SIGTERM, 143, None),
        # A second signal while the first one is being handled: swallowed, never a traceback
        # ("Signal 15 ignored due to race condition", RuntimeError from a threading primitive).
        (signal.SIGINT, 130, (signal.SIGINT, 0.002)),
        (signal.SIGINT, 130, (signal.SIGTERM, 0.0)),
        (signal.SIGTERM, 143, (signal.SIGINT, 0.004)),
    ],
)
def test_interrupt_mid_run_leaves_nothing_behind(big, tmp_path, sig, status, second):
    work = tmp_path / "work"
    work.mkdir()
    data = work / "data.csv"
    shutil.copy(big, data)
    out = work / "out"
    out.mkdir()
    (out / "unrelated.txt").write_text("the user's own file\n")
    before = digest(work)
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "robot_stiffness.cli", "diagnose", "vjm", str(data),
         "--report", str(out / "rep"), "--json", str(out / "d.json"), "--quiet"],
        cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )
    # Wait until the run is under way: its temporaries exist (outputs are reserved up front).
    deadline = time.monotonic() + 60
    while not leftovers(out) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert proc.poll() is None, f"finished before the signal: {proc.communicate()}"
    time.sleep(0.3)  # inside the computation
    assert proc.poll() is None, "the campaign is too small to interrupt mid-run"
    t0 = time.monotonic()
    proc.send_signal(sig)
    if second is not None:
        time.sleep(second[1])
        proc.send_signal(second[0])
    try:
        stdout, stderr = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    elapsed = time.monotonic() - t0
    # Two signals pending at once are handled in signal-number order (SIGINT first).
    expected = {status} if second is None else {130, 143}
    assert proc.returncode in expected, (proc.returncode, stderr)
    assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert elapsed < 10, f"took {elapsed:.1f} s to stop"
    assert not leftovers(tmp_path), "temporary files left behind"
    assert digest(work) == before, "a user file changed or a partial output was written"


# ----------------------------------------------------------------------------- flags


@pytest.mark.parametrize(
    "args, flag",
    [
        (["simulate", "vjm", "--out", "o.csv", "--poses", "-5"], "--poses"),
        (["simulate", "vjm", "--out", "o.csv", "--poses", "0"], "--poses"),
        (["simulate", "vjm", "--out", "o.csv", "--poses", "1e9"], "--poses"),
        (["simulate", "vjm", "--out", "o.csv", "--poses", "100000000"], "--poses"),
        (["simulate", "vjm", "--out", "o.csv", "--seed", "-1"], "--seed"),
        (["simulate", "vjm", "--out", "o.csv", "--seed", str(2**64)], "--seed"),
        (["simulate", "vjm", "--out", "o.csv", "--wrenches-per-pose", "0"], "--wrenches-per-pose"),
        (["simulate", "vjm", "--out", "o.csv", "--force-max", "1e9"], "--force-max"),
        (["simulate", "vjm", "--out", "o.csv", "--force-max", "nan"], "--force-max"),
        (["simulate", "vjm", "--out", "o.csv", "--force-max", "inf"], "--force-max"),
        (["simulate", "vjm", "--out", "o.csv", "--force-max", "0"], "--force-max"),
        (["simulate", "vjm", "--out", "o.csv", "--moment-max", "-1"], "--moment-max"),
        (["simulate", "csjm", "--out", "o.csv", "--increments", "0"], "--increments"),
        (["simulate", "csjm", "--out", "o.csv", "--max-increment", "-inf"], "--max-increment"),
        (["simulate", "csjm", "--out", "o.csv", "--seed", "x"], "--seed"),
        (["diagnose", "vjm", "d.csv", "--fdr", "2"], "--fdr"),
        (["diagnose", "vjm", "d.csv", "--fdr", "0"], "--fdr"),
        (["diagnose", "vjm", "d.csv", "--split-seed", "-3"], "--split-seed"),
        (["diagnose", "csjm", "d.csv", "--fdr", "nan"], "--fdr"),
        (["demo", "--seed", "-1"], "--seed"),
        (["identify", "csjm", "d.csv", "--order", "3"], "--order"),
    ],
)
def test_bad_flags_give_one_line_naming_the_flag(tmp_path, args, flag):
    proc = run_cli(args, cwd=tmp_path)
    assert proc.returncode == 2
    line = one_error_line(proc)
    assert line.startswith("robot-stiffness: error: argument " + flag), line
    assert list(tmp_path.iterdir()) == []


def test_too_many_simulated_rows_are_refused_before_the_run(tmp_path):
    proc = run_cli(["simulate", "vjm", "--out", "o.csv", "--poses", "100000", "--wrenches-per-pose", "1000"], cwd=tmp_path)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "--poses 100000" in line and "--wrenches-per-pose 1000" in line and "2000000" in line, line
    assert list(tmp_path.iterdir()) == []


def test_help_documents_the_caps(tmp_path):
    text = run_cli(["simulate", "vjm", "--help"], cwd=tmp_path).stdout
    assert "100000" in text and "10000 (default 80)" in " ".join(text.split())


@pytest.mark.parametrize(
    "spec, words",
    [
        ("joint_tilt:joint=3,axis=x,compliance", ["expected key=value"]),
        ("joint_tilt:joint=three,axis=x,compliance=5e-5", ["joint='three'", "integer"]),
        ("joint_tilt:joint=3,axis=x,compliance=abc", ["compliance='abc'", "number"]),
        ("joint_tilt:joint=3,axis=x,compliance=nan", ["compliance='nan'", "finite"]),
        ("joint_tilt:joint=3,joint=4,axis=x,compliance=5e-5", ["joint is given twice"]),
        (":joint=3", ["expected NAME:key=value"]),
        ("joint_tilt:joint=3,axis=x", ["compliance"]),  # found by the core, re-attributed
        ("no_such_effect:joint=3", ["no_such_effect"]),
        ("joint_tilt:joint=99,axis=x,compliance=5e-5", ["99"]),
        # Found by the core's checks of the simulated data (or, with hB's validation, of the
        # effect itself): never blamed on a line or column of a file the user did not give.
        ("joint_tilt:joint=3,axis=x,compliance=-1", []),
        ("joint_tilt:joint=3,axis=x,compliance=1e300", []),
    ],
)
def test_bad_effect_specs_name_the_effect_argument(tmp_path, spec, words):
    proc = run_cli(["simulate", "vjm", "--out", "o.csv", "--poses", "2", "--effect", spec], cwd=tmp_path)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert f"--effect {spec!r}" in line, line
    assert "effects[" not in line and "column" not in line, line
    for w in words:
        assert w in line, line
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- pipes and bugs


def test_broken_pipe_is_not_an_error(csjm_csv, tmp_path):
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen([sys.executable, "-m", "robot_stiffness.cli", "identify", "csjm", str(csjm_csv)],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stdout is not None
    proc.stdout.close()  # the reader is gone before anything is printed (like `| head -0`)
    _, err = proc.communicate(timeout=120)
    assert err.decode() == "" and proc.returncode == 0, (proc.returncode, err.decode())


def test_an_unexpected_exception_is_one_line_asking_for_a_report(tmp_path, monkeypatch, capsys):
    from robot_stiffness import cli, cli_identify

    def boom(args, out):
        raise ZeroDivisionError("deliberate")

    monkeypatch.setattr(cli_identify, "cmd_identify_csjm", boom)
    monkeypatch.delenv("ROBOT_STIFFNESS_DEBUG", raising=False)
    assert cli.main(["identify", "csjm", "x.csv"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error" in err and "please report" in err and "Traceback" not in err
    monkeypatch.setenv("ROBOT_STIFFNESS_DEBUG", "1")
    assert cli.main(["identify", "csjm", "x.csv"]) == 1
    assert "Traceback" in capsys.readouterr().err


def test_a_conflict_found_at_commit_leaves_no_output_at_all(tmp_path):
    """A file of the user's that appears in the report folder during the run is refused at the
    end, before any output (the JSON too) is renamed into place."""
    import robot_stiffness as rs
    from robot_stiffness._outputs import Outputs

    (tmp_path / "rep").mkdir()
    out = Outputs()
    staged_json = out.file(tmp_path / "d.json", "--json")
    staged_dir = out.directory(tmp_path / "rep", expected=["report.md"])
    staged_json.write_text("{}\n")
    (staged_dir.path / "report.md").write_text("the tool's report\n")
    (tmp_path / "rep" / "report.md").write_text("the user's report\n")  # appears meanwhile
    with pytest.raises(rs.OutputPathError):
        out.commit()
    out.discard()
    assert (tmp_path / "rep" / "report.md").read_text() == "the user's report\n"
    assert not (tmp_path / "d.json").exists() and not leftovers(tmp_path)


def test_report_plots_do_not_draw_one_rectangle_per_row(tmp_path, monkeypatch):
    """A report on a big campaign took minutes: ax.bar drew one rectangle per row and per pose
    (5 s for the per-pose plot of 1500 poses). Now the drawing cost does not grow per row."""
    import matplotlib

    matplotlib.use("Agg")
    import numpy as np
    from matplotlib.axes import Axes

    from robot_stiffness import vjm
    from robot_stiffness.report import render_report

    drawn = {"rectangles": 0}
    bar, span = Axes.bar, Axes.axvspan

    def counting_bar(self, x, *args, **kwargs):
        drawn["rectangles"] += int(np.size(x))
        return bar(self, x, *args, **kwargs)

    def counting_span(self, *args, **kwargs):
        drawn["rectangles"] += 1
        return span(self, *args, **kwargs)

    monkeypatch.setattr(Axes, "bar", counting_bar)
    monkeypatch.setattr(Axes, "axvspan", counting_span)
    robot = vjm.Robot.bundled()
    campaign = vjm.simulate(robot, n_poses=600, wrenches_per_pose=2, seed=8)
    result = vjm.diagnose(robot, campaign.measurements)
    assert result.per_pose is not None and len(result.per_pose) == 600
    assert result.rows is not None and len(result.rows) == 1200
    render_report(result, tmp_path)
    assert drawn["rectangles"] <= 2 * 60, drawn
    assert (tmp_path / "errors_per_pose.png").read_bytes()[:4] == b"\x89PNG"
