"""Issue 23 item 2: the full virtual-joint model (translational link springs) from Python:
``model="full"``, the labels ``J4tz``, a hidden link translation recovered without weight and
under gravity."""
from __future__ import annotations

import pytest

from robot_stiffness import vjm


@pytest.fixture(scope="module")
def panda() -> vjm.Robot:
    return vjm.Robot.bundled()


def test_full_labels(panda):
    labels = panda.labels("full")
    assert len(labels) == 42
    assert labels[:6] == ["J1z", "J1x", "J1y", "J1tz", "J1tx", "J1ty"]
    assert panda.labels("traditional + link_translation(J4z)")[4] == "J4tz"


def test_identify_recovers_a_hidden_link_translation(panda):
    c = 5e-6  # m/N: a link of 0.2 N/µm, well above the testbed's tracker noise
    effect = {"effect": "link_translation", "joint": 4, "axis": "z", "compliance": c}
    data = vjm.simulate(panda, [effect], n_poses=60, seed=3, gravity=None).measurements
    res = panda.identify(data.q, data.wrench, data.displacement, model="traditional + J4tz", gravity=None)
    # The result's labels are the model's (a translation reads J4tz, not J4z).
    k = panda.labels("traditional + J4tz").index("J4tz")
    assert res.labels == panda.labels("traditional + J4tz")
    assert res.parameters[k].kind == "translation" and res.parameters[0].kind == "rotation"
    assert res.identifiable[k]
    assert abs(res.compliance[k] - c) < 0.1 * c, res.compliance[k]
    full = panda.identify(data.q, data.wrench, data.displacement, model="full", gravity=None)
    assert full.labels == panda.labels("full")
    for c in full.combinations:
        assert all(label in full.labels for label, _ in c.terms), c.terms


def test_identify_under_gravity_recovers_a_hidden_link_translation(panda):
    """Under the arm's weight (the default) a translational spring carries the mass beyond it:
    identify at the sagged equilibrium recovers it as without weight."""
    c = 5e-6
    effect = {"effect": "link_translation", "joint": 4, "axis": "z", "compliance": c}
    data = vjm.simulate(panda, [effect], n_poses=60, seed=3).measurements
    res = panda.identify(data.q, data.wrench, data.displacement, model="traditional + J4tz")
    k = res.labels.index("J4tz")
    assert res.identifiable[k]
    assert abs(res.compliance[k] - c) < 0.1 * c, res.compliance[k]
