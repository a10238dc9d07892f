"""Issue 21: no output replaces one of the command's inputs (the URDF a model file names
included, compared by file identity), nor an existing file without --force; outputs are regular
files (a FIFO, a device, a socket or a symbolic link is refused and left as it is); --force
deletes only what the tool provably wrote (a signed manifest), never what a hand-written
manifest claims."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import stat
from pathlib import Path
from typing import List

import pytest

import robot_stiffness as rs
from conftest import run_cli
from test_nothing_lost import MANIFEST, leftovers, one_error_line
from test_validation import TWO_JOINTS

ARM = ["--base", "base", "--tip", "tool"]
PRECIOUS = b"the user's own file\n"

posix_only = pytest.mark.skipif(os.name != "posix", reason="FIFOs, sockets and devices are POSIX")


def state(path: Path) -> List[str]:
    """Every name under ``path`` with its type and content (links by their target): what must
    stay as it is when a command is refused."""
    out = []
    for p in sorted(path.rglob("*")):
        st = os.lstat(p)
        rel = str(p.relative_to(path))
        if stat.S_ISLNK(st.st_mode):
            out.append(f"{rel} -> {os.readlink(p)}")
        elif stat.S_ISREG(st.st_mode):
            out.append(f"{rel} {hashlib.sha256(p.read_bytes()).hexdigest()}")
        else:
            out.append(f"{rel} mode {stat.S_IFMT(st.st_mode):o}")
    return out


# ----------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def two_arm(tmp_path_factory) -> Path:
    """A two-joint URDF and a campaign simulated on it."""
    d = tmp_path_factory.mktemp("two")
    (d / "two.urdf").write_text(TWO_JOINTS.format(xyz="0 0 0.1"))
    # Weightless (--no-gravity): the URDF has no inertials.
    proc = run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "6", "--seed", "3", "--urdf", "two.urdf", *ARM,
                    "--no-gravity"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d


@pytest.fixture()
def arm(two_arm, tmp_path) -> Path:
    """A fresh folder with the URDF and the campaign."""
    for name in ("two.urdf", "c.csv"):
        shutil.copy(two_arm / name, tmp_path / name)
    return tmp_path


def identify_arm(cwd: Path, urdf: str) -> str:
    """identify vjm c.csv --urdf URDF --save m.json; returns the URDF path the model records."""
    proc = run_cli(["identify", "vjm", "c.csv", "--urdf", urdf, *ARM, "--save", "m.json", "--no-gravity"], cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    return str(json.loads((cwd / "m.json").read_text())["model"]["robot"]["urdf"])


@pytest.fixture(scope="module")
def panda_world(tmp_path_factory) -> Path:
    """The bundled arm: a campaign c.csv, its model m.json, and a CSJM campaign k.csv."""
    d = tmp_path_factory.mktemp("panda")
    for args in (["simulate", "vjm", "--out", "c.csv", "--poses", "12", "--seed", "4"],
                 ["identify", "vjm", "c.csv", "--save", "m.json"],
                 ["simulate", "csjm", "--out", "k.csv", "--seed", "2"]):
        proc = run_cli(args, cwd=d)
        assert proc.returncode == 0, proc.stderr
    return d


@pytest.fixture()
def world(panda_world, tmp_path) -> Path:
    for name in ("c.csv", "m.json", "k.csv"):
        shutil.copy(panda_world / name, tmp_path / name)
    return tmp_path


# ----------------------------------------------------------------------------- inputs


@pytest.mark.parametrize("recorded", ["absolute", "relative"])
@pytest.mark.parametrize("command,flag", [("predict", "--out"), ("compensate", "--out"), ("compensate", "--plot")])
def test_an_output_onto_the_urdf_the_model_names_is_refused(arm, recorded, command, flag):
    """Before: predict/compensate replaced the URDF the model file names, and the model was
    unusable afterwards. The output is spelled differently from the recorded path (relative
    for an absolute record, absolute for a relative one): compared by identity, not text."""
    urdf = arm / "two.urdf"
    rec = identify_arm(arm, str(urdf) if recorded == "absolute" else "two.urdf")
    # The model records the URDF by absolute path whichever way it was typed (issue 24).
    assert rec == str(urdf)
    target = "./two.urdf" if recorded == "absolute" else str(urdf)
    outputs = {"--out": target} if flag == "--out" else {"--out": "comp.csv", "--plot": target}
    args = [command, "vjm", "m.json", "c.csv", *[x for kv in outputs.items() for x in kv], "--no-gravity"]
    if command == "compensate":
        args.append("--position-only")
    before = state(arm)
    proc = run_cli(args, cwd=arm)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    line = one_error_line(proc)
    assert f"{flag} {Path(target)} is an input file" in line and "URDF m.json names" in line, line
    assert state(arm) == before and not leftovers(arm)
    # The model is still usable.
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "p.csv", "--no-gravity"], cwd=arm)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("link", ["hard", "symbolic"])
def test_a_link_to_the_named_urdf_is_the_urdf_even_with_force(arm, link):
    identify_arm(arm, "two.urdf")
    if link == "hard":
        os.link(arm / "two.urdf", arm / "alias.urdf")
    else:
        os.symlink("two.urdf", arm / "alias.urdf")
    before = state(arm)
    for force in ([], ["--force"]):
        proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "alias.urdf", *force, "--no-gravity"], cwd=arm)
        assert proc.returncode == 1
        assert "--out alias.urdf is an input file (the URDF m.json names)" in one_error_line(proc)
        assert state(arm) == before


def test_model_save_refuses_the_urdf_it_names_and_an_existing_file(arm, monkeypatch):
    """The Python API: StiffnessModel.save / Identification.save follow the CLI's rules."""
    from robot_stiffness import vjm

    monkeypatch.chdir(arm)
    robot = vjm.Robot.from_urdf("two.urdf", "base", "tool")
    m = vjm.read_measurements("c.csv", robot.n_joints)
    ident = robot.identify(m.q, m.wrench, m.displacement, gravity=None)  # no inertials
    urdf_bytes = (arm / "two.urdf").read_bytes()
    for path in ("two.urdf", str(arm / "two.urdf")):
        with pytest.raises(rs.OutputPathError, match="is an input file .the URDF this model names"):
            ident.save(path)
    assert (arm / "two.urdf").read_bytes() == urdf_bytes
    ident.save("m.json")
    first = (arm / "m.json").read_bytes()
    (arm / "m.json").write_bytes(PRECIOUS)
    with pytest.raises(rs.OutputPathError, match=r"the file exists; pass force=True to replace it"):
        ident.save("m.json")
    assert (arm / "m.json").read_bytes() == PRECIOUS
    ident.stiffness_model.save("m.json", force=True)
    assert (arm / "m.json").read_bytes() == first
    if os.name == "posix":
        os.mkfifo(arm / "pipe")
        with pytest.raises(rs.OutputPathError, match="named pipe"):
            ident.save("pipe", force=True)
        assert stat.S_ISFIFO(os.lstat(arm / "pipe").st_mode)
    assert not leftovers(arm)


def test_the_tools_own_file_in_a_folder_is_kept_while_it_is_an_input(tmp_path):
    """A folder the tool wrote (demo --out d: d/campaign.csv), then a command reading
    d/campaign.csv and writing its report into d with force: the input is neither replaced nor
    removed as a stale file of the earlier run."""
    from robot_stiffness._outputs import Outputs

    d = tmp_path / "d"
    first = Outputs()
    staged = first.directory(d, expected=["campaign.csv", "report.md"])
    (staged.path / "campaign.csv").write_text("q1\n1\n")
    (staged.path / "report.md").write_text("old\n")
    first.commit()
    data = d / "campaign.csv"

    out = Outputs(inputs=[data])
    staged = out.directory(d, force=True, flag="--report", expected=["report.md"])
    (staged.path / "report.md").write_text("new\n")
    out.commit()
    out.discard()
    assert data.read_text() == "q1\n1\n" and (d / "report.md").read_text() == "new\n"
    assert set(json.loads((d / MANIFEST).read_text())["files"]) == {"campaign.csv", "report.md"}

    # Writing a file of that name is refused: it is the input.
    again = Outputs(inputs=[data])
    with pytest.raises(rs.OutputPathError, match="campaign.csv is an input file"):
        again.directory(d, force=True, flag="--out", expected=["campaign.csv"])
    again.discard()
    assert data.read_text() == "q1\n1\n" and not leftovers(tmp_path)


# ----------------------------------------------------------------------------- --force


# Every command that writes a file; X is the output under test.
WRITERS = {
    "simulate-vjm": ["simulate", "vjm", "--out", "X", "--poses", "3"],
    "simulate-vjm-truth": ["simulate", "vjm", "--out", "o.csv", "--poses", "3", "--truth", "X"],
    "simulate-csjm": ["simulate", "csjm", "--out", "X", "--increments", "5"],
    "identify-vjm-json": ["identify", "vjm", "c.csv", "--json", "X"],
    "identify-vjm-save": ["identify", "vjm", "c.csv", "--save", "X"],
    "identify-csjm-json": ["identify", "csjm", "k.csv", "--json", "X"],
    "diagnose-vjm-json": ["diagnose", "vjm", "c.csv", "--quiet", "--json", "X"],
    "diagnose-vjm-rows": ["diagnose", "vjm", "c.csv", "--quiet", "--rows", "X"],
    "diagnose-csjm-json": ["diagnose", "csjm", "k.csv", "--json", "X"],
    "predict-out": ["predict", "vjm", "m.json", "c.csv", "--out", "X"],
    "design-out": ["design", "vjm", "--model", "traditional", "--poses", "3", "--pool", "10", "--out", "X"],
    "compensate-out": ["compensate", "vjm", "m.json", "c.csv", "--out", "X"],
    "compensate-plot": ["compensate", "vjm", "m.json", "c.csv", "--out", "comp.csv", "--plot", "X"],
}


def _with(args: List[str], out: str) -> List[str]:
    return [out if a == "X" else a for a in args]


@pytest.mark.parametrize("writer", sorted(WRITERS))
def test_an_existing_output_is_replaced_only_with_force(world, writer):
    """Before: every command silently replaced an existing file (`predict … --out victim.csv`)."""
    args = WRITERS[writer]
    flag = args[args.index("X") - 1]
    label = f"{flag} existing.out" if flag.startswith("--") else "existing.out"
    (world / "existing.out").write_bytes(PRECIOUS)
    before = state(world)
    proc = run_cli(_with(args, "existing.out"), cwd=world)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    line = one_error_line(proc)
    assert f"cannot write {label}: the file exists; pass --force to replace it" in line, line
    assert state(world) == before and not leftovers(world)

    proc = run_cli([*_with(args, "existing.out"), "--force"], cwd=world)
    assert proc.returncode == 0, proc.stderr
    assert (world / "existing.out").read_bytes() != PRECIOUS and not leftovers(world)


# ----------------------------------------------------------------------------- special files

#: A command that had --force before this change (so the tests below fail on the old code for
#: the special file, not for an unknown flag); --json goes last.
DIAGNOSE_JSON = ["diagnose", "vjm", "c.csv", "--quiet", "--json"]


@posix_only
@pytest.mark.parametrize("writer", ["predict-out", "identify-vjm-json", "simulate-vjm", "compensate-plot"])
def test_a_fifo_output_is_refused_and_stays_a_fifo(world, writer):
    """Before: the FIFO was replaced by a regular file."""
    os.mkfifo(world / "pipe")
    before = state(world)
    for force in ([], ["--force"]):
        proc = run_cli([*_with(WRITERS[writer], "pipe"), *force], cwd=world)
        assert proc.returncode == 1, proc.stdout + proc.stderr
        line = one_error_line(proc)
        assert "pipe: it is a named pipe (FIFO); outputs must be regular files" in line, line
        assert stat.S_ISFIFO(os.lstat(world / "pipe").st_mode)
        assert state(world) == before


@posix_only
def test_a_symlink_to_dev_null_is_refused_and_left_as_it_is(world):
    os.symlink(os.devnull, world / "null")
    before = state(world)
    proc = run_cli([*DIAGNOSE_JSON, "null", "--force"], cwd=world)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "--json null: it is a symbolic link (to /dev/null, a character device)" in line, line
    assert os.readlink(world / "null") == os.devnull and stat.S_ISCHR(os.stat(os.devnull).st_mode)
    assert state(world) == before


@pytest.mark.skipif(not Path("/proc/self/fd/1").exists(), reason="needs /proc")
def test_a_link_to_stdout_is_refused(world):
    """`--json /dev/stdout` (a link to /proc/self/fd/1): replaced as root before. A link of the
    same kind inside the test folder, so that a regression cannot replace the machine's
    /dev/stdout."""
    os.symlink("/proc/self/fd/1", world / "stdout")
    before = state(world)
    proc = run_cli([*DIAGNOSE_JSON, "stdout", "--force"], cwd=world)
    assert proc.returncode == 1
    assert "--json stdout: it is a symbolic link" in one_error_line(proc)
    assert '"findings"' not in proc.stdout and state(world) == before


@pytest.mark.skipif(os.name != "posix" or os.geteuid() != 0, reason="creating a device needs root")
def test_a_character_device_is_refused(world):
    """`--out /dev/null` as root replaced /dev/null. The same device (1, 3) made inside the
    test folder, so that a regression cannot replace the machine's /dev/null."""
    try:
        os.mknod(world / "null", 0o600 | stat.S_IFCHR, os.makedev(1, 3))
    except PermissionError:
        pytest.skip("this root may not create devices (no CAP_MKNOD)")
    before = state(world)
    proc = run_cli([*DIAGNOSE_JSON, "null", "--force"], cwd=world)
    assert proc.returncode == 1
    assert "--json null: it is a character device" in one_error_line(proc)
    assert stat.S_ISCHR(os.lstat(world / "null").st_mode) and state(world) == before


@posix_only
def test_a_socket_is_refused(world):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        s.bind(str(world / "sock"))
        before = state(world)
        proc = run_cli([*DIAGNOSE_JSON, "sock", "--force"], cwd=world)
        assert proc.returncode == 1
        assert "--json sock: it is a socket" in one_error_line(proc)
        assert stat.S_ISSOCK(os.lstat(world / "sock").st_mode) and state(world) == before
    finally:
        s.close()


@posix_only
def test_a_symlink_to_a_regular_file_is_refused_and_left_as_it_is(world):
    """The documented choice (docs/python.md): the tool writes files under their own name only;
    a link, even to a regular file, is refused with --force too, and neither the link nor the
    file it points to changes."""
    (world / "real.csv").write_bytes(PRECIOUS)
    os.symlink("real.csv", world / "link.csv")
    before = state(world)
    proc = run_cli([*DIAGNOSE_JSON, "link.csv", "--force"], cwd=world)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "--json link.csv: it is a symbolic link (to " in line and "give the file's own path" in line, line
    assert state(world) == before


# ----------------------------------------------------------------------------- forged manifests


def _diagnose_report(world: Path, folder: str, *extra: str):
    return run_cli(["diagnose", "csjm", "k.csv", "--report", folder, *extra], cwd=world)


def test_a_forged_manifest_with_force_leaves_the_user_file_byte_identical(world):
    """Before: `diagnose … --report rep --force` deleted a user file that a hand-written
    manifest in rep/ listed with its correct SHA-256."""
    rep = world / "rep"
    rep.mkdir()
    (rep / "notes.txt").write_bytes(PRECIOUS)
    forged = {"written_by": "robot-stiffness output manifest",
              "files": {"notes.txt": hashlib.sha256(PRECIOUS).hexdigest()}}
    (rep / MANIFEST).write_text(json.dumps(forged))
    before = state(world)
    proc = _diagnose_report(world, "rep", "--force")
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "signature does not verify" in line and "--force replaces nothing" in line, line
    assert "remove the folder's files yourself" in line
    assert state(world) == before and not leftovers(world)

    # The Python API, the same.
    from robot_stiffness import csjm
    from robot_stiffness.report import write_report

    with pytest.raises(rs.OutputPathError, match="signature does not verify.*force=True replaces nothing"):
        write_report(csjm.diagnose(world / "k.csv"), rep, force=True)
    assert state(world) == before


def test_a_manifest_copied_from_another_folder_does_not_verify(world):
    """A genuine manifest proves what the tool wrote in *its* folder: copied with the files into
    another folder, the copies are the user's."""
    assert _diagnose_report(world, "a").returncode == 0
    shutil.copytree(world / "a", world / "b")
    before = state(world)
    proc = _diagnose_report(world, "b", "--force")
    assert proc.returncode == 1 and "signature does not verify" in one_error_line(proc)
    assert state(world) == before
    # In its own folder it still verifies.
    proc = _diagnose_report(world, "a", "--force")
    assert proc.returncode == 0, proc.stderr


def test_without_a_usable_key_force_replaces_nothing_and_says_why(world, monkeypatch):
    (world / "blocker").write_text("a file where the state folder would be\n")
    monkeypatch.setenv("ROBOT_STIFFNESS_STATE_DIR", str(world / "blocker" / "state"))
    proc = _diagnose_report(world, "rep")  # written, but its manifest cannot be signed
    assert proc.returncode == 0, proc.stderr
    assert "signature" not in json.loads((world / "rep" / MANIFEST).read_text())
    before = state(world)
    proc = _diagnose_report(world, "rep", "--force")
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "cannot be proved" in line and str(world / "blocker" / "state" / "manifest.key") in line, line
    assert state(world) == before


@posix_only
def test_a_key_others_can_read_is_not_trusted(world, monkeypatch, tmp_path_factory):
    key_dir = tmp_path_factory.mktemp("loose-state")
    monkeypatch.setenv("ROBOT_STIFFNESS_STATE_DIR", str(key_dir))
    assert _diagnose_report(world, "rep").returncode == 0
    key = key_dir / "manifest.key"
    assert stat.S_IMODE(os.stat(key).st_mode) == 0o600
    os.chmod(key, 0o644)
    before = state(world)
    proc = _diagnose_report(world, "rep", "--force")
    assert proc.returncode == 1 and "readable by you only" in one_error_line(proc)
    assert state(world) == before
    os.chmod(key, 0o600)
    assert _diagnose_report(world, "rep", "--force").returncode == 0



def test_a_dash_is_not_a_file_named_dash(world):
    """`--json -` wrote a file named "-": no output streams to stdout, so it is refused."""
    before = state(world)
    proc = run_cli([*DIAGNOSE_JSON, "-"], cwd=world)
    assert proc.returncode == 1
    assert "standard output is not supported" in proc.stderr, proc.stderr
    assert state(world) == before


def test_an_output_onto_the_data_the_model_was_identified_from_is_refused(world):
    """The model file names its campaign (c.csv) as well as its URDF: `predict --out c.csv
    --force` replaced the data the model was fitted on."""
    shutil.copy(world / "c.csv", world / "poses.csv")
    before = state(world)
    for target in ("c.csv", str(world / "c.csv")):
        proc = run_cli(["predict", "vjm", "m.json", "poses.csv", "--out", target, "--force"], cwd=world)
        assert proc.returncode == 1, proc.stdout + proc.stderr
        assert "the data m.json was identified from" in one_error_line(proc), proc.stderr
        assert state(world) == before
