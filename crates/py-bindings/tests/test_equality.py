"""Equality on every result class (issue 24): field by field, arrays included, NaN equal to NaN;
a result equals its pickled copy, differs when one value differs, and comparing never raises."""
from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from robot_stiffness import vjm


@pytest.fixture(scope="module")
def robot() -> vjm.Robot:
    return vjm.Robot.bundled()


@pytest.fixture(scope="module")
def identification(robot):
    data = vjm.simulate(robot, [], n_poses=12, seed=4, gravity=None)
    m = data.measurements
    return robot.identify(m.q, m.wrench, m.displacement, gravity=None)


def _changed(obj, name):
    """``obj`` with the first element of its array field ``name`` changed."""
    arr = np.array(getattr(obj, name), copy=True)
    arr.flat[0] = arr.flat[0] + 1.0 if arr.dtype.kind in "fc" else not arr.flat[0]
    return dataclasses.replace(obj, **{name: arr})


def test_an_identification_equals_its_pickled_copy_and_not_a_changed_one(identification):
    copy = pickle.loads(pickle.dumps(identification))
    assert copy == identification  # raised ValueError before (arrays in the fields)
    assert _changed(identification, "compliance") != identification
    assert _changed(identification, "identifiable") != identification
    assert identification != "not an identification"


def test_a_stiffness_model_equals_its_pickled_copy(identification):
    model = identification.stiffness_model
    assert pickle.loads(pickle.dumps(model)) == model  # compared unequal before
    with pytest.raises(TypeError):
        hash(model)


def test_predictions_plans_and_studies_compare_field_by_field(robot, identification):
    model = identification.stiffness_model
    q = np.array([[0.1, -0.4, 0.2, -2.0, 0.1, 1.7, 0.5], [0.0, -0.2, 0.0, -1.8, 0.0, 1.6, 0.0]])
    w = np.array([[10.0, -5.0, 20.0, 0.5, 0.0, 0.2]] * 2)
    pred = model.predict(q, wrench=w, gravity=None)
    assert np.isnan(pred.deflection[:, 3:]).all()  # rotations not modelled: NaN
    assert pred == model.predict(q, wrench=w, gravity=None)
    assert _changed(pred, "deflection") != pred
    study = vjm.paper_study(robot, seed=2)
    assert pickle.loads(pickle.dumps(study)) == study
    assert dataclasses.replace(study, rows=_changed(study.rows, "measured")) != study
    plan = vjm.design(robot, poses=4, seed=1)
    assert pickle.loads(pickle.dumps(plan)) == plan
    assert _changed(plan, "q") != plan
