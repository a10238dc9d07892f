//! Issue 14: SO(3) maps of huge (finite) rotation vectors give valid results instead of NaN
//! (‖w‖² overflowed: `exp` of 1e308 returned NaN).

use nalgebra::Vector3;
use so3_stiffness::so3::{
    exp, left_jacobian, left_jacobian_inverse, orthogonality_error, right_jacobian,
};

fn huge_vectors() -> Vec<Vector3<f64>> {
    vec![
        Vector3::new(1e308, 0.0, 0.0),
        Vector3::new(1e308, -1e308, 1e308),
        Vector3::new(f64::MAX, f64::MAX, -f64::MAX),
        Vector3::new(3e200, -4e199, 1e150),
        Vector3::new(0.0, 2e151, 0.0),
    ]
}

#[test]
fn exp_of_a_huge_vector_is_a_rotation_about_its_axis() {
    for w in huge_vectors() {
        let r = exp(&w);
        let m = r.matrix();
        assert!(m.iter().all(|x| x.is_finite()), "exp({w:?}) = {m}");
        assert!(
            orthogonality_error(m) < 1e-14,
            "exp({w:?}) not orthonormal: {m}"
        );
        assert!((m.determinant() - 1.0).abs() < 1e-14);
        // The axis is fixed by the rotation.
        let n = w / w.amax();
        let n = n / n.norm();
        assert!((r * n - n).norm() < 1e-14, "exp({w:?}) moves its own axis");
    }
}

#[test]
fn both_sides_of_the_branch_switch_are_rotations_about_the_axis() {
    // Just below and just above the switch to the scaled branch (‖w‖² = 1e300).
    let n = Vector3::new(2.0, -3.0, 6.0) / 7.0;
    let below = exp(&(0.99e150 * n));
    let above = exp(&(1.01e150 * n));
    for r in [below, above] {
        assert!(orthogonality_error(r.matrix()) < 1e-14);
        assert!((r * n - n).norm() < 1e-14);
    }
}

#[test]
fn jacobians_of_a_huge_vector_are_finite_and_fix_the_axis() {
    for w in huge_vectors() {
        let n = w / w.amax();
        let n = n / n.norm();
        for (name, j) in [("left", left_jacobian(&w)), ("right", right_jacobian(&w))] {
            assert!(
                j.iter().all(|x| x.is_finite()),
                "{name}_jacobian({w:?}) = {j}"
            );
            // J n = n for every θ (hat(n) n = 0).
            assert!((j * n - n).norm() < 1e-12, "{name}_jacobian({w:?}) n ≠ n");
        }
        let ji = left_jacobian_inverse(&w);
        assert!(
            !ji.iter().any(|x| x.is_nan()),
            "left_jacobian_inverse({w:?}) = {ji}"
        );
    }
}

/// The "not a rotation" message names the option as the user writes it in Python, never a Rust
/// path (the command line rewords `project=True` as `--project`).
#[test]
fn the_not_a_rotation_message_names_the_option_neutrally() {
    let e = so3_stiffness::identification::IdentificationError::NotARotation {
        row: 3,
        line: 4,
        orthogonality_error: 0.1,
        tol: 1e-6,
    };
    let msg = e.to_string();
    assert!(msg.contains("project=True"), "{msg}");
    assert!(!msg.contains("::"), "{msg}");
}
