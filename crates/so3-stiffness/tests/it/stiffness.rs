//! Stiffness acceptance tests (issue 2): over random geometries, poses, tensions, cable
//! stiffnesses and point loads,
//! (a) the analytic covariant stiffness equals the central-difference covariant Hessian of
//!     the simulator's potential to 1e-6 relative,
//! (b) it is symmetric to 1e-8 relative,
//! (c) the Euclidean variant's asymmetry is exactly the commutator term hat(τ),
//! and the seed's printed eqs. 31/48b (γ = ±2, K_L = −hat τ) fail (a) and (b).

use nalgebra::{Matrix3, Rotation3, Vector3};
use proptest::prelude::*;
use so3_stiffness::csjm::{levi_civita_term, stiffness_at, CsjmGeometry, CsjmSimulator};
use so3_stiffness::so3::{self, hat};

use crate::finite_differences::{
    body_gradient, covariant_hessian, geodesic_second_derivative, iterated_derivatives,
    relative_error,
};
use crate::strategies::{config, loaded_system, unit_vector};

/// FD step (rad) for second derivatives of Φ: truncation ~h²·Φ⁗ and round-off ~ε·Φ/h² are
/// both ≲ 1e-8 relative for these systems (Φ ≲ 5 J, K ≳ 5 N·m/rad).
const H2: f64 = 1e-4;

fn potential(sim: &CsjmSimulator) -> impl Fn(&Rotation3<f64>) -> f64 + '_ {
    move |r| {
        sim.potential(r)
            .expect("cables stay taut within the FD stencil")
    }
}

proptest! {
    #![proptest_config(config(40))]

    #[test]
    fn holding_moment_is_the_body_gradient_of_the_potential((sim, r) in loaded_system()) {
        let tau = sim.holding_moment(&r).unwrap();
        let fd = body_gradient(&potential(&sim), &r, 1e-6);
        prop_assert!((tau - fd).norm() < 1e-7 * tau.norm().max(1.0), "τ {tau:?} vs ∇Φ {fd:?}");
    }

    #[test]
    fn covariant_stiffness_is_the_covariant_hessian_of_the_potential((sim, r) in loaded_system()) {
        let s = sim.stiffness(&r).unwrap();
        let fd = covariant_hessian(&potential(&sim), &r, H2);
        let err = relative_error(&s.covariant, &fd);
        prop_assert!(err < 1e-6, "relative error {err:e}\nanalytic {}\nfd {}", s.covariant, fd);
    }

    #[test]
    fn covariant_stiffness_matches_second_derivatives_along_geodesics((sim, r) in loaded_system(), x in unit_vector()) {
        // Independent of the connection formula: on a bi-invariant group the curves R·exp(t x)
        // are geodesics, so d²Φ/dt² = xᵀ K x.
        let s = sim.stiffness(&r).unwrap();
        let fd = geodesic_second_derivative(&potential(&sim), &r, &x, H2);
        let analytic = x.dot(&(s.covariant * x));
        prop_assert!((fd - analytic).abs() < 1e-6 * s.covariant.norm(), "{fd} vs {analytic}");
    }

    #[test]
    fn covariant_stiffness_is_symmetric((sim, r) in loaded_system()) {
        let k = sim.stiffness(&r).unwrap().covariant;
        let asym = (k - k.transpose()).norm() / k.norm();
        prop_assert!(asym < 1e-8, "‖K − Kᵀ‖/‖K‖ = {asym:e}");
    }

    #[test]
    fn euclidean_stiffness_is_the_iterated_derivative_and_its_asymmetry_is_the_commutator((sim, r) in loaded_system()) {
        let s = sim.stiffness(&r).unwrap();
        let fd = iterated_derivatives(&potential(&sim), &r, H2);
        prop_assert!(relative_error(&s.euclidean, &fd) < 1e-6);
        // K_D − K_Dᵀ = [L_j, L_i]Φ = hat(τ): measured on the finite differences, not the model.
        let commutator = hat(&body_gradient(&potential(&sim), &r, 1e-6));
        let fd_asym = fd - fd.transpose();
        prop_assert!((fd_asym - commutator).norm() < 1e-6 * s.euclidean.norm() + 1e-7);
        prop_assert!((s.euclidean - s.euclidean.transpose() - hat(&s.external_moment)).norm() < 1e-10 * s.euclidean.norm());
        prop_assert!((s.connection_term() - levi_civita_term(&s.external_moment)).norm() < 1e-12 * s.euclidean.norm());
    }

    #[test]
    fn paper_eq_48b_is_neither_the_hessian_nor_symmetric((sim, r) in loaded_system()) {
        let s = sim.stiffness(&r).unwrap();
        let tau = s.external_moment;
        // Only meaningful when the load is not negligible against the stiffness.
        prop_assume!(tau.norm() > 1e-3 * s.covariant.norm());
        let seed = s.paper_eq48b();
        let fd = covariant_hessian(&potential(&sim), &r, H2);
        // Its error is exactly ½ hat(τ), far above the FD error.
        let expected_gap = 0.5 * hat(&tau).norm();
        prop_assert!(((seed - fd).norm() - expected_gap).abs() < 1e-6 * s.covariant.norm());
        prop_assert!(((seed - seed.transpose()).norm() - hat(&tau).norm()).abs() < 1e-9 * s.covariant.norm());
    }

    #[test]
    fn stiffness_at_agrees_with_the_simulator((sim, r) in loaded_system()) {
        let t = sim.tensions(&r).unwrap();
        let k = std::array::from_fn(|i| sim.cables()[i].stiffness);
        let direct = stiffness_at(sim.geometry(), &r, &t, &k, sim.loads()).unwrap();
        prop_assert_eq!(direct, sim.stiffness(&r).unwrap());
        prop_assert!((direct.external_moment - sim.holding_moment(&r).unwrap()).norm() < 1e-12 * (1.0 + direct.external_moment.norm()));
    }
}

#[test]
fn structure_constants_are_plus_minus_one_not_two() {
    // [hat σ_j, hat σ_i] = Σ_k γ^k_ji hat σ_k (seed eq. 30). Seed eq. 31 prints γ³₁₂ = 2.
    let e = [Vector3::x(), Vector3::y(), Vector3::z()];
    for j in 0..3 {
        for i in 0..3 {
            let commutator = hat(&e[j]) * hat(&e[i]) - hat(&e[i]) * hat(&e[j]);
            let gamma = so3::vee(&commutator); // coordinates γ^k_ji, k = 1..3
            let levi_civita_symbol = Vector3::from_fn(|k, _| {
                let (a, b, c) = (j as i32, i as i32, k as i32);
                ((a - b) * (b - c) * (c - a) / 2) as f64
            });
            assert_eq!(gamma, levi_civita_symbol, "γ^k_{}{}", j + 1, i + 1);
        }
    }
    let commutator = hat(&e[0]) * hat(&e[1]) - hat(&e[1]) * hat(&e[0]);
    assert_eq!(commutator, hat(&e[2]), "[σ̂₁, σ̂₂] = σ̂₃: γ³₁₂ = 1");
}

#[test]
fn unloaded_symmetric_prototype_has_no_connection_term() {
    let g = CsjmGeometry::prototype();
    let s = stiffness_at(&g, &Rotation3::identity(), &[50.0; 6], &[5000.0; 6], &[]).unwrap();
    assert!(s.external_moment.norm() < 1e-13);
    assert!((s.covariant - s.euclidean).norm() < 1e-13);
    // 3-fold symmetry: equal tilt stiffnesses about x and y, no coupling.
    let k = s.covariant;
    assert!((k[(0, 0)] - k[(1, 1)]).abs() < 1e-10 * k[(0, 0)]);
    assert!(k[(0, 1)].abs() < 1e-10 * k[(0, 0)] && k[(0, 2)].abs() < 1e-10 * k[(0, 0)]);
}

/// An independent, manifestly symmetric closed form of the covariant stiffness, derived by
/// hand from K = K_D − ½ hat(τ) with b_s = a_s + c_s u_s (see docs/so3-stiffness.md):
/// per cable `k j jᵀ − t [hat(a) P hat(a)/c + ½(hat a hat u + hat u hat a)]`, per point load
/// `−½(hat p hat f + hat f hat p)` with f = Rᵀ f_B.
fn closed_form_stiffness(sim: &CsjmSimulator, r: &Rotation3<f64>) -> Matrix3<f64> {
    let t = sim.tensions(r).unwrap();
    let mut k = Matrix3::zeros();
    #[allow(clippy::needless_range_loop)] // s indexes four parallel per-cable arrays
    for s in 0..6 {
        let a = sim.geometry().platform_point(s);
        let c_a = r.inverse() * sim.geometry().base_point(s) - a;
        let (c, u) = (c_a.norm(), c_a.normalize());
        let p = Matrix3::identity() - u * u.transpose();
        let j = a.cross(&u);
        k += sim.cables()[s].stiffness * j * j.transpose()
            - t[s] * (hat(&a) * p * hat(&a) / c + 0.5 * (hat(&a) * hat(&u) + hat(&u) * hat(&a)));
    }
    for load in sim.loads() {
        let (p, f) = (load.point_in_a(), r.inverse() * load.force_in_b());
        k -= 0.5 * (hat(&p) * hat(&f) + hat(&f) * hat(&p));
    }
    k
}

proptest! {
    #![proptest_config(config(48))]

    #[test]
    fn covariant_stiffness_matches_the_symmetric_closed_form((sim, r) in loaded_system()) {
        let k = sim.stiffness(&r).unwrap().covariant;
        prop_assert!(relative_error(&k, &closed_form_stiffness(&sim, &r)) < 1e-12);
    }
}
