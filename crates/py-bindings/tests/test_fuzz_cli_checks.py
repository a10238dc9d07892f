"""The CLI fuzz harness (scripts/fuzz_cli.py) flags what it must flag: a traceback, an exit
status outside 0/1/2, a changed input, files written by a failed run, and a hang; and its cases
are a function of the seed alone."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def _fuzz_cli():
    spec = importlib.util.spec_from_file_location("fuzz_cli", ROOT / "scripts" / "fuzz_cli.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("fuzz_cli", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def _result(**changes):
    base = {"status": 1, "crash": None, "stdout": "", "stderr": "robot-stiffness: error: bad\n",
            "before": ["data.csv", "user/keep.txt"], "after": ["data.csv", "user/keep.txt"],
            "changed": [], "elapsed": 0.01}
    base.update(changes)
    return base


def test_clean_failure_passes_and_each_breach_is_flagged():
    fz = _fuzz_cli()
    case = fz.Case(0, ["identify", "vjm", "data.csv", "--json", "out.json"], {})
    assert fz.check(case, _result()) == (None, [])
    assert fz.check(case, None)[0].startswith("hang")
    assert fz.check(case, _result(crash="traceback: Traceback ..."))[0].startswith("traceback")
    assert "exit status" in fz.check(case, _result(status=3))[0]
    assert "traceback" in fz.check(case, _result(stderr="Traceback (most recent call last):\n"))[0]
    assert "changed" in fz.check(case, _result(changed=["data.csv"]))[0]
    written = _result(after=["data.csv", "out.json", "user/keep.txt"])
    assert "written" in fz.check(case, written)[0]
    # A successful run may write what it was asked to, never over its input.
    assert fz.check(case, _result(status=0, after=written["after"]))[0] is None
    over_input = fz.Case(0, ["identify", "vjm", "data.csv", "--json", "data.csv"], {})
    assert "changed" in fz.check(over_input, _result(status=0, changed=["data.csv"]))[0]


def test_cases_depend_on_the_seed_only():
    fz = _fuzz_cli()
    seeds = fz.load_seeds()
    first = [fz.make_case(7, i, seeds).to_json() for i in range(50)]
    again = [fz.make_case(7, i, seeds).to_json() for i in range(50)]
    other = [fz.make_case(8, i, seeds).to_json() for i in range(50)]
    assert first == again
    assert first != other
