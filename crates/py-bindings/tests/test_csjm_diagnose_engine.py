"""CSJM diagnose on the shared engine (issue 11): the same progress/cancel contract and FDR
default as the arm's diagnose, through arrays and files."""

from __future__ import annotations

from pathlib import Path

import pytest

import robot_stiffness as rs
from robot_stiffness import csjm


@pytest.fixture(scope="module")
def friction_csv(tmp_path_factory) -> Path:
    camp = csjm.simulate([{"effect": "cable_hysteresis", "friction": 2.0}], seed=11)
    path = tmp_path_factory.mktemp("csjm") / "c.csv"
    path.write_text(camp.csv)
    return path


def test_progress_is_reported_and_the_default_fdr_is_the_engines(friction_csv: Path):
    seen = []
    result = csjm.diagnose(friction_csv, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert "cable_hysteresis" in [f["effect"] for f in result.findings]
    stages = [s for s, _, _ in seen]
    assert stages[0] == "baseline" and "selection" in stages and stages[-1] == "residuals", seen
    assert result.fdr == 0.01
    # Arrays and the file give the same diagnosis.
    R, tau, ref = csjm.read_measurements(friction_csv)
    from_arrays = csjm.diagnose(R, tau, ref, progress=lambda *a: None)
    assert [f["effect"] for f in from_arrays.findings] == [f["effect"] for f in result.findings]


def test_an_exception_in_progress_stops_the_run_and_propagates(friction_csv: Path):
    class Stop(Exception):
        pass

    def stop(stage, done, total):
        raise Stop(stage)

    with pytest.raises(Stop):
        csjm.diagnose(friction_csv, progress=stop)


def test_a_progress_that_is_not_callable_is_refused(friction_csv: Path):
    with pytest.raises(rs.ArgumentTypeError, match="progress must be callable"):
        csjm.diagnose(friction_csv, progress=3)


def test_the_split_seed_has_the_arms_name_and_default(friction_csv: Path):
    # One name and one default for every model (issue 26): `split_seed`, 0.
    default = csjm.diagnose(friction_csv)
    assert default.split_seed == 0
    other = csjm.diagnose(friction_csv, split_seed=7)
    assert other.split_seed == 7
    assert (other.n_train, other.n_test) == (default.n_train, default.n_test)
    # Another split holds out other rows: the held-out error changes.
    assert other.baseline.test_mean_rel_error != default.baseline.test_mean_rel_error
    # The former name still works, with a warning, and means the same seed.
    with pytest.warns(DeprecationWarning, match="split_seed"):
        old = csjm.diagnose(friction_csv, holdout_seed=7)
    assert old.split_seed == 7 and old.baseline.test_mean_rel_error == other.baseline.test_mean_rel_error
    with pytest.raises(rs.StiffnessError, match="split_seed alone"):
        csjm.diagnose(friction_csv, split_seed=7, holdout_seed=7)
