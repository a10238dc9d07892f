//! SO(3) toolkit: group axioms as seeded properties, Jacobians against first-order
//! perturbations, edge-case fixtures at θ = 0, 1e-8, π − ε, π, and strict/projecting
//! conversion of measured matrices.

use std::f64::consts::PI;

use nalgebra::{Matrix3, Rotation3, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
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

/// `log` as it was before the polynomial arctangent (libm `atan2`; axis near π from the
/// normalised symmetric part), kept verbatim as an independent reference.
fn reference_log(r: &Rotation3<f64>) -> Vector3<f64> {
    let m = r.matrix();
    let s_vec = vee(m);
    let s = s_vec.norm();
    let c = 0.5 * (m.trace() - 1.0);
    let theta = s.atan2(c);
    if c >= 0.0 {
        let factor = if theta < 1e-4 {
            let t2 = theta * theta;
            1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0
        } else {
            theta / s
        };
        return factor * s_vec;
    }
    let sym = 0.5 * (m + m.transpose());
    let nn = (sym - Matrix3::identity() * c) / (1.0 - c);
    let k = (0..3)
        .max_by(|&i, &j| nn[(i, i)].total_cmp(&nn[(j, j)]))
        .unwrap_or(0);
    let mut n = nn.column(k).into_owned();
    n /= n.norm();
    if n.dot(&s_vec) < 0.0 {
        n = -n;
    }
    theta * n
}

/// Seeded dense sweep of every branch of `log` (Taylor below 1e-4, then cos θ > ½,
/// |cos θ| ≤ ½ and cos θ < −½) against the previous implementation and the round trips.
/// Angles: a uniform grid on [0, π], 1e-12…0.1 and π − (1e-12…0.1) log-spaced, the branch
/// boundaries 1e-4, π/3, 2π/3 (and π/2) and their neighbours; random axes.
///
/// Tolerances: log∘exp and new-vs-old are ≤ 1.5e-15·θ, i.e. ~7 ε relative. Both logs are
/// ~1–2 ε from the exact log of the rounded matrix, and the input matrix exp(ω) itself
/// carries ~ε rounding, which moves the answer by ~ε·θ. Near π nothing is looser: the axis
/// comes from the symmetric part, so conditioning stays at a few ε absolute (measured max
/// 0.53e-15·θ over the sweep; scaling θ by 1 + 1e-15 in the middle or the near-π branch
/// fails).
/// exp∘log is compared in the Frobenius norm of the 9 entries, each off by a few ε: ≤ 3e-15
/// (measured max 1.6e-15).
#[test]
fn log_matches_the_libm_reference_and_round_trips_on_a_dense_sweep() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed_0101);
    let mut thetas: Vec<f64> = (0..=20_000).map(|i| PI * f64::from(i) / 20_000.0).collect();
    for i in 0..=2_000 {
        let d = 10f64.powf(-12.0 + 11.0 * f64::from(i) / 2_000.0);
        thetas.push(d);
        thetas.push(PI - d);
    }
    for b in [1e-4, PI / 3.0, PI / 2.0, 2.0 * PI / 3.0] {
        let mut t = b;
        let mut u = b;
        for _ in 0..50 {
            thetas.push(t);
            thetas.push(u);
            t = f64::from_bits(t.to_bits() + 1);
            u = f64::from_bits(u.to_bits() - 1);
        }
    }
    let (mut worst_ref, mut worst_log_exp, mut worst_exp_log) = (0.0f64, 0.0f64, 0.0f64);
    for theta in thetas {
        let axis = loop {
            let v = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let norm = v.norm();
            if norm > 0.1 && norm < 1.0 {
                break v / norm;
            }
        };
        let w = axis * theta;
        let r = exp(&w);
        let l = log(&r);
        let tol = 1.5e-15 * theta;
        let e_ref = (l - reference_log(&r)).norm();
        let e_log_exp = (l - w).norm();
        let e_exp_log = (exp(&l).matrix() - r.matrix()).norm();
        assert!(
            e_ref <= tol && e_log_exp <= tol && e_exp_log <= 3e-15,
            "θ = {theta:e}, axis {axis:?}: |log − reference| = {e_ref:e}, \
             |log∘exp − id| = {e_log_exp:e}, ‖exp∘log − id‖ = {e_exp_log:e}"
        );
        if theta > 0.0 {
            worst_ref = worst_ref.max(e_ref / theta);
            worst_log_exp = worst_log_exp.max(e_log_exp / theta);
        }
        worst_exp_log = worst_exp_log.max(e_exp_log);
    }
    eprintln!(
        "log sweep: max |log − reference|/θ = {worst_ref:e}, max |log∘exp − id|/θ = \
         {worst_log_exp:e}, max ‖exp∘log − id‖ = {worst_exp_log:e}"
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
