//! The testbed's effects outside the diagnosis catalogue (compliant mount, tool compliant along
//! its axis) and the isotropic tracker noise, against hand computations that do not go through
//! the testbed's own code: the tip frame comes from the crate's forward kinematics, rotations
//! from explicit cos/sin.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::testbed::{simulate, CampaignSpec, Effect, TrackerNoise, TrueModel};
use vjm::SerialChain;

fn random_q(chain: &SerialChain, rng: &mut ChaCha8Rng) -> Vec<f64> {
    chain
        .limits()
        .iter()
        .map(|&(lo, hi)| rng.random_range(lo.max(-3.0) + 0.1..hi.min(3.0) - 0.1))
        .collect()
}

fn random_wrench(rng: &mut ChaCha8Rng) -> [f64; 6] {
    let mut w = [0.0; 6];
    for (k, v) in w.iter_mut().enumerate() {
        let scale = if k < 3 { 60.0 } else { 3.0 };
        *v = rng.random_range(-scale..scale);
    }
    w
}

/// A rigid arm (all spring compliances zero) carrying only `effect`.
fn rigid_with(effect: Effect) -> TrueModel {
    TrueModel::torsion_only(&[0.0; 7]).with_effect(effect)
}

#[test]
fn mount_translation_is_force_over_stiffness() {
    let chain = SerialChain::bundled();
    let k = 2.5e5;
    let truth = rigid_with(Effect::MountCompliance {
        translation: 1.0 / k,
        rotation: 0.0,
    });
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..20 {
        let q = random_q(&chain, &mut rng);
        let w = random_wrench(&mut rng);
        let (d, _) = truth.displacement(&chain, &q, &w);
        for a in 0..3 {
            // F/k (up to 240 µm here) to rounding: the testbed forms (p₀ + t) − p₀ with
            // |p₀| ≈ 1 m, so 1e-15 m absolute (≈ 5 ulp of p₀).
            assert!(
                (d[a] - w[a] / k).abs() <= 1e-15,
                "axis {a}: {} vs {}",
                d[a],
                w[a] / k
            );
        }
    }
}

#[test]
fn mount_rotation_turns_the_tip_about_the_base_origin() {
    // A pure moment about the base z axis (no force) turns the mount by θ = c_r·M_z; the tip
    // point p (from the crate's forward kinematics) moves to Rz(θ)·p.
    let chain = SerialChain::bundled();
    let c_r = 1.0 / 2.5e4; // compliant on purpose: θ = 1.2e-4 rad at 3 N·m
    let truth = rigid_with(Effect::MountCompliance {
        translation: 0.0,
        rotation: c_r,
    });
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for _ in 0..10 {
        let q = random_q(&chain, &mut rng);
        let p = chain.forward_kinematics(&q).unwrap().translation.vector;
        let mz = rng.random_range(-3.0..3.0);
        let (d, tip) = truth.displacement(&chain, &q, &[0.0, 0.0, 0.0, 0.0, 0.0, mz]);
        assert!((tip - p).norm() < 1e-12);
        let th: f64 = c_r * mz;
        let expected = Vector3::new(
            p.x * (th.cos() - 1.0) - p.y * th.sin(),
            p.x * th.sin() + p.y * (th.cos() - 1.0),
            0.0,
        );
        assert!((d - expected).norm() < 1e-15, "{d:?} vs {expected:?}");
    }
    // A force f at the tip point p makes the moment p × f about the base origin: to first
    // order the tip moves by c_r·(p × f) × p, and by F/k along f.
    let k = 2.5e5;
    let truth = rigid_with(Effect::MountCompliance {
        translation: 1.0 / k,
        rotation: 1.0 / k,
    });
    for _ in 0..10 {
        let q = random_q(&chain, &mut rng);
        let p = chain.forward_kinematics(&q).unwrap().translation.vector;
        let w = random_wrench(&mut rng);
        let f = Vector3::new(w[0], w[1], w[2]);
        let m = Vector3::new(w[3], w[4], w[5]);
        let phi = (m + p.cross(&f)) / k;
        let first_order = f / k + phi.cross(&p);
        let (d, _) = truth.displacement(&chain, &q, &w);
        // The remainder is second order in the rotation: ≤ |φ|²·|p|.
        let bound = phi.norm().powi(2) * p.norm() + 1e-18;
        assert!(
            (d - first_order).norm() <= bound,
            "{} > {bound}",
            (d - first_order).norm()
        );
        assert!((d - first_order).norm() < 1e-3 * first_order.norm());
    }
}

#[test]
fn tool_compliance_moves_the_tip_along_the_tool_axis() {
    let chain = SerialChain::bundled();
    let c = 1.0 / 1e5;
    let truth = rigid_with(Effect::ToolAxialCompliance { compliance: c });
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let q = random_q(&chain, &mut rng);
        let frame = chain.forward_kinematics(&q).unwrap();
        let z = frame.rotation * Vector3::z();
        let w = random_wrench(&mut rng);
        let f = Vector3::new(w[0], w[1], w[2]);
        let (d, _) = truth.displacement(&chain, &q, &w);
        let expected = z * (c * f.dot(&z));
        assert!((d - expected).norm() < 1e-15 + 1e-12 * expected.norm());
        // A force across the tool axis does not move the tool.
        let across = f - z * f.dot(&z);
        let (d, _) = truth.displacement(&chain, &q, &[across.x, across.y, across.z, 0.0, 0.0, 0.0]);
        assert!(d.norm() < 1e-18 + 1e-12 * c * across.norm(), "{}", d.norm());
    }
}

#[test]
fn outside_effects_add_to_the_arm_to_first_order() {
    // On the compliant arm, the mount and the tool add their own motion to the arm's
    // deflection, up to products of small rotations (φ·d_arm).
    let chain = SerialChain::bundled();
    let nominal = TrueModel::nominal(7);
    let (ct, cr, c_tool) = (1.0 / 2.5e5, 1.0 / 2.5e5, 1.0 / 1e5);
    let truth = nominal
        .clone()
        .with_effect(Effect::MountCompliance {
            translation: ct,
            rotation: cr,
        })
        .with_effect(Effect::ToolAxialCompliance { compliance: c_tool });
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for _ in 0..10 {
        let q = random_q(&chain, &mut rng);
        let frame = chain.forward_kinematics(&q).unwrap();
        let p = frame.translation.vector;
        let z = frame.rotation * Vector3::z();
        let w = random_wrench(&mut rng);
        let f = Vector3::new(w[0], w[1], w[2]);
        let m = Vector3::new(w[3], w[4], w[5]);
        let (d_arm, _) = nominal.displacement(&chain, &q, &w);
        let phi = cr * (m + p.cross(&f));
        let tool = z * (c_tool * f.dot(&z));
        let sum = d_arm + tool + ct * f + phi.cross(&p);
        let (d, _) = truth.displacement(&chain, &q, &w);
        let bound = phi.norm() * (d_arm + tool).norm() + phi.norm().powi(2) * p.norm();
        assert!(
            (d - sum).norm() <= 1.01 * bound + 1e-18,
            "{} > {bound}",
            (d - sum).norm()
        );
    }
}

#[test]
fn isotropic_tracker_noise_has_the_requested_sigma_everywhere() {
    let sigma = 10e-6;
    let t = TrackerNoise::isotropic(sigma);
    for p in [[0.0, 0.0, 0.0], [0.5, -0.3, 0.8], [-1.0, 2.0, 0.1]] {
        assert!((t.displacement_sigma(p) - sigma).abs() < 1e-15 * sigma);
    }
    // The default stays the distance-dependent MPE model.
    assert_eq!(TrackerNoise::default().mpe_per_m, 6e-6);
    // Drawn noise: on a rigid arm the recorded displacement is the noise alone.
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        tracker: t,
        seed: 31,
        ..Default::default()
    };
    let c = simulate(&chain, &TrueModel::torsion_only(&[0.0; 7]), &spec).unwrap();
    let z: Vec<f64> = (0..c.dataset.len())
        .flat_map(|i| c.dataset.displacement(i).map(|v| v / sigma))
        .collect();
    let n = z.len() as f64;
    let sd = (z.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    // 480 samples: the RMS is within ±10 % of 1 with probability > 0.99.
    assert!((sd - 1.0).abs() < 0.1, "sd {sd}");
}

#[test]
fn invalid_outside_effects_are_rejected() {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec::default();
    for e in [
        Effect::MountCompliance {
            translation: -1e-6,
            rotation: 0.0,
        },
        Effect::MountCompliance {
            translation: 0.0,
            rotation: f64::NAN,
        },
        Effect::ToolAxialCompliance {
            compliance: f64::INFINITY,
        },
        Effect::LinkTranslation {
            joint: 2,
            axis: vjm::SpringAxis::Z,
            compliance: -1e-6,
        },
        Effect::LinkTranslation {
            joint: 7,
            axis: vjm::SpringAxis::X,
            compliance: 1e-6,
        },
    ] {
        let err = simulate(&chain, &TrueModel::nominal(7).with_effect(e), &spec)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("compliance") || err.contains("the chain has 7 joints"),
            "{err}"
        );
    }
}
