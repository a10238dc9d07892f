"""Typed diagnosis results: the same classes for the VJM and the CSJM, nothing lost on the way
from the core, the documented JSON keys, pickling, and joints 1-based in the truth file."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

from robot_stiffness import _core, csjm, results, vjm
from robot_stiffness.results import (
    Alias,
    CandidateScore,
    ConnectionTest,
    Diagnosis,
    DisplacementRows,
    Evidence,
    Finding,
    FTest,
    ModelSummary,
    MomentRows,
    Parameter,
    ResidualStructure,
)
from robot_stiffness._vjm_data import _pose_array

# The keys docs/diagnose.md and docs/csjm-diagnose.md document for `diagnose … --json`.
VJM_KEYS = {"baseline", "findings", "extended", "unexplained", "gain", "residuals", "scores",
            "rejected_on_holdout", "per_pose", "n_train", "n_test", "fdr"}
CSJM_KEYS = {"baseline", "findings", "extended", "unexplained", "gain", "connection_term", "residuals",
             "scores", "rejected_on_holdout", "noise_sigma", "n_train", "n_test", "fdr", "split_seed"}
FINDING_KEYS = {"effect", "joint", "axis", "aliases", "evidence"}

TILT = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 5e-5}


@pytest.fixture(scope="module")
def panda():
    return vjm.Robot.bundled()


@pytest.fixture(scope="module")
def campaign(panda):
    return vjm.simulate(panda, [TILT], n_poses=30, seed=1)


@pytest.fixture(scope="module")
def vjm_core(panda, campaign):
    """The core's own values for the campaign (what the typed classes are built from)."""
    m = campaign.measurements
    return _core.vjm_diagnose(panda._inner, m.q, m.wrench, m.displacement, pose=_pose_array(m.pose), set=m.set)


@pytest.fixture(scope="module")
def vjm_result(panda, campaign):
    return vjm.diagnose(panda, campaign.measurements)


@pytest.fixture(scope="module")
def csjm_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("csjm") / "c.csv"
    path.write_text(_core.csjm_simulate([{"effect": "cable_hysteresis", "friction": 2.0}], seed=0).csv)
    return path


def _nulls(x):
    """NaN → None, as the core's JSON writes non-finite numbers."""
    if isinstance(x, float) and not np.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _nulls(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_nulls(v) for v in x]
    return x


def test_vjm_result_is_typed_all_the_way_down(vjm_result):
    d = vjm_result
    assert isinstance(d, Diagnosis) and d.model_kind == "vjm"
    assert isinstance(d.baseline, ModelSummary) and isinstance(d.extended, ModelSummary)
    assert all(isinstance(p, Parameter) for p in d.baseline.parameters)
    assert isinstance(d.residuals.baseline, ResidualStructure)
    assert all(isinstance(s, CandidateScore) for s in d.scores)
    assert d.findings, "the hidden tilt must be named"
    f = d.findings[0]
    assert isinstance(f, Finding) and isinstance(f.evidence, Evidence) and isinstance(f.evidence.f_test, FTest)
    assert all(isinstance(a, Alias) for a in f.aliases)
    # Joints are 1-based: the hidden tilt at joint 3 about x is named (or one of its aliases).
    named = {(f.effect, f.joint, f.axis)} | {(a.effect, a.joint, a.axis) for a in f.aliases}
    assert ("joint_tilt", 3, "x") in named
    # CSJM-only fields are absent from a VJM result.
    assert d.connection_term is None and d.baseline.k is None and d.noise_sigma is None


def test_rows_are_numpy_columns(vjm_result, campaign):
    rows = vjm_result.rows
    n = len(campaign.measurements)
    assert isinstance(rows, DisplacementRows) and len(rows) == n
    assert rows.measured.shape == rows.baseline.shape == rows.extended.shape == (n, 3)
    # The measured column is the file's displacement (the core's input, not its output).
    np.testing.assert_array_equal(rows.measured, campaign.measurements.displacement)
    np.testing.assert_array_equal(rows.held_out, np.array(campaign.measurements.set) == "test")
    assert rows.pose.dtype == np.int64 and rows.held_out.dtype == np.bool_


def test_every_value_the_core_sends_has_a_field(vjm_core, csjm_path):
    """A field the core gains must be added to results.py (one line): this lists the keys that
    no dataclass field takes yet."""
    summary, _ = vjm_core
    assert results._unmapped_keys(Diagnosis, summary) == []
    summary, _ = _core.csjm_diagnose_csv(csjm_path)
    assert results._unmapped_keys(Diagnosis, summary) == []


def test_to_dict_is_what_the_core_sent(vjm_core, csjm_path):
    """Typed and back: the same keys and values as the core's result (nothing dropped, nothing
    added), for both models."""
    summary, rows = vjm_core
    # per_pose crosses as columns; its JSON form is one dict per pose, built here by hand.
    cols = summary["per_pose"]
    as_json = {**summary, "per_pose": [
        {"pose": int(cols["pose"][k]), "set": "test" if cols["held_out"][k] else "train",
         "baseline": float(cols["baseline"][k]), "extended": float(cols["extended"][k])}
        for k in range(len(cols["pose"]))]}
    assert _nulls(Diagnosis._from_core("vjm", summary, rows).to_dict()) == _nulls(as_json)
    summary, rows = _core.csjm_diagnose_csv(csjm_path)
    assert _nulls(Diagnosis._from_core("csjm", summary, rows).to_dict()) == summary


def test_vjm_json_keys_and_rows_on_request(vjm_result, campaign):
    doc = vjm_result.to_dict()
    assert VJM_KEYS <= set(doc) and "rows" not in doc
    assert FINDING_KEYS <= set(doc["findings"][0])
    assert {"model", "n_params", "test_mean_rel_error"} <= set(doc["baseline"])
    assert "connection_term" not in doc and "k" not in doc["baseline"]
    full = json.loads(vjm_result.to_json(rows=True))
    assert len(full["rows"]) == len(campaign.measurements)
    assert set(full["rows"][0]) == {"pose", "set", "measured", "baseline", "extended"}
    assert full["rows"][0]["measured"] == campaign.measurements.displacement[0].tolist()


def test_csjm_uses_the_same_classes(csjm_path):
    d = csjm.diagnose(csjm_path)
    assert isinstance(d, Diagnosis) and d.model_kind == "csjm"
    assert isinstance(d.rows, MomentRows) and d.rows.dzeta.shape == (len(d.rows), 3)
    assert isinstance(d.connection_term, ConnectionTest)
    assert isinstance(d.baseline, ModelSummary) and np.shape(d.baseline.k) == (3, 3)
    assert all(isinstance(f, Finding) for f in d.findings)
    assert "cable_hysteresis" in [f.effect for f in d.findings]
    doc = d.to_dict()
    assert CSJM_KEYS <= set(doc) and "rows" not in doc and "per_pose" not in doc
    assert "lambda" in doc["connection_term"] and "lambda_" not in doc["connection_term"]
    assert d.per_pose is None


def test_results_pickle(vjm_result, csjm_path):
    for d in (vjm_result, csjm.diagnose(csjm_path)):
        back = pickle.loads(pickle.dumps(d))
        assert back == d
        assert back.to_dict() == d.to_dict() and back.rows == d.rows
        assert type(back.findings[0]) is Finding


def test_dict_access_of_earlier_versions_still_works(vjm_result):
    d = vjm_result
    assert d["findings"][0]["effect"] == d.findings[0].effect
    assert d["baseline"]["model"] == "traditional"
    assert d.findings[0].get("joint") == d.findings[0].joint
    assert len(d["rows"]) == len(d.rows)
    with pytest.raises(KeyError):
        d["no_such_key"]


def test_a_dict_result_reads_back_as_the_same_diagnosis(vjm_result):
    back = Diagnosis._from_dict(vjm_result.to_dict(rows=True))
    assert back == vjm_result and back.rows == vjm_result.rows


def test_a_csjm_result_saved_before_the_renames_reads_back(csjm_path):
    # Issue 26 renamed `holdout_seed` to `split_seed` and `z_seed_eq48b` to `z_paper_eq48b`:
    # a result saved under the former keys reads back as the same diagnosis.
    d = csjm.diagnose(csjm_path, split_seed=5)
    doc = d.to_dict(rows=True)
    assert "split_seed" in doc and "z_paper_eq48b" in doc["connection_term"]
    doc["holdout_seed"] = doc.pop("split_seed")
    doc["connection_term"]["z_seed_eq48b"] = doc["connection_term"].pop("z_paper_eq48b")
    back = Diagnosis._from_dict(doc)
    assert back == d and back.split_seed == 5
    assert back.connection_term.z_paper_eq48b == d.connection_term.z_paper_eq48b


def test_truth_counts_joints_from_one(panda, campaign, tmp_path):
    # The truth of a campaign names the joint the user gave (1-based), in Python and in the
    # CLI's truth.json.
    assert campaign.truth["effects"][0]["joint"] == 3
    from robot_stiffness.cli import main

    code = main(["simulate", "vjm", "--out", str(tmp_path / "c.csv"), "--poses", "4", "--effect",
                 "joint_backlash:joint=7,lost_motion=2e-4", "--truth", str(tmp_path / "t.json")])
    assert code == 0
    truth = json.loads((tmp_path / "t.json").read_text())["truth"]
    assert truth["effects"] == [{"effect": "joint_backlash", "joint": 7, "lost_motion": 2e-4}]


def test_csjm_fit_is_typed_and_pickles(csjm_path):
    fit = csjm.identify_csv(csjm_path, order=2)
    core = _core.csjm_identify_csv(csjm_path, order=2)
    assert not hasattr(fit, "raw")
    assert fit.to_dict()["regressor_condition"] == core.regressor_condition
    assert fit.dof == core.dof and fit.curvature is not None and fit.curvature.shape == (3, 3, 3)
    back = pickle.loads(pickle.dumps(fit))
    np.testing.assert_array_equal(back.K, fit.K)
    assert back.to_dict() == fit.to_dict()


def test_identification_is_typed_and_covers_the_core(panda, campaign):
    from robot_stiffness._identification import _CoreIdentification
    from robot_stiffness.vjm import IdentifiedParameter

    m = campaign.measurements
    core, _ = panda._identify(m.q, m.wrench, m.displacement, "extended", None, None, False, False, False,
                              "auto", None, False)
    assert results._unmapped_keys(_CoreIdentification, core) == []
    res = panda.identify(m.q, m.wrench, m.displacement, model="extended")
    assert not hasattr(res, "raw")
    assert all(isinstance(p, IdentifiedParameter) for p in res.parameters)
    assert [p.label for p in res.parameters] == res.labels and res.labels[:3] == ["J1z", "J1x", "J1y"]
    doc = res.to_dict()
    # The JSON of `identify vjm --json` is the core's own values, reorganised as documented.
    assert [p["compliance"] for p in doc["parameters"]] == core["compliance"]
    assert doc["combinations"] == core["combinations"] and doc["aliases"] == core["alias_labels"]


def test_results_with_undefined_statistics_equal_their_copies(vjm_result):
    import dataclasses

    f = vjm_result.findings[0]
    undefined = dataclasses.replace(f.evidence.f_test, p_value=float("nan"))
    d = dataclasses.replace(vjm_result, gain=float("nan"), findings=[
        dataclasses.replace(f, evidence=dataclasses.replace(f.evidence, f_test=undefined))])
    assert pickle.loads(pickle.dumps(d)) == d
    assert d != vjm_result  # and a real difference is still one
    assert dataclasses.replace(d, gain=0.5) != d


def test_long_lists_of_flat_results_are_built_as_single_items_are():
    """per_pose (10⁵ entries in a large campaign) takes a fast path: the same objects as the
    field-by-field one, null floats as NaN, a key the core left out left to its default."""
    from typing import List

    from robot_stiffness import results

    entries = [{"pose": 3, "set": "test", "baseline": 0.25, "extended": None},
               {"pose": np.int64(4), "set": "train", "baseline": 1, "extended": 0.5}]
    fast = results._build(List[results.PoseError], entries)
    slow = [results._build(results.PoseError, e) for e in entries]
    assert fast == slow
    assert isinstance(fast[1].pose, int) and isinstance(fast[1].baseline, float)
    assert np.isnan(fast[0].extended)
    with pytest.raises(TypeError):
        results._build(List[results.PoseError], [[1, "test", 0.1, 0.2]])


def test_per_pose_errors_are_columns_read_as_a_sequence(vjm_result, campaign):
    """per_pose crosses as four arrays (10⁵ poses in a large campaign) and reads as a sequence
    of PoseError: length, indexing from either end, slices, iteration, its JSON form, pickling,
    and a clear error for an index out of range or a column of the wrong length."""
    from robot_stiffness.results import PoseError, PoseErrors

    pp = vjm_result.per_pose
    assert isinstance(pp, PoseErrors)
    poses = list(dict.fromkeys(campaign.measurements.pose.tolist()))
    assert len(pp) == len(poses) and pp.pose.tolist() == poses
    assert pp.pose.dtype == np.int64 and pp.held_out.dtype == np.bool_ and pp.baseline.dtype == np.float64
    first, last = pp[0], pp[-1]
    assert isinstance(first, PoseError) and first.pose == poses[0] and last.pose == poses[-1]
    assert first.baseline == pp.baseline[0] and first.set in ("train", "test")
    # A pose is held out exactly when its rows are.
    test_rows = {p for p, s in zip(campaign.measurements.pose.tolist(), campaign.measurements.set) if s == "test"}
    assert {e.pose for e in pp if e.set == "test"} == test_rows
    assert [e.pose for e in pp[1:4]] == poses[1:4] and isinstance(pp[1:4], PoseErrors)
    with pytest.raises(IndexError, match="out of range"):
        pp[len(pp)]
    doc = vjm_result.to_dict()["per_pose"]
    assert doc[0] == {"pose": first.pose, "set": first.set, "baseline": first.baseline, "extended": first.extended}
    assert PoseErrors._from_core(doc) == pp
    assert pickle.loads(pickle.dumps(pp)) == pp
    with pytest.raises(ValueError, match="'baseline' has shape"):
        PoseErrors([1, 2], [False, True], [0.1], [0.2, 0.3])
    with pytest.raises(AttributeError):
        pp.pose = pp.pose  # type: ignore[misc]
