//! Pose measurement (eqs. 51–54) and load measurement (eqs. 55–56).

use nalgebra::{Isometry3, Matrix4, Point3, Translation3, UnitQuaternion, Vector3, Vector6};
use rand_distr::{Distribution, Normal};
use so3_stiffness::identification::load::{
    gravity_moment, sensor_wrench_to_platform, total_moment,
};
use so3_stiffness::identification::pose::{
    body_displacement, fit_frame_to_points, platform_in_base,
};
use so3_stiffness::identification::IdentificationError;
use so3_stiffness::so3;

use super::common::{random_vector, rng};

fn random_pose(seed: u64) -> Isometry3<f64> {
    let mut g = rng(seed);
    let r = so3::exp(&random_vector(&mut g, 2.0));
    Isometry3::from_parts(
        Translation3::from(random_vector(&mut g, 3.0)),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

fn base_points(n: usize, seed: u64) -> Vec<Point3<f64>> {
    let mut g = rng(seed);
    (0..n)
        .map(|_| Point3::from(random_vector(&mut g, 0.15)))
        .collect()
}

/// The seed's construction (eq. 51–52): ᴸ_B T = ᴸP_H (ᴮP_H)⁻¹ with 4×4 homogeneous matrices
/// whose fourth column is the cross product of two edges.
fn paper_eq51(pb: &[Point3<f64>], pl: &[Point3<f64>]) -> Matrix4<f64> {
    let build = |p: &[Point3<f64>]| {
        let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
        let mut m = Matrix4::zeros();
        for i in 0..3 {
            m.fixed_view_mut::<3, 1>(0, i).copy_from(&p[i].coords);
            m[(3, i)] = 1.0;
        }
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&n);
        m
    };
    build(pl) * build(pb).try_inverse().unwrap()
}

#[test]
fn three_exact_points_match_the_seed_construction() {
    let t = random_pose(1);
    let pb = base_points(3, 2);
    let pl: Vec<_> = pb.iter().map(|p| t * p).collect();
    let fit = fit_frame_to_points(&pb, &pl).unwrap();
    assert!((fit.transform.to_homogeneous() - paper_eq51(&pb, &pl)).norm() < 1e-10);
    assert!((fit.transform.to_homogeneous() - t.to_homogeneous()).norm() < 1e-10);
    assert!(fit.rms_residual < 1e-12);
}

#[test]
fn least_squares_with_more_points_reports_the_residual() {
    let t = random_pose(3);
    let pb = base_points(6, 4);
    let mut g = rng(5);
    let sigma = 20e-6;
    let noise = Normal::new(0.0, sigma).unwrap();
    let pl: Vec<_> = pb
        .iter()
        .map(|p| t * p + Vector3::from_fn(|_, _| noise.sample(&mut g)))
        .collect();
    let fit = fit_frame_to_points(&pb, &pl).unwrap();
    // Residual of a 6-parameter fit to 18 coordinates: ≈ σ·√3·√(12/18).
    assert!(
        fit.rms_residual > 0.3 * sigma && fit.rms_residual < 3.0 * sigma,
        "{}",
        fit.rms_residual
    );
    let angle = so3::distance(
        &fit.transform.rotation.to_rotation_matrix(),
        &t.rotation.to_rotation_matrix(),
    );
    assert!(angle < 1e-3, "{angle}");
    // The least-squares fit beats the exact three-point construction on the same data.
    let seed = paper_eq51(&pb[..3], &pl[..3]);
    let seed_sq: f64 = pb
        .iter()
        .zip(&pl)
        .map(|(b, l)| (seed.transform_point(b) - l).norm_squared())
        .sum();
    let fit_sq: f64 = fit.residuals.iter().map(|r| r * r).sum();
    assert!(fit_sq <= seed_sq);
    // One gross outlier shows up in its residual.
    let mut bad = pl.clone();
    bad[2].x += 1e-3;
    let fit_bad = fit_frame_to_points(&pb, &bad).unwrap();
    let worst = fit_bad.residuals.iter().cloned().fold(0.0, f64::max);
    assert_eq!(fit_bad.residuals.iter().position(|r| *r == worst), Some(2));
}

#[test]
fn degenerate_point_sets_are_errors() {
    let pb: Vec<_> = (0..4)
        .map(|i| Point3::new(0.1 * i as f64, 0.0, 0.0))
        .collect();
    let pl = pb.clone();
    assert!(matches!(
        fit_frame_to_points(&pb, &pl),
        Err(IdentificationError::Degenerate { .. })
    ));
    assert!(matches!(
        fit_frame_to_points(&pb[..2], &pl[..2]),
        Err(IdentificationError::Degenerate { .. })
    ));
    assert!(matches!(
        fit_frame_to_points(&pb, &pl[..3]),
        Err(IdentificationError::LengthMismatch { .. })
    ));
}

#[test]
fn platform_pose_and_displacement() {
    let t_lb = random_pose(6);
    let r_ba = so3::exp(&Vector3::new(0.1, -0.2, 0.3));
    let t_ba = Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_rotation_matrix(&r_ba),
    );
    let t_la = t_lb * t_ba;
    let back = platform_in_base(&t_lb, &t_la);
    assert!(
        back.translation.vector.norm() < 1e-12,
        "A and B share the origin O"
    );
    assert!(so3::distance(&back.rotation.to_rotation_matrix(), &r_ba) < 1e-12);
    let dz = Vector3::new(0.02, -0.01, 0.05);
    assert!((body_displacement(&r_ba, &(r_ba * so3::exp(&dz))) - dz).norm() < 1e-14);
}

/// Eq. 55 against an independent computation: a force F applied at a point, both known in A.
#[test]
fn sensor_wrench_maps_to_moment_about_o() {
    let mut g = rng(7);
    // Sensor frame S: pose of A in S.
    let r_sa = so3::exp(&random_vector(&mut g, 1.5));
    let p_sa = random_vector(&mut g, 0.1);
    let t_sa = Isometry3::from_parts(
        Translation3::from(p_sa),
        UnitQuaternion::from_rotation_matrix(&r_sa),
    );
    // A force f (A components) at point q (A coordinates), plus a pure couple c (A components).
    let f_a = random_vector(&mut g, 20.0);
    let q_a = random_vector(&mut g, 0.2);
    let c_a = random_vector(&mut g, 1.0);
    let expected_moment = q_a.cross(&f_a) + c_a;
    // What the sensor reads: the same loads in S, moment about S's origin.
    let f_s = r_sa * f_a;
    let q_s = t_sa * Point3::from(q_a);
    let m_s = q_s.coords.cross(&f_s) + r_sa * c_a;
    let w_s = Vector6::new(f_s.x, f_s.y, f_s.z, m_s.x, m_s.y, m_s.z);
    let w_a = sensor_wrench_to_platform(&t_sa, &w_s);
    assert!((w_a.fixed_rows::<3>(0) - f_a).norm() < 1e-12);
    assert!((w_a.fixed_rows::<3>(3) - expected_moment).norm() < 1e-12);
}

/// Eq. 56: the weight's moment is minus the body gradient of its potential V = −ᴮG·(R ᴬr_G).
#[test]
fn gravity_moment_is_the_gradient_of_the_weight_potential() {
    let g_b = Vector3::new(0.0, 0.0, -4.82);
    let r_g = Vector3::new(0.0, 0.0, 0.081);
    let mut g = rng(8);
    for _ in 0..10 {
        let r = so3::exp(&random_vector(&mut g, 1.0));
        let potential = |rot: nalgebra::Rotation3<f64>| -g_b.dot(&(rot * r_g));
        let h = 1e-6;
        let fd = Vector3::from_fn(|i, _| {
            let e = Vector3::ith(i, h);
            -(potential(r * so3::exp(&e)) - potential(r * so3::exp(&-e))) / (2.0 * h)
        });
        assert!((gravity_moment(&r, &g_b, &r_g) - fd).norm() < 1e-8);
    }
    // Upright platform: no moment; tipped 90° about x: |τ| = G·|r_G|.
    assert!(gravity_moment(&so3::exp(&Vector3::zeros()), &g_b, &r_g).norm() < 1e-15);
    let tipped = so3::exp(&Vector3::new(std::f64::consts::FRAC_PI_2, 0.0, 0.0));
    assert!((gravity_moment(&tipped, &g_b, &r_g).norm() - 4.82 * 0.081).abs() < 1e-12);
    // total = external + gravity.
    let t_sa = Isometry3::identity();
    let w = Vector6::new(0.0, 0.0, 0.0, 0.1, 0.2, 0.3);
    let total = total_moment(&t_sa, &w, &tipped, &g_b, &r_g);
    assert!(
        (total - Vector3::new(0.1, 0.2, 0.3) - gravity_moment(&tipped, &g_b, &r_g)).norm() < 1e-15
    );
}

/// Three points (always coplanar: the cross-covariance H has an exactly zero singular value,
/// where nalgebra's SVD has returned factors that do not reproduce H, issue #1172) and four
/// coplanar points, over 2 000 seeded poses: every fit is the true pose to 2e-9 (the worst of
/// the 4 000 is 4e-10 with points 0.15 m apart and translations of metres; a broken
/// decomposition is off by far more).
#[test]
fn coplanar_points_give_the_true_pose_at_every_draw() {
    for seed in 0..2000u64 {
        let t = random_pose(1000 + seed);
        let mut pb = base_points(4, 5000 + seed);
        pb[3] = Point3::from(pb[0].coords * 0.3 + pb[1].coords * 0.5 + pb[2].coords * 0.2);
        for n in [3, 4] {
            let pl: Vec<_> = pb[..n].iter().map(|p| t * p).collect();
            let fit = fit_frame_to_points(&pb[..n], &pl).unwrap();
            let err = (fit.transform.to_homogeneous() - t.to_homogeneous()).norm();
            assert!(err < 2e-9, "seed {seed}, {n} points: {err:e}");
        }
    }
}
