//! The virtual testbed: effect physics against their defining curves, the deflected-chain
//! kinematics against the crate's analytic Jacobian and K_C and against finite differences, and
//! the campaign generator's noise and reproducibility.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::testbed::effects::{backlash_deflection, rotate};
use vjm::testbed::kinematics::{deflected_pose, deflected_tip};
use vjm::testbed::{
    simulate, CampaignSpec, Effect, HarmonicDriveSpring, TrueModel, NOMINAL_TORSION,
};
use vjm::{complementary_stiffness, jacobian, SerialChain, SpringAxis, VirtualJointModel};

fn random_q(chain: &SerialChain, rng: &mut ChaCha8Rng) -> Vec<f64> {
    chain
        .limits()
        .iter()
        .map(|&(lo, hi)| rng.random_range(lo.max(-3.0) + 0.1..hi.min(3.0) - 0.1))
        .collect()
}

#[test]
fn harmonic_drive_curve_matches_its_segments() {
    let s = HarmonicDriveSpring {
        k1: 1000.0,
        k2: 2000.0,
        k3: 4000.0,
        t1: 5.0,
        t2: 15.0,
    };
    // Hand-computed points: 10 N·m = 5/1000 + 5/2000; 20 N·m = 5/1000 + 10/2000 + 5/4000.
    assert!((s.deflection(3.0) - 0.003).abs() < 1e-15);
    assert!((s.deflection(10.0) - 0.0075).abs() < 1e-15);
    assert!((s.deflection(20.0) - 0.01125).abs() < 1e-15);
    assert!((s.deflection(-20.0) + 0.01125).abs() < 1e-15);
    assert_eq!(s.deflection(0.0), 0.0);
    // Slopes by central differences inside each segment, and continuity at the breakpoints.
    for (tau, k) in [(2.0, 1000.0), (9.0, 2000.0), (30.0, 4000.0), (-9.0, 2000.0)] {
        let h = 1e-3;
        let slope = (s.deflection(tau + h) - s.deflection(tau - h)) / (2.0 * h);
        assert!((slope - 1.0 / k).abs() < 1e-12, "slope at {tau}");
        assert_eq!(s.tangent_compliance(tau), 1.0 / k);
    }
    for t in [5.0, 15.0] {
        assert!((s.deflection(t + 1e-9) - s.deflection(t - 1e-9)).abs() < 1e-11);
    }
    let st = HarmonicDriveSpring::stiffening(1e-3, 2.0, 5.0, 15.0);
    assert_eq!((st.k1, st.k2, st.k3), (1000.0, 2000.0, 4000.0));
}

#[test]
fn backlash_is_half_the_band_with_the_torque_sign() {
    assert_eq!(backlash_deflection(3.0, 2e-3), 1e-3);
    assert_eq!(backlash_deflection(-0.1, 2e-3), -1e-3);
    assert_eq!(backlash_deflection(0.0, 2e-3), 0.0);
    // Through the true model: the torsion of a backlash joint jumps by b across τ = 0.
    let mut t = TrueModel::nominal(2).with_effect(Effect::Backlash {
        joint: 1,
        lost_motion: 4e-4,
    });
    t.compliance[3] = 1e-4;
    let up = t.spring_response(&[0.0, 0.0, 0.0, 1e-9, 0.0, 0.0])[3];
    let down = t.spring_response(&[0.0, 0.0, 0.0, -1e-9, 0.0, 0.0])[3];
    assert!((up - down - 4e-4).abs() < 1e-12);
}

#[test]
fn rotate_is_rodrigues() {
    // A quarter turn about z takes x to y; a small rotation is v + φ × v to first order.
    let r = rotate([0.0, 0.0, std::f64::consts::FRAC_PI_2], [1.0, 0.0, 0.0]);
    assert!((r[0]).abs() < 1e-15 && (r[1] - 1.0).abs() < 1e-15);
    let phi = [1e-6, -2e-6, 3e-6];
    let v = [0.3, -0.2, 0.5];
    let r = rotate(phi, v);
    let lin = [
        v[0] + phi[1] * v[2] - phi[2] * v[1],
        v[1] + phi[2] * v[0] - phi[0] * v[2],
        v[2] + phi[0] * v[1] - phi[1] * v[0],
    ];
    for k in 0..3 {
        assert!((r[k] - lin[k]).abs() < 1e-11);
    }
}

#[test]
fn testbed_jacobian_equals_the_crate_jacobian() {
    // Two independent code paths: the testbed composes isometries, the crate uses Rodrigues
    // blocks and its own spring-axis bookkeeping.
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..20 {
        let q = random_q(&chain, &mut rng);
        let ours = deflected_pose(&chain, &q, &[0.0; 21]).jacobian;
        let theirs = jacobian(&chain, &model, &q).unwrap();
        assert!((&ours - &theirs).amax() < 1e-12, "q = {q:?}");
    }
}

#[test]
fn deflected_jacobian_columns_are_derivatives_of_the_tip() {
    let chain = SerialChain::bundled();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for _ in 0..5 {
        let q = random_q(&chain, &mut rng);
        let theta: Vec<f64> = (0..21).map(|_| rng.random_range(-0.01..0.01)).collect();
        let j = deflected_pose(&chain, &q, &theta).jacobian;
        for s in 0..21 {
            let h = 1e-6;
            let mut tp = theta.clone();
            tp[s] += h;
            let mut tm = theta.clone();
            tm[s] -= h;
            let fd = (deflected_tip(&chain, &q, &tp) - deflected_tip(&chain, &q, &tm)) / (2.0 * h);
            // The x and y springs of joint j sit after z (and y after x) in the composition, so
            // their columns are the derivatives of the tip in the deflected configuration.
            for r in 0..3 {
                assert!((fd[r] - j[(r, s)]).abs() < 1e-8, "spring {s} row {r}");
            }
        }
    }
}

/// A truth with all 21 springs compliant (torsion nominal, tilts 0.3×).
fn full_truth() -> TrueModel {
    TrueModel::with_tilts(&NOMINAL_TORSION, 0.3)
}

#[test]
fn geometric_equilibrium_is_a_stationary_point_of_the_potential() {
    // With a pure force F, the loaded chain minimises V(θ) = ½ θᵀKθ − Fᵀ p(θ). Check ∂V/∂θ = 0
    // by central differences of the tip position only (independent of any Jacobian).
    let chain = SerialChain::bundled();
    let truth = full_truth().with_effect(Effect::GeometricNonlinearity);
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    for _ in 0..4 {
        let q = random_q(&chain, &mut rng);
        let f = [60.0, -40.0, 50.0];
        let w = [f[0], f[1], f[2], 0.0, 0.0, 0.0];
        let (d, tip0) = truth.displacement(&chain, &q, &w);
        // Recover θ from the spring torques at the solution: θ = C τ(θ) is the fixed point, so
        // iterate the same map here from the linear guess, with the tip-position derivative by
        // finite differences instead of the Jacobian.
        let p = |th: &[f64]| deflected_tip(&chain, &q, th);
        let c = &truth.compliance;
        let mut theta: Vec<f64> = vec![0.0; 21];
        for _ in 0..60 {
            let next: Vec<f64> = (0..21)
                .map(|s| {
                    let h = 1e-7;
                    let mut tp = theta.clone();
                    tp[s] += h;
                    let mut tm = theta.clone();
                    tm[s] -= h;
                    let dp = (p(&tp) - p(&tm)) / (2.0 * h);
                    c[s] * (f[0] * dp[0] + f[1] * dp[1] + f[2] * dp[2])
                })
                .collect();
            theta = next;
        }
        let d_fd = p(&theta) - tip0;
        let lin = {
            let j = deflected_pose(&chain, &q, &[0.0; 21]).jacobian;
            let th0: Vec<f64> = (0..21)
                .map(|s| c[s] * (0..3).map(|r| j[(r, s)] * f[r]).sum::<f64>())
                .collect();
            p(&th0) - tip0
        };
        // The two solutions agree far below the size of the non-linear effect itself.
        let effect = (d - lin).norm();
        assert!(effect > 1e-7, "the effect should be visible: {effect}");
        assert!(
            (d - d_fd).norm() < 1e-3 * effect + 1e-12,
            "{} vs {}",
            (d - d_fd).norm(),
            effect
        );
    }
}

#[test]
fn geometric_equilibrium_agrees_with_the_crate_kc_to_second_order() {
    // θ_KC = (I − C K_C)⁻¹ C Jᵀ W is the first-order equilibrium with the crate's analytic K_C;
    // the testbed's exact θ differs from the linear one at second order in the load, and from
    // θ_KC only at third order: halving the load divides the first gap by ~4, the second by ~8.
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = full_truth();
    let geo = truth.clone().with_effect(Effect::GeometricNonlinearity);
    let c = DMatrix::from_diagonal(&DVector::from_column_slice(&truth.compliance));
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    for _ in 0..4 {
        let q = random_q(&chain, &mut rng);
        let gaps = |s: f64| {
            let w = [70.0 * s, 30.0 * s, -50.0 * s, 3.0 * s, -2.0 * s, 1.0 * s];
            let (d_exact, tip0) = geo.displacement(&chain, &q, &w);
            let j = jacobian(&chain, &model, &q).unwrap();
            let kc = complementary_stiffness(&chain, &model, &q, &w).unwrap();
            let tau = j.transpose() * DVector::from_column_slice(&w);
            let th_lin = &c * &tau;
            let a = DMatrix::identity(21, 21) - &c * &kc;
            let th_kc = a.lu().solve(&th_lin).unwrap();
            let tip = |th: &DVector<f64>| deflected_tip(&chain, &q, th.as_slice()) - tip0;
            (
                (d_exact - tip(&th_lin)).norm(),
                (d_exact - tip(&th_kc)).norm(),
            )
        };
        let (lin1, kc1) = gaps(1.0);
        let (lin2, kc2) = gaps(0.5);
        assert!(
            kc1 < 0.1 * lin1,
            "K_C should explain the equilibrium shift: {kc1} vs {lin1}"
        );
        let r_lin = lin1 / lin2;
        let r_kc = kc1 / kc2;
        assert!((r_lin - 4.0).abs() < 0.4, "second order: ratio {r_lin}");
        assert!(r_kc > 6.5, "third order: ratio {r_kc}");
    }
}

#[test]
fn linear_truth_is_j_c_jt_w() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = full_truth();
    let q = [0.3, -0.5, 0.2, -1.8, 0.4, 1.6, 0.1];
    let w = [20.0, -10.0, 30.0, 1.0, 2.0, -1.5];
    let (d, _) = truth.displacement(&chain, &q, &w);
    let j = jacobian(&chain, &model, &q).unwrap();
    let c = DMatrix::from_diagonal(&DVector::from_column_slice(&truth.compliance));
    let expected = j.rows(0, 3) * &c * j.transpose() * DVector::from_column_slice(&w);
    for r in 0..3 {
        assert!((d[r] - expected[r]).abs() < 1e-15 + 1e-12 * expected.norm());
    }
}

#[test]
fn campaigns_are_reproducible_and_respect_the_spec() {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 10,
        wrenches_per_pose: 3,
        seed: 5,
        ..Default::default()
    };
    let a = simulate(&chain, &TrueModel::nominal(7), &spec).unwrap();
    let b = simulate(&chain, &TrueModel::nominal(7), &spec).unwrap();
    assert_eq!(a.dataset, b.dataset);
    assert_eq!(a.dataset.len(), 30);
    for i in 0..a.dataset.len() {
        for (qj, &(lo, hi)) in a.dataset.q(i).iter().zip(chain.limits()) {
            assert!(*qj >= lo + 0.1 - 1e-12 && *qj <= hi - 0.1 + 1e-12);
        }
        assert!(vjm::testbed::inverse_condition(&chain, a.dataset.q(i)) >= 0.05);
        assert!(a.tip[i][2] >= 0.1);
        let w = a.applied_wrench[i];
        let f = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let m = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt();
        assert!((10.0..=80.0).contains(&f) && m <= 3.0);
    }
    // Held-out whole poses, about a quarter.
    let test_poses: std::collections::BTreeSet<i64> = (0..30)
        .filter(|&i| a.dataset.set(i) == Some(vjm::dataset::SetLabel::Test))
        .map(|i| a.dataset.pose(i).unwrap())
        .collect();
    assert_eq!(test_poses.len(), 3);
    // The noise-free campaign with the same seed has the same poses and loads.
    let quiet = simulate(
        &chain,
        &TrueModel::nominal(7),
        &CampaignSpec {
            noise: false,
            ..spec.clone()
        },
    )
    .unwrap();
    assert_eq!(quiet.dataset.q_flat(), a.dataset.q_flat());
    assert_eq!(quiet.applied_wrench, a.applied_wrench);
}

#[test]
fn noise_has_the_stated_standard_deviations() {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 40,
        wrenches_per_pose: 4,
        seed: 21,
        ..Default::default()
    };
    let c = simulate(&chain, &TrueModel::nominal(7), &spec).unwrap();
    let (mut zd, mut zf, mut zm) = (Vec::new(), Vec::new(), Vec::new());
    let fs = spec.force_sensor.sigma();
    for i in 0..c.dataset.len() {
        let sd = spec.tracker.displacement_sigma(c.tip[i]);
        // √2·(15 µm + 6 µm/m · L)/2 with L between ~1.5 and ~3.5 m.
        assert!(sd > 17e-6 && sd < 27e-6, "{sd}");
        let d = c.dataset.displacement(i);
        let w = c.dataset.wrench(i);
        for k in 0..3 {
            zd.push((d[k] - c.true_displacement[i][k]) / sd);
            zf.push((w[k] - c.applied_wrench[i][k]) / fs[k]);
            zm.push((w[k + 3] - c.applied_wrench[i][k + 3]) / fs[k + 3]);
        }
    }
    for (name, z) in [("displacement", zd), ("force", zf), ("moment", zm)] {
        let n = z.len() as f64;
        let mean = z.iter().sum::<f64>() / n;
        let sd = (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        // 480 samples: the sample sd is within ±10 % of 1 with probability > 0.99.
        assert!((sd - 1.0).abs() < 0.1, "{name}: sd {sd}");
        assert!(mean.abs() < 0.15, "{name}: mean {mean}");
    }
    assert_eq!(fs, [0.5, 0.5, 0.5, 0.05, 0.05, 0.05]);
}

#[test]
fn measurement_effects_act_on_the_recorded_values() {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 6,
        wrenches_per_pose: 2,
        noise: false,
        seed: 3,
        ..Default::default()
    };
    let bias = [1.0, -2.0, 0.5, 0.1, 0.0, -0.2];
    let phi = [0.01, -0.02, 0.005];
    let truth = TrueModel::nominal(7)
        .with_effect(Effect::WrenchBias { bias })
        .with_effect(Effect::FrameMisalignment { rotation: phi })
        .with_effect(Effect::PoseDrift { sigma: 1e-4 });
    let c = simulate(&chain, &truth, &spec).unwrap();
    let plain = simulate(&chain, &TrueModel::nominal(7), &spec).unwrap();
    let mut offsets: std::collections::BTreeMap<i64, [f64; 3]> = Default::default();
    for i in 0..c.dataset.len() {
        let w = c.dataset.wrench(i);
        for k in 0..6 {
            assert!((w[k] - c.applied_wrench[i][k] - bias[k]).abs() < 1e-12);
        }
        // The true displacement is unchanged by measurement effects.
        assert_eq!(c.true_displacement[i], plain.true_displacement[i]);
        let r = rotate(phi, c.true_displacement[i]);
        let d = c.dataset.displacement(i);
        let off = [d[0] - r[0], d[1] - r[1], d[2] - r[2]];
        let pose = c.dataset.pose(i).unwrap();
        let prev = *offsets.entry(pose).or_insert(off);
        for k in 0..3 {
            assert!(
                (prev[k] - off[k]).abs() < 1e-15,
                "drift must be constant per pose"
            );
        }
    }
    let spread: f64 = offsets.values().map(|o| o[0].abs()).fold(0.0, f64::max);
    assert!(spread > 1e-5, "pose drift should be present");
}

#[test]
fn invalid_truth_and_spec_are_rejected() {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec::default();
    let bad = TrueModel::nominal(6);
    assert!(simulate(&chain, &bad, &spec)
        .unwrap_err()
        .to_string()
        .contains("21"));
    let bad = TrueModel::nominal(7).with_effect(Effect::JointTilt {
        joint: 9,
        axis: SpringAxis::X,
        compliance: 1e-5,
    });
    assert!(simulate(&chain, &bad, &spec)
        .unwrap_err()
        .to_string()
        .contains("joint 10"));
    let bad = TrueModel::nominal(7).with_effect(Effect::TorsionNonlinear {
        joint: 1,
        spring: HarmonicDriveSpring {
            k1: 1.0,
            k2: 1.0,
            k3: 1.0,
            t1: 5.0,
            t2: 2.0,
        },
    });
    assert!(simulate(&chain, &bad, &spec).is_err());
    let spec = CampaignSpec {
        n_poses: 1,
        ..Default::default()
    };
    assert!(simulate(&chain, &TrueModel::nominal(7), &spec).is_err());
}
