//! Verification (eqs. 61–65).

use nalgebra::{Matrix3, Vector3};
use so3_stiffness::identification::{estimation_error, predict_pose, verify, IdentificationError};
use so3_stiffness::so3;

use super::common::{random_vector, rng};

#[test]
fn predicted_pose_is_a_body_frame_perturbation() {
    let mut g = rng(1);
    let k = Matrix3::new(29.4, 1.2, 3.0, 1.2, 30.0, -1.1, 3.0, -1.1, 7.0);
    for _ in 0..20 {
        let r0 = so3::exp(&random_vector(&mut g, 1.0));
        let dtau = random_vector(&mut g, 3.0);
        let r = predict_pose(&r0, &k, &dtau).unwrap();
        // K · log(R₀ᵀR) reproduces the load increment.
        assert!((k * so3::log(&(r0.inverse() * r)) - dtau).norm() < 1e-12);
        let case = verify(&r0, &k, &dtau, &r).unwrap();
        assert!(case.e_theta < 1e-12);
        // A known extra rotation of 0.03 rad is measured as E_θ = 0.03.
        let r_act = r * so3::exp(&(random_vector(&mut g, 1.0).normalize() * 0.03));
        assert!((estimation_error(&r_act, &r) - 0.03).abs() < 1e-12);
    }
}

#[test]
fn singular_stiffness_is_an_error() {
    let k = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0);
    let r0 = so3::exp(&Vector3::zeros());
    assert!(matches!(
        predict_pose(&r0, &k, &Vector3::new(1.0, 0.0, 0.0)),
        Err(IdentificationError::SingularStiffness { .. })
    ));
    assert!(matches!(
        predict_pose(&r0, &Matrix3::identity(), &Vector3::new(f64::NAN, 0.0, 0.0)),
        Err(IdentificationError::NonFiniteInput { .. })
    ));
}
