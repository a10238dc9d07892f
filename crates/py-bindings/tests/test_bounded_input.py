"""Issue 21: bounded parsing, model files checked behind their hash, short numbers, SIGTERM.

A URDF of 20 000 nested elements killed ``identify``/``predict``/``design``/``diagnose`` with
SIGSEGV (and ``Robot.from_urdf_string`` with 100 000 levels killed Python); 200 000 nested ``[``
in a model file gave "internal error (RecursionError)"; a hand-edited model file with its hash
recomputed and a negative variance gave sd = 0; a 1e308 cell's message printed 309 digits.
"""

from __future__ import annotations

import hashlib
import json
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import listing
from robot_stiffness import ModelFileError, RobotModelError
from robot_stiffness.model import StiffnessModel
from robot_stiffness.vjm import Robot

#: The bundled arm's URDF (the Rust crate's copy).
URDF_FILE = Path(__file__).resolve().parents[2] / "vjm" / "data" / "panda_arm.urdf"
BUNDLED_URDF = URDF_FILE.read_text(encoding="utf-8")
ROBOT_TAG = '<robot name="panda">'


def run_cli(args, cwd: Path) -> subprocess.CompletedProcess:
    """The console script's module in a subprocess, with this environment (so that it runs the
    package under test, installed or on PYTHONPATH)."""
    return subprocess.run([sys.executable, "-m", "robot_stiffness.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def leftovers(root: Path) -> list:
    return [p for p in listing(root) if ".tmp-" in p]


def one_error_line(proc: subprocess.CompletedProcess) -> str:
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    return lines[0]


def deep_urdf(levels: int) -> str:
    assert ROBOT_TAG in BUNDLED_URDF
    return BUNDLED_URDF.replace(ROBOT_TAG, ROBOT_TAG + "<a>\n" * levels + "</a>" * levels, 1)


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    """A campaign, a model file of it, a pose table and a 20 000-level URDF."""
    d = tmp_path_factory.mktemp("bounded")
    proc = run_cli(["simulate", "vjm", "--out", "data.csv", "--poses", "12", "--seed", "1"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    proc = run_cli(["identify", "vjm", "data.csv", "--save", "m.json"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    lines = (d / "data.csv").read_text().splitlines()
    header = lines[0].split(",")
    keep = [i for i, c in enumerate(header) if c.startswith("q") or c in ("fx", "fy", "fz", "mx", "my", "mz")]
    (d / "poses.csv").write_text(
        "\n".join(",".join(row.split(",")[i] for i in keep) for row in lines[:4]) + "\n"
    )
    (d / "deep.urdf").write_text(deep_urdf(20_000))
    (d / "deep.json").write_text("[" * 200_000)
    return d


def test_from_urdf_string_with_100000_levels_raises(tmp_path):
    # In a subprocess: a stack overflow kills the interpreter, which must fail this test and
    # not pytest.
    code = textwrap.dedent(
        """
        import sys
        from robot_stiffness import RobotModelError
        from robot_stiffness.vjm import Robot
        BUNDLED_URDF = open(sys.argv[1], encoding="utf-8").read()
        tag = '<robot name="panda">'
        xml = BUNDLED_URDF.replace(tag, tag + "<a>" * 100000 + "</a>" * 100000, 1)
        try:
            Robot.from_urdf_string(xml, "panda_link0", "panda_link8")
        except RobotModelError as e:
            print("refused:", e)
        """
    )
    proc = subprocess.run([sys.executable, "-c", code, str(URDF_FILE)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)
    assert "refused: URDF nests 100001 levels deep, more than the 256 accepted" in proc.stdout, proc.stdout


def test_urdf_within_the_limit_still_loads():
    robot = Robot.from_urdf_string(deep_urdf(200), "panda_link0", "panda_link8")
    assert robot.n_joints == 7
    with pytest.raises(RobotModelError, match="levels deep"):
        Robot.from_urdf_string(deep_urdf(300), "panda_link0", "panda_link8")


ROBOT = ["--urdf", "deep.urdf", "--base", "panda_link0", "--tip", "panda_link8"]


@pytest.mark.parametrize(
    "args",
    [
        ["identify", "vjm", "data.csv", *ROBOT, "--json", "id.json", "--save", "new.json"],
        ["predict", "vjm", "m.json", "poses.csv", "--out", "pred.csv", *ROBOT],
        ["compensate", "vjm", "m.json", "poses.csv", "--out", "comp.csv", *ROBOT],
        ["design", "vjm", *ROBOT, "--out", "plan.csv"],
        ["diagnose", "vjm", "data.csv", *ROBOT, "--report", "rep", "--json", "d.json"],
        ["simulate", "vjm", "--out", "sim.csv", *ROBOT],
    ],
    ids=lambda a: a[0],
)
def test_cli_refuses_a_deeply_nested_urdf(work, args):
    before = listing(work)
    proc = run_cli(args, cwd=work)
    assert proc.returncode == 1, (proc.returncode, proc.stderr)
    line = one_error_line(proc)
    assert "deep.urdf" in line and "20001 levels deep, more than the 256 accepted" in line, line
    assert listing(work) == before, "an output or a temporary was left behind"


@pytest.mark.parametrize("verb", ["predict", "compensate"])
def test_cli_refuses_a_deeply_nested_model_file(work, verb):
    before = listing(work)
    proc = run_cli([verb, "vjm", "deep.json", "poses.csv", "--out", "out.csv"], cwd=work)
    assert proc.returncode == 1, (proc.returncode, proc.stderr)
    line = one_error_line(proc)
    assert "deep.json" in line and "200000 levels deep, more than the 32 accepted" in line, line
    assert listing(work) == before


def test_api_refuses_a_deeply_nested_model_file(work, panda):
    with pytest.raises(ModelFileError, match="200000 levels deep"):
        StiffnessModel.load(work / "deep.json", panda)


def _compact(text: str) -> str:
    """JSON text without the whitespace outside strings: the compact form serde_json writes,
    over which the content hash is taken (the file is its pretty form, in the same order)."""
    out, in_string, escaped = [], False, False
    for c in text:
        if in_string:
            out.append(c)
            if escaped:
                escaped = False
            elif c == "\\":
                escaped = True
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
            out.append(c)
        elif not c.isspace():
            out.append(c)
    return "".join(out)


def rehashed(text: str) -> str:
    """``text`` with its content hash recomputed, as a user who read docs/model-file.md can."""
    doc = json.loads(text)
    start = text.index('"model": ') + len('"model": ')
    end = text.rstrip().rindex("}")
    digest = hashlib.sha256(_compact(text[start:end]).encode()).hexdigest()
    return text.replace(doc["content_sha256"], digest)


def negate_first(text: str, key: str) -> str:
    """The first number after ``"key": [`` negated (nested lists: the first element)."""
    at = text.index(f'"{key}": [') + len(f'"{key}": [')
    while not (text[at].isdigit() or text[at] == "-"):
        at += 1
    assert text[at] != "-"
    return text[:at] + "-" + text[at:]


@pytest.mark.parametrize(
    "key, field",
    [
        ("covariance", "estimate.covariance[0][0] is -"),
        ("noise_sigma", "noise.noise_sigma[0] is -"),
    ],
)
def test_impossible_values_are_refused_even_with_a_recomputed_hash(work, panda, tmp_path, key, field):
    good = (work / "m.json").read_text()
    assert rehashed(good) == good, "the test's hash recomputation does not match the writer's"
    forged = rehashed(negate_first(good, key))
    path = tmp_path / "forged.json"
    path.write_text(forged)
    with pytest.raises(ModelFileError) as err:
        StiffnessModel.load(path, panda)
    assert field in str(err.value) and "forged.json" in str(err.value), err.value
    # The CLI says the same in one line.
    proc = run_cli(["predict", "vjm", str(path), str(work / "poses.csv"), "--out", "p.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and field in one_error_line(proc), proc.stderr


def test_a_huge_cell_is_quoted_short(work, tmp_path):
    lines = (work / "data.csv").read_text().splitlines()
    header = lines[0].split(",")
    row = lines[1].split(",")
    row[header.index("fx")] = "1e308"
    (tmp_path / "bad.csv").write_text("\n".join([lines[0], ",".join(row), *lines[2:]]) + "\n")
    proc = run_cli(["identify", "vjm", "bad.csv"], cwd=tmp_path)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "1e308" in line and len(line) < 300, line


def test_sigterm_mid_write_leaves_no_temporary_and_the_previous_output(tmp_path):
    """SIGTERM while ``simulate`` writes a 200 000-row table over an existing output
    (``--force``): exit 143, the temporary removed, the previous file unchanged."""
    out = tmp_path / "out.csv"
    out.write_text("the previous output\n")
    proc = subprocess.Popen(
        [sys.executable, "-m", "robot_stiffness.cli", "simulate", "vjm", "out.csv", "--poses", "10000",
         "--wrenches-per-pose", "20", "--seed", "3", "--force"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    # Wait until the table is being written: its temporary has content.
    deadline = time.monotonic() + 120
    writing = False
    while proc.poll() is None and time.monotonic() < deadline and not writing:
        for name in leftovers(tmp_path):
            try:
                writing = (tmp_path / name).stat().st_size > 0
            except OSError:
                pass
        time.sleep(0.005)
    assert proc.poll() is None and writing, f"finished before the write could be interrupted: {proc.communicate()}"
    proc.send_signal(signal.SIGTERM)
    try:
        _, stderr = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode == 143, (proc.returncode, stderr)
    assert "Traceback" not in stderr, stderr
    assert not leftovers(tmp_path), "temporary files left behind"
    assert out.read_text() == "the previous output\n"
    assert listing(tmp_path) == ["out.csv"]


def test_model_file_values_are_finite_numbers_in_the_api(work, panda):
    # The model a real identification writes passes every check (the checks are not too strict).
    m = StiffnessModel.load(work / "m.json", panda)
    sd = m.measurement_stddev()
    assert np.all(sd[np.isfinite(sd)] >= 0)
