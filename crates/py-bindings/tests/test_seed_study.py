"""`vjm.seed_study`: a typed result with the per-row table as numpy arrays, both metrics, the
truth calibrated to the seed's torsion share."""

from __future__ import annotations

import numpy as np
import pytest

from robot_stiffness import vjm


@pytest.fixture(scope="module")
def study() -> vjm.SeedStudy:
    return vjm.seed_study(vjm.Robot.bundled(), seed=3)


def test_typed_result_with_the_per_row_table(study: vjm.SeedStudy) -> None:
    assert isinstance(study, vjm.SeedStudy)
    rows = study.rows
    assert rows.measured.shape == rows.traditional.shape == rows.extended.shape == (26, 3)
    assert rows.measured.dtype == np.float64
    np.testing.assert_array_equal(rows.test, np.arange(1, 27))
    np.testing.assert_array_equal(rows.test, 2 * (rows.configuration - 1) + rows.load)
    np.testing.assert_array_equal(rows.identification, rows.configuration <= 8)
    assert study.extended_rank <= 21
    assert study.paper.traditional_all == 0.0775 and study.paper.extended_verification_max_test == 21


def test_the_metrics_are_the_named_ones(study: vjm.SeedStudy) -> None:
    rows = study.rows
    d = np.linalg.norm(rows.measured, axis=1)
    magnitude = np.abs(np.linalg.norm(rows.traditional, axis=1) - d) / d
    vector = np.linalg.norm(rows.extended - rows.measured, axis=1) / d
    np.testing.assert_allclose(rows.traditional_magnitude_error, magnitude, rtol=1e-12)
    np.testing.assert_allclose(rows.extended_vector_error, vector, rtol=1e-12)
    t = study.traditional.magnitude
    assert t.all == pytest.approx(magnitude.mean(), rel=1e-12)
    assert t.identification == pytest.approx(magnitude[:16].mean(), rel=1e-12)
    assert t.verification == pytest.approx(magnitude[16:].mean(), rel=1e-12)
    e = study.extended.vector
    assert e.verification_max == pytest.approx(vector[16:].max(), rel=1e-12)
    assert e.verification_max_test == 17 + int(np.argmax(vector[16:]))


def test_the_truth_has_the_seed_torsion_share(study: vjm.SeedStudy) -> None:
    assert study.torsion_share == pytest.approx(0.765, abs=1e-3)
    fixed = vjm.seed_study(vjm.Robot.bundled(), tilt_ratio=0.5, noise=False)
    assert fixed.tilt_ratio == 0.5 and fixed.torsion_share < 0.7


def test_a_bad_tilt_ratio_is_named() -> None:
    with pytest.raises(ValueError, match="tilt_ratio"):
        vjm.seed_study(vjm.Robot.bundled(), tilt_ratio=-0.1)
