"""benches/cli_predict.py removes the previous run's PRED file between timed runs: only a file
directly in the bench's own temporary directory; anything else is refused and left alone."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]


def _bench():
    sys.path.insert(0, str(ROOT / "benches"))
    try:
        spec = importlib.util.spec_from_file_location("cli_predict_bench", ROOT / "benches" / "cli_predict.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(ROOT / "benches"))


def test_median_child_removes_only_a_file_of_its_own_scratch_directory(tmp_path):
    bench = _bench()
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    users = tmp_path / "PRED.csv"  # beside the scratch directory, not in it
    users.write_text("a user's file\n")
    nested = scratch / "sub" / "PRED.csv"
    nested.parent.mkdir()
    nested.write_text("deeper\n")
    for fresh, where in [(users, scratch), (nested, scratch), (users, None)]:
        with pytest.raises(ValueError, match="not removing it"):
            bench.median_child(1, ["--version"], fresh=fresh, scratch=where)
    assert users.read_text() == "a user's file\n" and nested.read_text() == "deeper\n"
    # Its own file goes before the run, which then writes nothing there.
    own = scratch / "pred.csv"
    own.write_text("previous run\n")
    wall, peak = bench.median_child(1, ["--version"], fresh=own, scratch=scratch)
    assert not own.exists() and wall > 0 and peak > 0
