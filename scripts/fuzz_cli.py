#!/usr/bin/env python3
"""Fuzz harness for the ``robot-stiffness`` command, run in-process (fast).

Each case is a command line (``identify vjm``, ``identify csjm``, ``diagnose vjm``, ``simulate
vjm``, ``predict vjm`` and ``compensate vjm`` with a saved model, ``design vjm`` on the bundled
arm and on short chains, …) on a mutated measurement
file or with mutated arguments, run by
``robot_stiffness.cli.main`` in a worker process in a fresh folder. A case passes when it
ends within the time limit (2 s) with exit status 0, 1 or 2, prints no traceback, leaves the
user's files (the input and an unrelated file) untouched and, when it fails, writes nothing.
A failing case is saved (command, files, message) to the crash folder and makes the exit
status 1. The cases are a function of ``--seed`` alone; ``--seconds`` decides how many run.

    python3 scripts/fuzz_cli.py --seconds 30 --seed 1 --record fuzz-cli.json

Seeds are the CSV files of the Rust harness's corpus (tests/fuzz/corpus/{vjm,csjm}) and, for
``predict``/``compensate``, its model files (tests/fuzz/corpus/model, mostly left intact).
"""
from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import platform
import random
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from queue import Empty, Queue
from typing import Any, Dict, List, Optional, Tuple

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "fuzz" / "corpus"
MAX_INPUT = 1 << 20
# `diagnose` runs on small files only (the 2 s budget is for reading and identifying files up to
# MAX_INPUT; a diagnosis of 4000 rows takes longer by design).
MAX_DIAGNOSE_INPUT = 64 << 10

SPECIAL_NUMBERS = [
    "nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e309", "5e-324", "-0", "0", "1", "-1",
    "1e6", "1e15", "1e154", "99999999999999999999999", "", " ", "+", ".", "1e", "0x10", "1_000",
    "\"1\"", "１", "6.283185307179586", "12.566370614359172", "1e-12", "train", "test", "x",
]
HEADER_NAMES = [
    "q0", "q1", "q8", "q99", "fx", "mz", "dx", "dz", "rx", "rz", "pose", "set", "r11", "r33",
    "tx", "tz", "ref", "", " ", "Q1", "DX", "\ufeffq1", "x",
]
# Values put in place of a flag's value, by kind.
FLAG_VALUES = {
    "int": ["-5", "-1", "0", "1", "2", "3.5", "1e9", "nan", "", "abc", "99999999999999999999"],
    "float": ["-1", "0", "nan", "inf", "-inf", "1e9", "1e308", "1e-300", "", "abc", "0.5"],
    "out": ["", ".", "..", "/proc/x.json", "/nonexistent/dir/x.json", "user", "user/keep.txt",
            "INPUT", "MODEL", "out dir/x.json", "x.json/", "-"],
    "effect": [
        "joint_tilt:joint=3,axis=x,compliance=5e-5", "joint_tilt:joint=3,axis=x,compliance=-1",
        "joint_tilt:joint=3,axis=x,compliance=nan", "joint_tilt:joint=99,axis=x,compliance=5e-5",
        "joint_tilt:joint=0,axis=q,compliance=5e-5", "joint_tilt:joint=3", "unknown:x=1", "",
        "joint_tilt:joint=3,axis=x,compliance=5e-5,bogus=1", "backlash:joint=2,width=1e9",
        "joint_tilt:joint=-1,axis=x,compliance=1e308", ":", "joint_tilt:joint=3.5,axis=x",
    ],
    "model": ["traditional", "extended", "", "bogus", "traditional+joint_tilt(J2x)", "+", "nan"],
    # predict/compensate --payload MASS[,cx,cy,cz] (kg, m): implausible, malformed, fine.
    "payload": ["5", "0", "-1", "nan", "inf", "1e6", "1e308", "1,2", "1,0,0,1e6", "2,0,0,0.1", "",
                "abc", "1,,0,0", "5e-324"],
    # design --base/--tip on SHORT_ARM: each link (base == tip included), unknown, empty.
    "link": ["base", "l1", "l2", "tool", "nope", "", "panda_link0"],
}

# Command lines; DATA is replaced by the (mutated) seed file, flags' value kinds follow.
TEMPLATES: List[Tuple[str, List[str]]] = [
    ("vjm", ["identify", "vjm", "DATA", "--json", "out.json"]),
    ("vjm", ["identify", "vjm", "DATA", "--model", "extended", "--use-rotations", "--method", "qr"]),
    ("vjm", ["identify", "vjm", "DATA", "--nonnegative", "--json", "out.json"]),
    ("csjm", ["identify", "csjm", "DATA", "--order", "2", "--json", "k.json"]),
    ("csjm", ["identify", "csjm", "DATA", "--project", "--json", "k.json"]),
    ("vjm", ["diagnose", "vjm", "DATA", "--quiet", "--json", "d.json"]),
    ("vjm", ["diagnose", "vjm", "DATA", "--quiet", "--report", "report", "--split-seed", "3"]),
    ("", ["simulate", "vjm", "--out", "sim.csv", "--poses", "3", "--wrenches-per-pose", "1", "--seed", "1",
          "--effect", "joint_tilt:joint=3,axis=x,compliance=5e-5", "--truth", "truth.json"]),
    ("", ["simulate", "csjm", "--out", "sim.csv", "--increments", "4", "--seed", "2"]),
    # A saved model (MODEL: a seed of tests/fuzz/corpus/model) used on a mutated pose file; the
    # --payload forms get the file without its fx..mz columns (see make_case).
    ("vjm", ["predict", "vjm", "MODEL", "DATA", "--out", "pred.csv"]),
    ("vjm", ["predict", "vjm", "MODEL", "DATA", "--payload", "2,0,0,0.1", "--out", "pred.csv"]),
    ("vjm", ["compensate", "vjm", "MODEL", "DATA", "--out", "comp.csv"]),
    ("vjm", ["compensate", "vjm", "MODEL", "DATA", "--payload", "5", "--position-only", "--out",
             "comp.csv", "--plot", "comp.png"]),
    # Planning: small pools (the 2 s budget), the bundled arm and chains of one and two joints
    # of SHORT_ARM (arm.urdf), one of them with the tip on its only axis (rank 0).
    ("", ["design", "vjm", "--poses", "3", "--wrenches-per-pose", "3", "--pool", "20", "--seed", "1",
          "--out", "plan.csv"]),
    ("", ["design", "vjm", "--model", "traditional", "--poses", "4", "--pool", "30", "--margin", "0.2",
          "--out", "plan.csv"]),
    ("", ["design", "vjm", "--urdf", "arm.urdf", "--base", "base", "--tip", "tool", "--no-gravity", "--poses", "3",
          "--pool", "20", "--out", "plan.csv"]),
    ("", ["design", "vjm", "--urdf", "arm.urdf", "--base", "l1", "--tip", "tool", "--no-gravity", "--model", "traditional",
          "--poses", "2", "--pool", "20", "--out", "plan.csv"]),
    ("", ["design", "vjm", "--urdf", "arm.urdf", "--base", "base", "--tip", "l1", "--no-gravity", "--poses", "2",
          "--pool", "20", "--out", "plan.csv"]),
]
# Two revolute joints (z at 0.3 m, y 0.4 m out) and a tool 0.3 m beyond: the `design` cases'
# short chains.
SHORT_ARM = (ROOT / "crates" / "vjm" / "tests" / "data" / "arm2.urdf").read_bytes()
FLAG_KIND = {
    "--poses": "int", "--wrenches-per-pose": "int", "--seed": "int", "--split-seed": "int",
    "--increments": "int", "--order": "int", "--force-max": "float", "--moment-max": "float",
    "--max-increment": "float", "--fdr": "float", "--json": "out", "--report": "out",
    "--truth": "out", "--effect": "effect", "--model": "model", "--baseline": "model",
    "--out": "out", "--plot": "out", "--payload": "payload", "--pool": "int", "--margin": "float",
    "--base": "link", "--tip": "link",
}
EXTRA_FLAGS = ["--force-max", "--moment-max", "--fdr", "--max-increment", "--no-noise", "--help",
               "--version", "--bogus", "--", "-", "--json", "--report", "--urdf", "--base", "--tip",
               "--allow-outside-limits", "--payload", "--no-kc"]
USER_FILE = ("user/keep.txt", b"the user's own file\n")


# ---------------------------------------------------------------- mutations (bytes and CSV)

def _numbers(data: bytes) -> List[Tuple[int, int]]:
    return [m.span() for m in re.finditer(rb"-?[0-9][0-9.eE+-]*", data)]


def mutate_csv(data: bytes, rng: random.Random) -> bytes:
    """1–4 stacked mutations: numeric cells, lines, columns, header names, bytes, truncation."""
    for _ in range(rng.randint(1, 4)):
        data = _mutate_once(data, rng)[:MAX_INPUT]
    return data


def _mutate_once(data: bytes, rng: random.Random) -> bytes:
    lines = data.split(b"\n")
    kind = rng.randrange(9)
    if kind <= 2:
        spans = _numbers(data)
        if spans:
            a, b = rng.choice(spans)
            value = rng.choice(SPECIAL_NUMBERS) if rng.random() < 0.8 else \
                f"{rng.uniform(-10, 10)}e{rng.randint(-330, 330)}"
            return data[:a] + value.encode() + data[b:]
    if kind == 3 and lines:
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        op = rng.randrange(4)
        if op == 0:
            lines.insert(j, lines[i])
        elif op == 1:
            del lines[i]
        elif op == 2:
            lines[i], lines[j] = lines[j], lines[i]
        else:
            lines[i] = b""
        return b"\n".join(lines)
    if kind == 4 and lines and lines[0]:
        width = lines[0].count(b",") + 1
        c = rng.randrange(width)
        op = rng.randrange(2)
        edited = []
        for line in lines:
            cells = line.split(b",")
            if c < len(cells):
                if op == 0:
                    del cells[c]
                else:
                    cells.insert(c, cells[c])
            edited.append(b",".join(cells))
        return b"\n".join(edited)
    if kind == 5 and lines:
        cells = lines[0].split(b",")
        i = rng.randrange(len(cells))
        name = rng.choice(HEADER_NAMES).encode()
        if rng.random() < 0.5:
            cells[i] = name
        else:
            cells.append(name)
        lines[0] = b",".join(cells)
        return b"\n".join(lines)
    if kind == 6 and len(lines) > 2:
        i = rng.randrange(1, len(lines))
        times = rng.choice([2, 10, 100, 2000])
        return b"\n".join(lines[:i] + [lines[i]] * times + lines[i:])
    if kind == 7 and data:
        return data[: rng.randrange(len(data))]
    if kind == 8:
        return rng.choice([data.replace(b"\n", b"\r\n"), b"\xef\xbb\xbf" + data,
                           data.replace(b",", b";"), data + b"\n\n", data.replace(b"\n", b",\n")])
    # raw bytes
    raw = bytearray(data)
    at = rng.randrange(len(raw)) if raw else 0
    special = b"\0\xff\x80,\"'\n\r\t e-."
    op = rng.randrange(3)
    if op == 0 and raw:
        raw[at] ^= 1 << rng.randrange(8)
    elif op == 1:
        raw.insert(at, rng.choice(special))
    elif raw:
        del raw[at: at + rng.randint(1, 16)]
    return bytes(raw)


def mutate_argv(argv: List[str], rng: random.Random) -> List[str]:
    """A flag's value swapped for an odd one, a flag dropped, duplicated or added."""
    argv = list(argv)
    for _ in range(rng.randint(1, 2)):
        op = rng.randrange(5)
        flags = [i for i, a in enumerate(argv) if a in FLAG_KIND and i + 1 < len(argv)]
        if op <= 1 and flags:
            i = rng.choice(flags)
            argv[i + 1] = rng.choice(FLAG_VALUES[FLAG_KIND[argv[i]]])
        elif op == 2 and len(argv) > 2:
            del argv[rng.randrange(2, len(argv))]
        elif op == 3 and flags:
            i = rng.choice(flags)
            argv += argv[i: i + 2]
        else:
            flag = rng.choice(EXTRA_FLAGS)
            argv.insert(rng.randrange(2, len(argv) + 1), flag)
            kind = FLAG_KIND.get(flag)
            if kind is not None:
                argv.insert(argv.index(flag) + 1, rng.choice(FLAG_VALUES[kind]))
    return argv


# ---------------------------------------------------------------- cases

@dataclass
class Case:
    """One command line and the files it finds in its (fresh) folder."""
    index: int
    argv: List[str]
    files: Dict[str, bytes] = field(default_factory=dict)

    def to_json(self) -> Dict[str, Any]:
        return {"index": self.index, "argv": self.argv,
                "files": {k: v.decode("latin-1") for k, v in self.files.items()}}

    @staticmethod
    def from_json(obj: Dict[str, Any]) -> "Case":
        return Case(obj["index"], obj["argv"],
                    {k: v.encode("latin-1") for k, v in obj["files"].items()})


def load_seeds() -> Dict[str, List[Tuple[str, bytes]]]:
    seeds: Dict[str, List[Tuple[str, bytes]]] = {}
    for kind in ("vjm", "csjm", "model"):
        folder = CORPUS / kind
        seeds[kind] = [(p.name, p.read_bytes()) for p in sorted(folder.iterdir()) if p.is_file()]
    return seeds


WRENCH_COLUMNS = {b"fx", b"fy", b"fz", b"mx", b"my", b"mz"}


def without_wrench(data: bytes) -> bytes:
    """A measurement file's q1..qn and other columns, without fx..mz: a pose table for
    ``--payload`` (with the columns too, the command refuses the two loads at once)."""
    lines = data.split(b"\n")
    keep = [i for i, c in enumerate(lines[0].split(b",")) if c.strip().lower() not in WRENCH_COLUMNS]
    return b"\n".join(b",".join(c for i, c in enumerate(line.split(b",")) if i in keep) for line in lines)


def make_case(seed: int, index: int, seeds: Dict[str, List[Tuple[str, bytes]]]) -> Case:
    """Case number ``index`` of the run with ``seed`` (independent of every other case)."""
    rng = random.Random(f"{seed}:{index}")
    kind, template = TEMPLATES[rng.randrange(len(TEMPLATES))]
    argv = list(template)
    files = {USER_FILE[0]: USER_FILE[1]}
    if kind:
        name, data = rng.choice(seeds[kind])
        # Mostly the file is mutated; sometimes the arguments; sometimes both.
        what = rng.random()
        if what < 0.7:
            data = mutate_csv(data, rng)
        if what >= 0.6:
            argv = mutate_argv(argv, rng)
        if argv[0] == "diagnose":
            data = data[:MAX_DIAGNOSE_INPUT]
        if "MODEL" in template:
            if "--payload" in template:
                data = without_wrench(data)
            # The model file mostly a valid one, so that the case reaches predict/compensate
            # (the model reader has its own fuzz target); sometimes any seed, or mutated.
            valid = [m for m in seeds["model"] if m[0].startswith("valid")] or seeds["model"]
            _, model = rng.choice(valid if rng.random() < 0.9 else seeds["model"])
            files["model.json"] = mutate_csv(model, rng) if rng.random() < 0.1 else model
        files["data.csv"] = data
        argv = ["data.csv" if a == "DATA" else a for a in argv]
    else:
        argv = mutate_argv(argv, rng)
    argv = ["data.csv" if a == "INPUT" else "model.json" if a == "MODEL" else a for a in argv]
    if "arm.urdf" in argv:
        files["arm.urdf"] = SHORT_ARM
    return Case(index, argv, files)


# ---------------------------------------------------------------- worker (in-process runs)

class CaseTimeout(BaseException):
    """Raised by the profiling timer inside a case that runs too long (a BaseException, so the
    command's own error handling does not swallow it). The limit is CPU time of the worker (all
    threads), so a machine shared with other work does not turn a slow case into a hang; a case
    stuck where Python cannot interrupt it (inside Rust, or blocked) is killed by the parent
    after WALL_FACTOR times the limit of wall time."""


def _on_alarm(signum: int, frame: Any) -> None:
    raise CaseTimeout()


def _snapshot(folder: Path) -> Dict[str, bytes]:
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            out[str(p.relative_to(folder))] = p.read_bytes()
        elif p.is_dir() and not any(p.iterdir()):
            out[str(p.relative_to(folder)) + "/"] = b""
    return out


def run_case(case: Case, timeout: float) -> Dict[str, Any]:
    """Runs one case in a fresh folder; returns what the parent checks."""
    from robot_stiffness.cli import main

    with tempfile.TemporaryDirectory(prefix="fuzz-cli-") as tmp:
        folder = Path(tmp)
        for name, data in case.files.items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(data)
        before = _snapshot(folder)
        out, err = io.StringIO(), io.StringIO()
        status: Any = None
        crash = None
        cwd = os.getcwd()
        started = time.perf_counter()
        os.chdir(folder)
        signal.setitimer(signal.ITIMER_PROF, timeout)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                status = main(case.argv)
        except SystemExit as e:  # argparse: --help, --version, usage errors
            status = e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
        except CaseTimeout:
            crash = f"hang: over {timeout:g} s of CPU time"
        except BaseException:  # noqa: BLE001 — anything escaping main is the finding
            crash = "traceback: " + traceback.format_exc()
        finally:
            signal.setitimer(signal.ITIMER_PROF, 0)
            os.chdir(cwd)
        elapsed = time.perf_counter() - started
        after = _snapshot(folder)
    return {"status": status, "crash": crash, "stdout": out.getvalue()[-2000:],
            "stderr": err.getvalue()[-4000:], "before": sorted(before), "after": sorted(after),
            "changed": sorted(k for k in before if after.get(k) != before[k]),
            "elapsed": elapsed}


def _warm_up() -> None:
    """What a worker pays once is not a case's work: the package, and matplotlib with a first
    figure drawn (its font cache is built then on a fresh machine), before the first case, so
    that the per-case CPU limit measures the command alone. Without it the first `--report`
    case of each fresh worker paid the imports and, on a slow machine, passed 2 s of CPU."""
    import robot_stiffness.cli  # noqa: F401
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure()
    fig.add_subplot().plot([0.0, 1.0])
    fig.savefig(io.BytesIO(), format="png")
    plt.close(fig)


def serve(timeout: float) -> None:
    signal.signal(signal.SIGPROF, _on_alarm)
    # Matplotlib without a display; no progress bars.
    os.environ.setdefault("MPLBACKEND", "Agg")
    _warm_up()
    answers = sys.stdout  # cases print into their own buffers; answers go here
    for line in sys.stdin:
        case = Case.from_json(json.loads(line))
        result = run_case(case, timeout)
        answers.write(json.dumps(result) + "\n")
        answers.flush()


# ---------------------------------------------------------------- parent (watchdog, checks)

class Worker:
    """A worker process; killed and replaced when a case does not answer in time."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, __file__, "--worker", "--timeout", str(ARGS_TIMEOUT)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            text=True, env={**os.environ, "MPLBACKEND": "Agg"})
        self.answers: "Queue[Optional[str]]" = Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.answers.put(line)
        self.answers.put(None)

    def run(self, case: Case, limit: float) -> Optional[Dict[str, Any]]:
        """The worker's answer, or None when it died or did not answer within ``limit``."""
        assert self.proc.stdin is not None
        try:
            self.proc.stdin.write(json.dumps(case.to_json()) + "\n")
            self.proc.stdin.flush()
            line = self.answers.get(timeout=limit)
        except (BrokenPipeError, Empty):
            return None
        return None if line is None else json.loads(line)

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait()


ARGS_TIMEOUT = 2.0
# The parent's wall-clock limit, as a multiple of the per-case CPU limit.
WALL_FACTOR = 5.0


def _named_outputs(argv: List[str]) -> set:
    """Files the command line names as outputs (``--json F``, ``--truth F``, ``--out F``, simulate's deprecated positional OUT):
    replacing one of those when the command succeeds with ``--force`` is what the user asked
    for (without ``--force`` an existing file is never replaced)."""
    if "--force" not in argv:
        return set()
    named = {argv[i + 1] for i, a in enumerate(argv[:-1]) if a in ("--json", "--truth", "--out")}
    if argv[:1] == ["simulate"] and len(argv) > 2 and not argv[2].startswith("-"):
        named.add(argv[2])  # the deprecated positional OUT.csv
    return {os.path.normpath(n) for n in named if n}


def check(case: Case, result: Optional[Dict[str, Any]]) -> Tuple[Optional[str], List[str]]:
    """(failure, warnings): a failure breaks the contract; warnings are message quality."""
    if result is None:
        return "hang: the worker did not answer (stuck outside Python, or died)", []
    if result["crash"]:
        return result["crash"], []
    status, stderr = result["status"], result["stderr"]
    if status not in (0, 1, 2):
        return f"exit status {status!r} (expected 0, 1 or 2)", []
    if "Traceback (most recent call last)" in stderr:
        return "traceback printed:\n" + stderr, []
    # The input is never replaced; another user file only when named as an output of a run
    # that succeeded.
    allowed = _named_outputs(case.argv) - {"data.csv"} if status == 0 else set()
    changed = [f for f in result["changed"] if os.path.normpath(f) not in allowed]
    if changed:
        return f"user files changed or removed: {changed}", []
    if status != 0 and result["after"] != result["before"]:
        new = sorted(set(result["after"]) - set(result["before"]))
        return f"exit status {status} but files were written: {new}", []
    warnings = []
    if status == 1:
        lines = [ln for ln in stderr.splitlines() if ln.strip()]
        if len(lines) != 1:
            warnings.append(f"error is {len(lines)} lines")
        if "::" in stderr or ".tmp-" in stderr or "/tmp/" in stderr:
            warnings.append("error names a Rust type or a temporary path: " + stderr.strip()[:300])
    return None, warnings


def classify(text: str) -> str:
    """A failure's class: numbers, quoted text and temporary names blanked."""
    text = re.sub(r"\.tmp-\S+", ".tmp-_", text)
    text = re.sub(r"'[^']*'|\"[^\"]*\"|`[^`]*`", "_", text)
    return re.sub(r"[0-9][0-9.e+-]*", "#", text)[:160]


def save(crashes: Path, case: Case, message: str) -> Path:
    crashes.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha1(json.dumps(case.to_json(), sort_keys=True).encode()).hexdigest()[:12]
    path = crashes / f"cli-{digest}"
    path.mkdir(exist_ok=True)
    for name, data in case.files.items():
        (path / name).parent.mkdir(parents=True, exist_ok=True)
        (path / name).write_bytes(data)
    (path / "case.txt").write_text(
        f"cd {path} && robot-stiffness {' '.join(repr(a) if not a or ' ' in a else a for a in case.argv)}\n"
        f"case {case.index}\n{message}\n", encoding="utf-8")
    return path


def machine() -> Dict[str, Any]:
    cpu = "unknown"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return {"cpu": cpu, "logical_cpus": os.cpu_count(), "os": platform.platform(),
            "python": platform.python_version()}


def fuzz(args: argparse.Namespace) -> int:
    seeds = load_seeds()
    worker = Worker()
    started = time.monotonic()
    counts: Dict[str, int] = {}
    failures: List[Dict[str, Any]] = []
    warnings: Dict[str, Dict[str, Any]] = {}
    seen: set = set()
    index = 0
    try:
        while time.monotonic() - started < args.seconds and (args.max_cases is None or index < args.max_cases):
            case = make_case(args.seed, index, seeds)
            result = worker.run(case, WALL_FACTOR * args.timeout)
            if result is None or (result["crash"] or "").startswith("hang"):
                # An interrupted command may leave threads running or end the process itself:
                # the next case gets a fresh worker.
                worker.kill()
                worker = Worker()
            failure, warns = check(case, result)
            key = "failure" if failure else f"status {result['status']}" if result else "failure"
            counts[key] = counts.get(key, 0) + 1
            if failure:
                # A traceback's class is its last line (the exception), per subcommand.
                last = [ln for ln in failure.splitlines() if ln.strip()][-1]
                cls = classify(failure.splitlines()[0] + last + " " + " ".join(case.argv[:2]))
                if cls not in seen:
                    seen.add(cls)
                    path = save(args.crashes, case, failure)
                    print(f"fuzz-cli: case {index}: {failure.splitlines()[0][:200]} (saved {path})",
                          file=sys.stderr)
                    failures.append({"case": index, "argv": case.argv, "message": failure[:2000]})
            for w in warns:
                cls = classify(w)
                if cls not in warnings:
                    warnings[cls] = {"case": index, "argv": case.argv, "message": w}
            index += 1
    finally:
        worker.kill()
    elapsed = time.monotonic() - started
    summary = (f"fuzz-cli: {index} cases in {elapsed:.1f} s, seed {args.seed}: "
               + ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
               + f"; {len(failures)} distinct failures, {len(warnings)} message warnings")
    print(summary)
    for warning in warnings.values():
        print(f"  warning (case {warning['case']}): {warning['message'][:200]}")
    if args.record:
        record = {
            "command": " ".join([Path(sys.argv[0]).name] + sys.argv[1:]),
            "date_utc": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "seed": args.seed, "timeout_s": args.timeout, "duration_s": round(elapsed, 1),
            "cases": index, "outcomes": counts, "failures": failures,
            "message_warnings": list(warnings.values()),
            "corpus": {k: len(v) for k, v in seeds.items()}, "machine": machine(),
        }
        Path(args.record).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    return 1 if failures else 0


def main() -> int:
    global ARGS_TIMEOUT
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=10.0, help="time budget (default 10)")
    p.add_argument("--seed", type=int, default=0, help="seed of the cases (default 0)")
    p.add_argument("--record", metavar="FILE", help="write the run's record as JSON")
    p.add_argument("--timeout", type=float, default=2.0, help="limit per case, s (default 2)")
    p.add_argument("--max-cases", type=int, default=None, help="stop after this many cases")
    p.add_argument("--crashes", type=Path, default=ROOT / "target" / "fuzz-crashes",
                   help="where failing cases are saved")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args()
    ARGS_TIMEOUT = args.timeout
    # The manifests' signing key of the cases' `--force` runs: in a folder of the run's own,
    # never the user's ~/.local/state (the cases inherit the environment).
    os.environ.setdefault("ROBOT_STIFFNESS_STATE_DIR", tempfile.mkdtemp(prefix="fuzz-cli-state-"))
    if args.worker:
        serve(args.timeout)
        return 0
    return fuzz(args)


if __name__ == "__main__":
    sys.exit(main())
