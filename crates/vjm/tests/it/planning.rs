//! Measurement planning: the predicted standard errors are what simulated campaigns at the
//! planned rows show, and the plan beats as many random poses by ≥ 2× on the worst one.

use vjm::gravity::Gravity;
use vjm::testbed::{simulate, simulate_at, CampaignSpec, TrueModel};
use vjm::Measurements;
use vjm::{
    design, identify, predicted_stderr, IdentifyOptions, NoiseModel, Plan, PlanSpec, SerialChain,
    VirtualJointModel,
};

fn default_plan() -> (SerialChain, VirtualJointModel, Plan) {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let plan = design(
        &chain,
        &model,
        &PlanSpec::default(),
        &NoiseModel::typical(&model),
    )
    .unwrap();
    (chain, model, plan)
}

/// Shape of the plan: 24 poses × 4 wrenches, inside the limits by the margin, every
/// identifiable combination of the Panda's extended model (rank 15) with a positive error.
#[test]
fn plan_rows_are_a_campaign() {
    let (chain, _, plan) = default_plan();
    assert_eq!(plan.wrench.len(), 96);
    assert_eq!(plan.q.len(), 96 * 7);
    assert_eq!(plan.pose.len(), 96);
    assert_eq!(plan.rank, 15);
    assert_eq!(plan.combinations.len(), 15);
    for (i, q) in plan.q.chunks_exact(7).enumerate() {
        assert_eq!(plan.pose[i], i / 4);
        for (j, (&x, &(lo, hi))) in q.iter().zip(chain.limits()).enumerate() {
            assert!(
                x >= lo + 0.1 - 1e-12 && x <= hi - 0.1 + 1e-12,
                "row {i} joint {j}: {x}"
            );
        }
    }
    for w in &plan.wrench {
        let f = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        assert!((f - 80.0).abs() < 1e-9, "{w:?}");
    }
    assert!(plan
        .combinations
        .iter()
        .all(|c| c.stderr > 0.0 && c.stderr.is_finite()));
    assert_eq!(
        plan.worst_stderr,
        plan.combinations
            .iter()
            .map(|c| c.stderr)
            .fold(0.0, f64::max)
    );
}

/// Over 200 simulated campaigns at the planned rows (the testbed's truth, tracker and F/T
/// noise, the identification with its defaults) the spread of every combination's estimate is
/// within ±25 % of the predicted standard error.
#[test]
fn predicted_standard_errors_match_simulated_campaigns() {
    let (chain, model, plan) = default_plan();
    let worst = observed_over_predicted(&chain, &model, &plan, None, 200);
    assert!(worst <= 0.25, "{worst}");
}

/// The same under gravity (issue 22): planned at the sagged pose, the campaigns measured under
/// the weight (loaded − unloaded at the static equilibrium) and identified under gravity.
#[test]
fn predicted_standard_errors_match_simulated_campaigns_under_gravity() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let mut noise = NoiseModel::typical(&model);
    noise.gravity = Some(Gravity::default());
    let plan = design(&chain, &model, &PlanSpec::default(), &noise).unwrap();
    assert_eq!(plan.rank, 15);
    // The sag moves every row's Jacobian: the plan's errors are not the weightless plan's.
    let (_, _, weightless) = default_plan();
    assert!(plan
        .combinations
        .iter()
        .zip(&weightless.combinations)
        .any(|(a, b)| (a.stderr / b.stderr - 1.0).abs() > 1e-6));
    let worst = observed_over_predicted(&chain, &model, &plan, Some(Gravity::default()), 100);
    assert!(worst <= 0.25, "{worst}");
}

/// The worst |observed spread / predicted standard error − 1| over the plan's combinations, from
/// `campaigns` testbed campaigns at the planned rows (nominal truth, tracker and F/T noise)
/// identified with the defaults (under `gravity` when given).
fn observed_over_predicted(
    chain: &SerialChain,
    model: &VirtualJointModel,
    plan: &Plan,
    gravity: Option<Gravity>,
    campaigns: u64,
) -> f64 {
    let truth = TrueModel::nominal(7);
    let poses: Vec<i64> = plan.pose.iter().map(|&p| p as i64).collect();
    let k = plan.combinations.len();
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); k];
    let mut opts = IdentifyOptions::default();
    opts.gravity = gravity;
    for seed in 0..campaigns {
        let spec = CampaignSpec {
            seed: 1000 + seed,
            gravity,
            ..Default::default()
        };
        let c = simulate_at(chain, &truth, &plan.q, &plan.wrench, &poses, &spec).unwrap();
        let ds = &c.dataset;
        let (q, w, d) = (ds.q_flat(), ds.wrench_flat(), ds.displacement_flat());
        let id = identify(chain, model, Measurements::new(q, w, d), &opts).unwrap();
        assert_eq!(id.rank, plan.rank);
        for (j, comb) in id.combinations.iter().enumerate() {
            assert_eq!(comb.label, plan.combinations[j].label);
            values[j].push(comb.value);
        }
    }
    let mut worst: f64 = 0.0;
    for (j, v) in values.iter().enumerate() {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        let ratio = sd / plan.combinations[j].stderr;
        println!(
            "{:<28} predicted {:.3e} observed {:.3e} ratio {ratio:.3}",
            plan.combinations[j].label, plan.combinations[j].stderr, sd
        );
        worst = worst.max((ratio - 1.0).abs());
    }
    println!("worst |observed/predicted − 1| over {campaigns} campaigns: {worst:.3}");
    worst
}

/// The plan's worst predicted standard error is at least 2× smaller than that of testbed
/// campaigns with as many random poses and wrenches per pose (5 seeds), on the same
/// combinations and with the same noise model.
#[test]
fn plan_beats_random_poses() {
    let (chain, model, plan) = default_plan();
    let truth = TrueModel::nominal(7);
    let terms: Vec<Vec<(usize, f64)>> = plan
        .combinations
        .iter()
        .map(|c| c.terms.iter().map(|t| (t.param, t.coefficient)).collect())
        .collect();
    let noise = NoiseModel::typical(&model);
    for seed in 0..5 {
        let spec = CampaignSpec {
            n_poses: 24,
            wrenches_per_pose: 4,
            noise: false,
            seed: 500 + seed,
            ..Default::default()
        };
        let c = simulate(&chain, &truth, &spec).unwrap();
        let se = predicted_stderr(
            &chain,
            &model,
            c.dataset.q_flat(),
            &c.applied_wrench,
            plan.rank,
            &terms,
            &noise,
        )
        .unwrap();
        let worst = se.iter().copied().fold(0.0, f64::max);
        println!(
            "seed {seed}: random worst {worst:.3e}, planned {:.3e}, ratio {:.2}",
            plan.worst_stderr,
            worst / plan.worst_stderr
        );
        assert!(
            worst >= 2.0 * plan.worst_stderr,
            "{worst} vs {}",
            plan.worst_stderr
        );
    }
}

#[test]
fn plan_errors_name_the_option() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let noise = NoiseModel::typical(&model);
    let mut spec = PlanSpec::default();
    spec.n_poses = 0;
    let e = design(&chain, &model, &spec, &noise)
        .unwrap_err()
        .to_string();
    assert!(e.contains("poses"), "{e}");
    let mut spec = PlanSpec::default();
    spec.limit_margin = f64::NAN;
    let e = design(&chain, &model, &spec, &noise)
        .unwrap_err()
        .to_string();
    assert!(e.contains("margin"), "{e}");
    let mut spec = PlanSpec::default();
    spec.limit_margin = 2.0;
    let e = design(&chain, &model, &spec, &noise)
        .unwrap_err()
        .to_string();
    assert!(e.contains("margin") && e.contains("panda_joint2"), "{e}");
    let mut spec = PlanSpec::default();
    spec.min_tip_height = 5.0;
    spec.pool_size = 30;
    let e = design(&chain, &model, &spec, &noise)
        .unwrap_err()
        .to_string();
    assert!(e.contains("acceptable poses"), "{e}");
    let mut bad = noise.clone();
    bad.prior_compliance.pop();
    let e = design(&chain, &model, &PlanSpec::default(), &bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("prior compliance"), "{e}");
}

/// A planar-ish arm: `j1` about z at 0.3 m height, `j2` about y 0.4 m out, tool 0.3 m beyond
/// and 0.1 m up. `base`→`l1` is one joint with the tip on its axis (nothing moves it).
/// The same file serves the Python short-chain tests and the CLI fuzzer's design cases.
const ARM2: &str = include_str!("../data/arm2.urdf");

fn arm2(base: &str, tip: &str) -> SerialChain {
    SerialChain::from_urdf_str(ARM2, base, tip).unwrap()
}

/// Issue 21: chains of one and two joints get a plan or a clear error, never a panic (a
/// rank-0 chain used to reach nalgebra's "empty matrix" panic).
#[test]
fn short_chains_get_a_plan_or_a_clear_error() {
    for (base, tip, joints) in [("base", "tool", 2), ("l1", "tool", 1)] {
        let chain = arm2(base, tip);
        assert_eq!(chain.n_joints(), joints);
        for model in [
            VirtualJointModel::traditional(joints),
            VirtualJointModel::extended(joints),
        ] {
            let plan = design(
                &chain,
                &model,
                &PlanSpec::default(),
                &NoiseModel::typical(&model),
            )
            .unwrap_or_else(|e| panic!("{base}→{tip}: {e}"));
            assert!(
                plan.rank >= 1 && plan.worst_stderr.is_finite(),
                "{base}→{tip}"
            );
            assert_eq!(plan.wrench.len(), 96);
        }
    }
    // The tip on the only joint's axis: nothing to identify.
    let chain = arm2("base", "l1");
    let model = VirtualJointModel::extended(1);
    let e = design(
        &chain,
        &model,
        &PlanSpec::default(),
        &NoiseModel::typical(&model),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("rank 0") && e.contains("`l1`"), "{e}");
}

/// A chain whose tip never rises above the height filter is refused early (not after 600 000
/// draws) with the filter, the links and the highest tip seen in the message.
#[test]
fn a_tip_below_the_height_filter_is_named() {
    let chain = arm2("l1", "tool");
    let model = VirtualJointModel::extended(1);
    let mut spec = PlanSpec::default();
    spec.min_tip_height = 1.0;
    let e = design(&chain, &model, &spec, &NoiseModel::typical(&model))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("acceptable poses")
            && e.contains("1 m above the base `l1`")
            && e.contains("highest"),
        "{e}"
    );
    assert!(e.contains("in 50000 draws"), "gave up late: {e}");
}

/// The measurement cap (poses × wrenches) is checked before any work.
#[test]
fn too_many_measurements_are_refused() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let mut spec = PlanSpec::default();
    spec.n_poses = 10_000;
    spec.wrenches_per_pose = 11;
    spec.pool_size = 10_000;
    let e = design(&chain, &model, &spec, &NoiseModel::typical(&model))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("110000 measurements") && e.contains("100000"),
        "{e}"
    );
}

/// A cancelled token stops the planning with `Cancelled`; progress is reported per stage.
#[test]
fn design_is_cancellable_and_reports_progress() {
    use std::sync::Mutex;
    use stiffness_core::{Cancel, Monitor, Progress};
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let noise = NoiseModel::typical(&model);
    let cancel = Cancel::new();
    cancel.cancel();
    let e = vjm::design_monitored(
        &chain,
        &model,
        &PlanSpec::default(),
        &noise,
        &Monitor::new(cancel),
    )
    .unwrap_err();
    assert!(matches!(e, vjm::VjmError::Cancelled(_)), "{e}");
    let seen = Mutex::new(Vec::new());
    let sink = |p: Progress| seen.lock().unwrap().push(p.stage);
    let mut spec = PlanSpec::default();
    spec.n_poses = 3;
    spec.pool_size = 30;
    vjm::design_monitored(
        &chain,
        &model,
        &spec,
        &noise,
        &Monitor::new(Cancel::new()).with_progress(&sink),
    )
    .unwrap();
    let seen = seen.into_inner().unwrap();
    for stage in ["pool", "selection", "check"] {
        assert!(seen.contains(&stage), "{seen:?}");
    }
}

#[test]
fn planning_conditions_poses_as_the_testbed_does_from_its_own_kinematics() {
    // Planning's pose filter (`vjm::inverse_condition`, the library's Jacobian) and the
    // testbed's (its independent kinematics) are two code paths: they agree on seeded poses,
    // near a singularity too (q4 → 0 stretches the Panda's elbow).
    use rand::{Rng, SeedableRng};
    let chain = SerialChain::bundled();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(26);
    let mut smallest: f64 = 1.0;
    for k in 0..200 {
        let mut q: Vec<f64> = chain
            .limits()
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo.max(-3.0)..hi.min(3.0)))
            .collect();
        if k % 4 == 0 {
            q[3] = -1e-3 * (k as f64 + 1.0);
        }
        let (lib, bed) = (
            vjm::inverse_condition(&chain, &q),
            vjm::testbed::inverse_condition(&chain, &q),
        );
        assert!(
            (lib - bed).abs() <= 1e-12 * bed.max(1e-3),
            "{q:?}: {lib} vs {bed}"
        );
        assert!(lib > 0.0 && lib <= 1.0);
        smallest = smallest.min(lib);
    }
    assert!(smallest < 0.02, "no pose near a singularity: {smallest}");
}
