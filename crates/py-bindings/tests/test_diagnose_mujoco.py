"""``diagnose`` under gravity on campaigns measured in MuJoCo with gravity on
(mujoco_campaign.py; each campaign is diagnosed under the gravity it was measured with): only
what holds with margin on every seed of scripts/diagnose_on_mujoco.py (docs/gravity.md,
"Diagnose on MuJoCo campaigns"), checked here at a few of its seeds. Skipped with a reason when
mujoco or example-robot-data is absent.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="mujoco is not installed (pip install mujoco)")

import mujoco_campaign as mc  # noqa: E402

from robot_stiffness import vjm  # noqa: E402

SEEDS = (22000, 22001, 22002)


def _spec(name: str) -> mc.ArmSpec:
    spec = mc.ArmSpec.example(name)
    if spec is None:
        pytest.skip(f"example-robot-data's {mc.ARMS[name][0]} not found (pip install example-robot-data)")
    return spec


def test_a_campaign_is_what_the_crate_predicts_under_gravity_and_reproducible():
    """The generator records loaded − unloaded under gravity for the wrench the arm felt: with
    no noise its rows are the crate's deflection_under_gravity (the same physics, checked
    against MuJoCo in test_gravity_mujoco.py), and the same seed gives the same campaign."""
    spec = _spec("xarm7")
    camp = mc.measure(spec, 6, 2, seed=5, tracker_sigma=0.0, ft_sigma=(0.0, 0.0))
    m = camp.measurements
    assert m.q.shape == (12, 7) and m.wrench.shape == (12, 6) and m.displacement.shape == (12, 3)
    assert list(m.pose) == [p for p in range(6) for _ in range(2)]
    assert set(m.set) == {"train", "test"}
    assert np.all((camp.torsion >= 2e3) & (camp.torsion <= 1e4))
    c = 1.0 / camp.torsion
    for q, w, d in zip(m.q, m.wrench, m.displacement):
        ours = camp.robot.deflection_under_gravity(c, q, w, "traditional")[:3]
        np.testing.assert_allclose(d, ours, rtol=0, atol=1e-8 * np.linalg.norm(ours))
    again = mc.measure(spec, 6, 2, seed=5, tracker_sigma=0.0, ft_sigma=(0.0, 0.0))
    np.testing.assert_array_equal(again.measurements.displacement, m.displacement)
    noisy = mc.measure(spec, 6, 2, seed=5, tracker_sigma=1e-5)
    assert 0 < np.abs(noisy.measurements.displacement - m.displacement).max() < 1e-4
    np.testing.assert_array_equal(noisy.measurements.q, m.q)  # noise changes no pose


#: arm → (named at its own joint: on 96–98 % of the study's seeds on UR10, all on Kinova;
#: held-out error lower on every study seed).
#: Panda and xArm7 intersect their J1 and J2 axes, so J2's tilt is J1's tilt about the same
#: axis through the same point: diagnose names either, with the other among its aliases.
#: UR10's held-out error drops on 92–94 % of the seeds only (0.97× at seed 22001).
TILT_ARMS = {"panda": (False, True), "xarm7": (False, True), "ur10": (True, False), "kinova": (True, True)}


@pytest.mark.parametrize("arm", sorted(TILT_ARMS))
def test_a_hidden_shoulder_tilt_is_named_under_gravity(arm):
    """A tilt at the shoulder (J2x, 50 kN·m/rad; J2y rigid), gravity on, noise given or not:
    named at J2x or as J1x with J2x among its aliases on ≥ 96 % of the study's 50 seeds per
    arm (docs/gravity.md), checked here at three of them; where the study shows it (almost)
    always, at its own joint, and where it shows it always, with a held-out error at most 0.9×
    the baseline's."""
    spec = _spec(arm)
    own_joint, better = TILT_ARMS[arm]
    for seed in SEEDS:
        camp = mc.measure(spec, 40, 4, seed=seed, tracker_sigma=10e-6, hidden=mc.tilt(1, kx=mc.TILT_K, ky=mc.STIFF))
        for given in (False, True):
            o = mc.judge(camp, given)
            assert o.named_or_alias, (seed, given, o.findings)
            if own_joint:
                assert o.named, (seed, given, o.findings)
            if better:
                assert o.extended_test < 0.9 * o.baseline_test, (seed, given, o)


def test_a_hidden_elbow_tilt_on_the_xarm7_is_named_or_a_joint_alias():
    """A tilt at the xArm7's elbow (J4, 50 kN·m/rad about x and y), whose J3 sits close to it:
    diagnose often names J3x instead (the study: J4 named in 16–24 % of 50 seeds, named or
    aliased in 96–98 %, docs/gravity.md). When it does, J4's two tilts together are a joint
    alias of the J3 tilt (`joint_tilt J4 x+y`): neither J4 tilt alone explains it, so without
    joint aliases these seeds would count as misses."""
    spec = _spec("xarm7")
    by_joint_alias = 0
    for seed in SEEDS:
        camp = mc.measure(spec, 40, 4, seed=seed, tracker_sigma=10e-6, hidden=mc.tilt(3, kx=mc.TILT_K, ky=mc.TILT_K))
        for given in (False, True):
            o = mc.judge(camp, given)
            assert o.named_or_alias, (seed, given, o.findings)
            by_joint_alias += not o.named and o.joint_alias
    assert by_joint_alias >= 1


def test_weightless_mujoco_data_alarm_on_nothing_but_the_real_geometric_nonlinearity():
    """The control: with gravity off, springs only, the one thing diagnose names is the
    geometric non-linearity that MuJoCo's equilibrium really has, nothing is unexplained."""
    spec = _spec("kinova")
    for seed in SEEDS:
        camp = mc.measure(spec, 40, 4, seed=seed, tracker_sigma=10e-6, gravity=(0.0, 0.0, 0.0))
        for given in (False, True):
            o = mc.judge(camp, given)
            assert not o.alarm_beyond_geometry, (seed, given, o.findings, o.unexplained)


@pytest.mark.parametrize("arm", ["panda", "ur10"])
def test_clean_springs_under_gravity_alarm_on_nothing_but_the_geometric_nonlinearity(arm):
    """Springs only, gravity on, diagnosed under that gravity: nothing named but the geometric
    non-linearity MuJoCo's equilibrium really has, nothing unexplained, noise given or not. The
    same campaigns diagnosed weightless (the model before issue 22) alarm on some of them with
    the noise given, so the test sees a diagnosis that ignores the weight."""
    spec = _spec(arm)
    weightless_alarms = 0
    for seed in SEEDS:
        camp = mc.measure(spec, 40, 4, seed=seed, tracker_sigma=10e-6)
        for given in (False, True):
            o = mc.judge(camp, given)
            assert not o.alarm_beyond_geometry, (seed, given, o.findings, o.unexplained)
        weightless_alarms += mc.judge(camp, True, weightless=True).alarm_beyond_geometry
    assert weightless_alarms >= 1


#: arm → the 0-based joint of a shoulder (J2) and an elbow gear.
GEAR_JOINTS = {"panda": (1, 3), "kinova": (1, 2)}


@pytest.mark.parametrize("arm", sorted(GEAR_JOINTS))
def test_a_gear_preloaded_by_gravity_is_named_at_its_joint_and_its_model_predicts_better(arm):
    """A hardening gear (5 → 12 kN·m/rad above 15 N·m) at the shoulder or the elbow, preloaded
    by the weight differently in every pose: named as joint_torsion_nonlinear at its joint,
    noise given or not, and the extended model's held-out error is lower than the baseline's
    (on every seed of the study for these arms). Weightless, the gear's knee sits at the wrong
    torque: on the Panda's shoulder the weightless model names it on neither seed (the control
    that the gravity model is what finds it; on the Kinova the weightless model finds it too)."""
    spec = _spec(arm)
    for joint in GEAR_JOINTS[arm]:
        weightless_named = 0
        for seed in SEEDS[:2]:
            camp = mc.measure(spec, 40, 4, seed=seed, tracker_sigma=10e-6, hidden=mc.gear(joint))
            for given in (False, True):
                o = mc.judge(camp, given)
                assert o.named, (joint, seed, given, o.findings)
                assert o.extended_test < o.baseline_test, (joint, seed, given, o)
            weightless_named += mc.judge(camp, False, weightless=True).named
        if (arm, joint) == ("panda", 1):
            assert weightless_named == 0


def test_the_hidden_effects_expected_finding():
    assert mc.CLEAN.expected() is None
    assert mc.tilt(1, kx=5e4, ky=mc.STIFF).expected() == ("joint_tilt", 2, ("x",))
    assert mc.tilt(2, kx=5e4, ky=5e4).expected() == ("joint_tilt", 3, ("x", "y"))
    assert mc.gear(3).expected() == ("joint_torsion_nonlinear", 4, (None,))
    with pytest.raises(ValueError, match="kind"):
        mc.Hidden("backlash", 1)
    law = mc.hardening()
    assert law(1e-3) == pytest.approx(-5.0)  # 5 kN·m/rad below the knee
    assert law(-(3e-3 + 1e-3)) == pytest.approx(15.0 + 12.0)  # 12 kN·m/rad beyond 15 N·m
    assert vjm.Measurements is type(mc.measure(_spec("kinova"), 2, 1, seed=0).measurements)
