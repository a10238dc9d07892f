//! SO(3) toolkit: group axioms as seeded properties, Jacobians against first-order
//! perturbations, edge-case fixtures at θ = 0, 1e-8, π − ε, π, and strict/projecting
//! conversion of measured matrices.

use std::f64::consts::PI;

use nalgebra::{Matrix3, Rotation3, Vector3};
use proptest::prelude::*;
use so3_stiffness::so3::*;
use so3_stiffness::So3Error;

use crate::strategies::{config, rotation, rotation_vector, unit_vector, vector};

/// Step of the first-order checks: the remainder is O(h²) ≈ 1e-12 rad, while a wrong
/// Jacobian coefficient would leave an O(h) ≈ 1e-7 rad error.
const H: f64 = 1e-6;

proptest! {
    #![proptest_config(config(64))]

    #[test]
    fn exp_of_log_is_identity(r in rotation()) {
        let back = exp(&log(&r));
        prop_assert!((back.matrix() - r.matrix()).norm() < 1e-13);
        prop_assert!(log(&r).norm() <= PI + 1e-15);
    }

    #[test]
    fn log_of_exp_is_identity_below_pi(w in rotation_vector(PI - 1e-6)) {
        prop_assert!((log(&exp(&w)) - w).norm() < 1e-12 * w.norm().max(1.0));
    }

    #[test]
    fn log_near_pi_is_accurate_for_any_axis(n in unit_vector(), eps in 1e-9..1e-5f64, tiny in 0.0..1e-9f64) {
        let w = n * (PI - eps);
        prop_assert!((log(&exp(&w)) - w).norm() < 1e-9, "ε = {eps:e}");
        // Closer to π the sign of the axis is below round-off: either answer, but exp∘log = id.
        let r = exp(&(n * (PI - tiny)));
        let l = log(&r);
        prop_assert!((exp(&l).matrix() - r.matrix()).norm() < 1e-12);
        prop_assert!((l.norm() - (PI - tiny)).abs() < 1e-9);
    }

    #[test]
    fn vee_of_hat_is_identity(w in vector(10.0)) {
        prop_assert_eq!(vee(&hat(&w)), w);
        let v = Vector3::new(0.3, -1.2, 0.7);
        prop_assert!((hat(&w) * v - w.cross(&v)).norm() < 1e-14 * (1.0 + w.norm()));
    }

    #[test]
    fn exp_matches_an_independent_rodrigues(n in unit_vector(), log_theta in -9.0..0.5f64, near_pi in 0.0..1e-6f64) {
        // nalgebra's Rotation3::new is a separate implementation of the same map; compare at
        // θ from 1e-9 to ~3.16 rad and just below π.
        for theta in [10f64.powf(log_theta), PI - near_pi] {
            let w = n * theta;
            let reference = Rotation3::new(w);
            prop_assert!((exp(&w).matrix() - reference.matrix()).norm() < 4e-16 * 9.0,
                "θ = {theta:e}: {:e}", (exp(&w).matrix() - reference.matrix()).norm());
        }
    }

    #[test]
    fn exp_is_a_rotation(w in vector(10.0)) {
        let r = exp(&w);
        prop_assert!(orthogonality_error(r.matrix()) < 1e-14);
        prop_assert!((r.matrix().determinant() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn adjoint_conjugates_hat(r in rotation(), w in vector(2.0)) {
        let lhs = adjoint(&r) * w;
        let rhs = vee(&(r.matrix() * hat(&w) * r.matrix().transpose()));
        prop_assert!((lhs - rhs).norm() < 1e-14 * (1.0 + w.norm()));
    }

    #[test]
    fn left_jacobian_is_adjoint_of_right(w in rotation_vector(3.0)) {
        let jl = left_jacobian(&w);
        prop_assert!((jl - adjoint(&exp(&w)) * right_jacobian(&w)).norm() < 1e-14);
        prop_assert!((left_jacobian(&-w) - right_jacobian(&w)).norm() < 1e-15);
    }

    #[test]
    fn right_jacobian_first_order(w in rotation_vector(3.0), n in unit_vector()) {
        let d = n * H;
        let lhs = log(&(exp(&w).inverse() * exp(&(w + d))));
        prop_assert!((lhs - right_jacobian(&w) * d).norm() < 1e-11, "{:e}", (lhs - right_jacobian(&w) * d).norm());
    }

    #[test]
    fn left_jacobian_first_order(w in rotation_vector(3.0), n in unit_vector()) {
        let d = n * H;
        let lhs = log(&(exp(&(w + d)) * exp(&w).inverse()));
        prop_assert!((lhs - left_jacobian(&w) * d).norm() < 1e-11);
    }

    #[test]
    fn right_jacobian_inverse_first_order(w in rotation_vector(3.0), n in unit_vector()) {
        // log(exp(w)·exp(d)) ≈ w + J_r⁻¹(w) d
        let d = n * H;
        let lhs = log(&(exp(&w) * exp(&d))) - w;
        prop_assert!((lhs - right_jacobian_inverse(&w) * d).norm() < 1e-11);
        prop_assert!((right_jacobian_inverse(&w) * right_jacobian(&w) - Matrix3::identity()).norm() < 1e-12);
    }

    #[test]
    fn left_jacobian_inverse_first_order(w in rotation_vector(3.0), n in unit_vector()) {
        let d = n * H;
        let lhs = log(&(exp(&d) * exp(&w))) - w;
        prop_assert!((lhs - left_jacobian_inverse(&w) * d).norm() < 1e-11);
        prop_assert!((left_jacobian_inverse(&w) * left_jacobian(&w) - Matrix3::identity()).norm() < 1e-12);
    }

    #[test]
    fn bracket_is_the_matrix_commutator(a in vector(2.0), b in vector(2.0)) {
        let commutator = hat(&a) * hat(&b) - hat(&b) * hat(&a);
        prop_assert!((hat(&bracket(&a, &b)) - commutator).norm() < 1e-14);
    }

    #[test]
    fn distance_is_a_bi_invariant_metric(a in rotation(), b in rotation(), c in rotation()) {
        let d = distance(&a, &b);
        prop_assert!((d - distance(&b, &a)).abs() < 1e-12);
        prop_assert!((distance(&(c * a), &(c * b)) - d).abs() < 1e-12);
        prop_assert!((distance(&(a * c), &(b * c)) - d).abs() < 1e-12);
        prop_assert!(distance(&a, &c) <= distance(&a, &b) + distance(&b, &c) + 1e-12);
    }

    #[test]
    fn projection_recovers_a_perturbed_rotation(r in rotation(), noise in vector(1e-3)) {
        let mut m = *r.matrix();
        m[(0, 1)] += noise.x;
        m[(2, 0)] += noise.y;
        m[(1, 1)] += noise.z;
        let p = project_to_rotation(&m).unwrap();
        prop_assert!(orthogonality_error(p.matrix()) < 1e-14);
        // Nearest rotation: never farther from m than the original rotation.
        prop_assert!((p.matrix() - m).norm() <= (r.matrix() - m).norm() + 1e-15);
    }
}

#[test]
fn log_is_exactly_zero_at_identity() {
    assert_eq!(log(&Rotation3::identity()), Vector3::zeros());
    assert_eq!(exp(&Vector3::zeros()), Rotation3::identity());
    assert_eq!(right_jacobian(&Vector3::zeros()), Matrix3::identity());
    assert_eq!(
        left_jacobian_inverse(&Vector3::zeros()),
        Matrix3::identity()
    );
}

#[test]
fn log_at_1e_minus_8_is_accurate_to_1e_minus_12_relative() {
    for n in [
        Vector3::x(),
        Vector3::new(1.0, -2.0, 2.0) / 3.0,
        Vector3::new(-0.48, 0.6, 0.64),
    ] {
        let w = n * 1e-8;
        let rel = (log(&exp(&w)) - w).norm() / 1e-8;
        assert!(rel < 1e-12, "relative error {rel:e} along {n:?}");
        // The Jacobians are I ± hat(w)/2 + O(θ²) there.
        let expected = Matrix3::identity() - 0.5 * hat(&w);
        assert!((right_jacobian(&w) - expected).norm() < 1e-16 * 10.0);
    }
}

#[test]
fn log_near_pi_is_within_1e_minus_9() {
    for n in [
        Vector3::z(),
        Vector3::new(1.0, 2.0, -2.0) / 3.0,
        Vector3::new(0.0, 0.6, -0.8),
    ] {
        for theta in [PI - 1e-9, PI - 1e-7, PI - 1e-4] {
            let w = n * theta;
            let err = (log(&exp(&w)) - w).norm();
            assert!(err < 1e-9, "θ = π − {:e}: error {err:e}", PI - theta);
        }
    }
}

#[test]
fn log_at_pi_returns_one_of_the_two_answers() {
    for n in [
        Vector3::x(),
        Vector3::new(1.0, 2.0, -2.0) / 3.0,
        Vector3::new(0.0, 0.6, -0.8),
    ] {
        let r = exp(&(n * PI));
        let l = log(&r);
        assert!((l.norm() - PI).abs() < 1e-12);
        assert!(
            (l - n * PI).norm() < 1e-9 || (l + n * PI).norm() < 1e-9,
            "{l:?}"
        );
    }
    // An exact half-turn matrix (not produced by exp): diag(1, −1, −1).
    let half_turn =
        Rotation3::from_matrix_unchecked(Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)));
    let l = log(&half_turn);
    assert!(
        (l.abs() - Vector3::new(PI, 0.0, 0.0)).norm() < 1e-15,
        "{l:?}"
    );
}

#[test]
fn inverse_jacobians_at_pi_are_finite() {
    let w = Vector3::new(0.0, 0.6, -0.8) * PI;
    let e = (right_jacobian_inverse(&w) * right_jacobian(&w) - Matrix3::identity()).norm();
    assert!(e < 1e-13, "{e:e}");
}

#[test]
fn strict_conversion_reports_the_orthogonality_error() {
    let r = exp(&Vector3::new(0.3, -0.2, 0.1));
    let m = r.matrix() * 1.002;
    match rotation_from_matrix(&m, 1e-3) {
        Err(So3Error::NotOrthogonal { error, tol }) => {
            assert!((error - orthogonality_error(&m)).abs() < 1e-15);
            assert!((error - 3f64.sqrt() * (1.002f64.powi(2) - 1.0)).abs() < 1e-12);
            assert_eq!(tol, 1e-3);
        }
        other => panic!("expected NotOrthogonal, got {other:?}"),
    }
    // Accepted matrices are returned unchanged, never re-orthonormalised.
    let slightly_off = r.matrix() * (1.0 + 1e-9);
    assert_eq!(
        rotation_from_matrix(&slightly_off, 1e-6).unwrap().matrix(),
        &slightly_off
    );
    // A reflection is orthogonal but not a rotation.
    let reflection = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    assert!(matches!(
        rotation_from_matrix(&reflection, 1e-6),
        Err(So3Error::NonPositiveDeterminant { .. })
    ));
}

#[test]
fn projection_rejects_bad_matrices() {
    let mut nan = Matrix3::identity();
    nan[(2, 1)] = f64::INFINITY;
    assert_eq!(
        project_to_rotation(&nan),
        Err(So3Error::NonFinite {
            what: "matrix to project",
            row: 2,
            col: 1
        })
    );
    let singular = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0));
    assert!(matches!(
        project_to_rotation(&singular),
        Err(So3Error::NonPositiveDeterminant { .. })
    ));
    let rank_one = Vector3::new(1.0, 2.0, 3.0) * Vector3::new(1.0, 0.0, 1.0).transpose();
    assert!(project_to_rotation(&rank_one).is_err());
    assert!(matches!(
        project_to_rotation(&-Matrix3::identity()),
        Err(So3Error::NonPositiveDeterminant { .. })
    ));
}

#[test]
fn projection_rejects_numerically_rank_deficient_matrices() {
    // det > 0 but one singular value at round-off level: the nearest rotation is not unique.
    let m = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 1e-300));
    assert!(matches!(
        project_to_rotation(&m),
        Err(So3Error::RankDeficient { .. })
    ));
}
