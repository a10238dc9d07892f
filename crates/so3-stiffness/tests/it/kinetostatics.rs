//! Kinetostatics: δC = −J δζ against finite differences of cable lengths under body
//! perturbations R·exp(hat δζ), the derivative D of eq. 45, and the prototype layout.

use nalgebra::{Matrix3, Rotation3, Vector3};
use proptest::prelude::*;
use so3_stiffness::csjm::{
    cable_lengths, jacobian, CableKinematics, CsjmGeometry, PointLoad, CABLES,
};
use so3_stiffness::so3;

use crate::strategies::{config, geometry, rotation, unit_vector, vector};

proptest! {
    #![proptest_config(config(48))]

    #[test]
    fn cable_length_change_is_minus_j_times_body_perturbation(g in geometry(), r in rotation(), n in unit_vector()) {
        let h = 1e-6;
        let Ok(j) = jacobian(&g, &r) else { return Ok(()) };
        let plus = cable_lengths(&g, &(r * so3::exp(&(n * h)))).unwrap();
        let minus = cable_lengths(&g, &(r * so3::exp(&(n * -h)))).unwrap();
        let predicted = -j * n;
        for i in 0..CABLES {
            let fd = (plus[i] - minus[i]) / (2.0 * h);
            prop_assert!((fd - predicted[i]).abs() < 1e-8, "cable {}: fd {fd:e} vs −Jδζ {:e}", i + 1, predicted[i]);
        }
    }

    #[test]
    fn jacobian_derivative_matches_finite_differences(g in geometry(), r in rotation(), t in proptest::array::uniform6(1.0..100.0f64)) {
        // Column j of D is ∂(JᵀT)/∂ζ_j at fixed T.
        let h = 1e-6;
        let kin = CableKinematics::new(&g, &r).unwrap();
        let d = kin.jacobian_derivative_times_tensions(&t);
        let fd = Matrix3::from_fn(|i, j| {
            let mut e = Vector3::zeros();
            e[j] = h;
            let p = CableKinematics::new(&g, &(r * so3::exp(&e))).unwrap().cable_moment(&t);
            let m = CableKinematics::new(&g, &(r * so3::exp(&-e))).unwrap().cable_moment(&t);
            (p[i] - m[i]) / (2.0 * h)
        });
        prop_assert!((d - fd).norm() < 1e-7 * d.norm().max(1.0), "D {d} vs fd {fd}");
    }

    #[test]
    fn cable_moment_is_sum_of_a_cross_t(g in geometry(), r in rotation(), t in proptest::array::uniform6(0.0..100.0f64)) {
        // Independent path: Σ a_i × (t_i u_i), u_i from the B-frame cable vector mapped to A.
        let kin = CableKinematics::new(&g, &r).unwrap();
        let expected = (0..CABLES).fold(Vector3::zeros(), |m, i| {
            let c_b = g.base_point(i) - r * g.platform_point(i);
            m + g.platform_point(i).cross(&(r.inverse() * c_b.normalize() * t[i]))
        });
        prop_assert!((kin.cable_moment(&t) - expected).norm() < 1e-12 * (1.0 + expected.norm()));
    }

    #[test]
    fn point_load_moment_is_gradient_of_its_potential(r in rotation(), p in vector(0.2), f in vector(10.0), n in unit_vector()) {
        let load = PointLoad::new(p, f).unwrap();
        let h = 1e-6;
        let fd = (load.potential(&(r * so3::exp(&(n * h)))) - load.potential(&(r * so3::exp(&(n * -h))))) / (2.0 * h);
        // The load's own moment does work −dV: dV/dδ = −m·δ.
        prop_assert!((fd + load.moment_in_a(&r).dot(&n)).abs() < 1e-8);
        let dm = load.moment_derivative(&r) * n;
        let fd_m = (load.moment_in_a(&(r * so3::exp(&(n * h)))) - load.moment_in_a(&(r * so3::exp(&(n * -h))))) / (2.0 * h);
        prop_assert!((dm - fd_m).norm() < 1e-8);
    }
}

#[test]
fn prototype_matches_the_seed_dimensions() {
    let g = CsjmGeometry::prototype();
    let a = g.platform_points();
    let b = g.base_points();
    let side = |p: &[Vector3<f64>; 6], i: usize, j: usize| (p[i - 1] - p[j - 1]).norm();
    for (i, j) in [(1, 2), (3, 4), (5, 6)] {
        assert!((side(a, i, j) - 0.010).abs() < 1e-12, "A{i}A{j}");
        assert!((side(b, i, j) - 0.128).abs() < 1e-12, "B{i}B{j}");
    }
    for (i, j) in [(2, 3), (4, 5), (6, 1)] {
        assert!((side(a, i, j) - 0.095).abs() < 1e-12, "A{i}A{j}");
        assert!((side(b, i, j) - 0.005).abs() < 1e-12, "B{i}B{j}");
    }
    for i in 0..6 {
        assert!((a[i].z - 0.08).abs() < 1e-15 && (b[i].z + 0.08).abs() < 1e-15);
    }
    // x_A through the midpoint of A1A2, x_B through the midpoint of B1B2.
    let ma = (a[0] + a[1]) / 2.0;
    let mb = (b[0] + b[1]) / 2.0;
    assert!(ma.y.abs() < 1e-15 && ma.x > 0.0 && mb.y.abs() < 1e-15 && mb.x > 0.0);
}

#[test]
fn prototype_is_tensionable_at_the_home_pose() {
    let g = CsjmGeometry::prototype();
    let kin = CableKinematics::new(&g, &Rotation3::identity()).unwrap();
    let sv = kin.jacobian().svd(false, false).singular_values;
    let smallest = sv.min();
    assert!(smallest > 0.01, "σ_min(J) = {smallest} m");
    // Equal tensions are in equilibrium: a strictly positive vector in the null space of Jᵀ,
    // so any moment can be resisted with all six cables in tension (force closure).
    let m = kin.cable_moment(&[1.0; 6]);
    assert!(m.norm() < 1e-15, "{m:?}");
    // Gravity of the prototype at the home pose: the centre of mass is above O, no moment.
    let grav = PointLoad::prototype_gravity();
    assert!(grav.moment_in_a(&Rotation3::identity()).norm() < 1e-15);
    let tilted = so3::exp(&Vector3::new(0.1, 0.0, 0.0));
    // Tilted by +0.1 rad about x, the weight's moment is along +x, i.e. it tilts the platform
    // further (destabilising), with magnitude G·0.081·sin(0.1).
    let expected = 4.82 * 0.081 * 0.1f64.sin();
    assert!((grav.moment_in_a(&tilted) - Vector3::new(expected, 0.0, 0.0)).norm() < 1e-15);
}
