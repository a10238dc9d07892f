//! Shared proptest strategies and deterministic data generators (also used by the
//! testbed/diagnose/dataset test modules).
#![allow(dead_code)]

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::Measurements;
use vjm::SerialChain;

/// Proptest configuration: `cases` cases from a fixed seed, so every run sees the same inputs.
pub fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x5EED_0003),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A unit axis: mostly random, sometimes exactly ±x, ±y or ±z (the fallback branches of
/// the spring-axis convention).
pub fn arb_axis() -> impl Strategy<Value = Vector3<f64>> {
    prop_oneof![
        3 => (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
            .prop_filter("non-degenerate", |(x, y, z)| x * x + y * y + z * z > 0.05)
            .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize()),
        1 => prop::sample::select(vec![
            Vector3::x(), -Vector3::x(), Vector3::y(), -Vector3::y(), Vector3::z(), -Vector3::z()
        ]),
    ]
}

/// A rigid transform with translation in [-0.4, 0.4]³ m and any rotation.
pub fn arb_isometry() -> impl Strategy<Value = Isometry3<f64>> {
    (
        (-0.4f64..0.4, -0.4f64..0.4, -0.4f64..0.4),
        (-3.1f64..3.1, -1.5f64..1.5, -3.1f64..3.1),
    )
        .prop_map(|((x, y, z), (r, p, yw))| {
            Isometry3::from_parts(
                Translation3::new(x, y, z),
                UnitQuaternion::from_euler_angles(r, p, yw),
            )
        })
}

/// A random serial chain of `joints` revolute joints (continuous limits).
pub fn arb_chain(joints: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = SerialChain> {
    joints
        .prop_flat_map(|n| {
            (
                prop::collection::vec((arb_isometry(), arb_axis()), n),
                arb_isometry(),
            )
        })
        .prop_map(|(js, tip)| {
            let joints = js
                .into_iter()
                .enumerate()
                .map(|(i, (o, a))| (format!("j{}", i + 1), o, a, (-3.0, 3.0)))
                .collect();
            SerialChain::from_joints("base", "tip", joints, tip).expect("valid random chain")
        })
}

/// A random chain with one configuration q ∈ [-π, π]ⁿ.
pub fn arb_chain_and_q(
    joints: std::ops::RangeInclusive<usize>,
) -> impl Strategy<Value = (SerialChain, Vec<f64>)> {
    arb_chain(joints).prop_flat_map(|c| {
        let n = c.n_joints();
        (Just(c), prop::collection::vec(-3.1f64..3.1, n))
    })
}

/// A wrench with forces up to 50 N and moments up to 5 N·m.
pub fn arb_wrench() -> impl Strategy<Value = [f64; 6]> {
    (
        prop::array::uniform3(-50.0f64..50.0),
        prop::array::uniform3(-5.0f64..5.0),
    )
        .prop_map(|(f, m)| [f[0], f[1], f[2], m[0], m[1], m[2]])
}

/// N configurations uniformly inside the chain's limits (continuous joints: [-π, π]),
/// N×n row-major, from a fixed seed.
pub fn random_configurations(chain: &SerialChain, count: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut q = Vec::with_capacity(count * chain.n_joints());
    for _ in 0..count {
        for &(lo, hi) in chain.limits() {
            let (lo, hi) = if lo.is_finite() && hi.is_finite() {
                (lo, hi)
            } else {
                (-std::f64::consts::PI, std::f64::consts::PI)
            };
            q.push(rng.random_range(lo..hi));
        }
    }
    q
}

/// N wrenches (forces up to 50 N, moments up to 5 N·m), N×6 row-major, from a fixed seed.
pub fn random_wrenches(count: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .flat_map(|_| {
            let mut w = [0.0; 6];
            for (i, v) in w.iter_mut().enumerate() {
                let s = if i < 3 { 50.0 } else { 5.0 };
                *v = rng.random_range(-s..s);
            }
            w
        })
        .collect()
}

/// Compliances in [1e-7, 1e-5] rad/(N·m) from a fixed seed.
pub fn random_compliances(m: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..m)
        .map(|_| 10f64.powf(rng.random_range(-7.0..-5.0)))
        .collect()
}

/// A seeded campaign of the bundled Panda with nominal torsion springs and nothing hidden:
/// `n_poses` poses × `wrenches_per_pose` loads (the testbed's default noise and split).
pub fn nominal_panda_campaign(
    n_poses: usize,
    wrenches_per_pose: usize,
    seed: u64,
) -> (SerialChain, vjm::dataset::Dataset<'static>) {
    let chain = SerialChain::bundled();
    let spec = vjm::testbed::CampaignSpec {
        n_poses,
        wrenches_per_pose,
        seed,
        ..Default::default()
    };
    let c = vjm::testbed::simulate(&chain, &vjm::testbed::TrueModel::nominal(7), &spec)
        .expect("the bundled Panda simulates");
    (chain, c.dataset)
}

/// A stiffness model of `model`'s springs identified (weightless) from a campaign simulated on
/// `chain` with the nominal torsion-only truth: `spec` sets poses, seed and noise.
pub fn identified_model(
    chain: &SerialChain,
    model: &vjm::VirtualJointModel,
    spec: &vjm::testbed::CampaignSpec,
) -> vjm::StiffnessModel {
    use vjm::testbed::{simulate, TrueModel};
    use vjm::{identify, DataSource, IdentifyOptions, StiffnessModel};
    let truth = TrueModel::nominal(chain.n_joints());
    let data = simulate(chain, &truth, spec).unwrap().dataset;
    let (q, w, d) = (data.q_flat(), data.wrench_flat(), data.displacement_flat());
    let opts = IdentifyOptions::default();
    let id = identify(chain, model, Measurements::new(q, w, d), &opts).unwrap();
    StiffnessModel::from_identification(&id, chain, model, &opts, DataSource::in_memory(data.len()))
        .unwrap()
}
