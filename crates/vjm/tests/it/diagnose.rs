//! `diagnose`: hidden effects are named, clean data give no finding, the extension pays off on
//! held-out rows, unexplained structure is flagged, and the statistics are right.

use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::diagnose::stats::{
    benjamini_hochberg, beta_inc, chi2_sf, f_sf, nested_f_test, one_way_anova, ranks, spearman,
    t_two_sided,
};
use vjm::diagnose::{
    detectability, diagnose, diagnose_with_progress, DiagnoseError, DiagnoseOptions,
    NoiseAssumption,
};
use vjm::testbed::{
    simulate, Campaign, CampaignSpec, Effect, HarmonicDriveSpring, TrueModel, NOMINAL_TORSION,
};
use vjm::{jacobian, SerialChain, SpringAxis, VirtualJointModel};

use crate::strategies::config;

/// The detectability threshold of docs/diagnose.md: the effect's whitened displacement signal,
/// after projecting out the baseline, must carry at least 64 noise variances (8 σ).
const DETECTABLE: f64 = 64.0;

fn spec(seed: u64) -> CampaignSpec {
    CampaignSpec {
        seed,
        ..Default::default()
    }
}

/// Simulates `truth` and returns the campaign with the detectability of what `truth` adds to
/// the nominal robot (noise-free campaign on the same poses and loads).
fn campaign_and_lambda(
    chain: &SerialChain,
    truth: &TrueModel,
    spec: &CampaignSpec,
) -> (Campaign, f64) {
    let noisy = simulate(chain, truth, spec).unwrap();
    let quiet = |t: &TrueModel| {
        simulate(
            chain,
            t,
            &CampaignSpec {
                noise: false,
                ..spec.clone()
            },
        )
        .unwrap()
    };
    // The effect's signal is what the nominal model gets wrong on noise-free data: the measured
    // displacement minus the nominal prediction from the *recorded* wrench (for a wrench bias the
    // displacement is unchanged and the error sits in the recorded load).
    let with = quiet(truth);
    let nominal = TrueModel::nominal(7);
    let signal: Vec<[f64; 3]> = (0..with.dataset.len())
        .map(|i| {
            let a = with.dataset.displacement(i);
            let (b, _) = nominal.displacement(chain, with.dataset.q(i), &with.dataset.wrench(i));
            [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
        })
        .collect();
    // Measured on the noise-free campaign: with the recorded (noisy) wrench in the baseline's
    // columns, errors in the wrench would count as signal.
    let lambda = detectability(chain, &with.dataset, &signal, &DiagnoseOptions::default()).unwrap();
    (noisy, lambda)
}

/// Whether the diagnosis names `effect` at `joint` (1-based) / `axis`, as a finding or alias.
fn named(
    d: &vjm::diagnose::report::Diagnosis,
    effect: &str,
    joint: Option<usize>,
    axis: Option<&str>,
) -> bool {
    d.findings.iter().any(|f| {
        (f.effect == effect && f.joint == joint && f.axis.as_deref() == axis)
            || f.aliases
                .iter()
                .any(|a| a.effect == effect && a.joint == joint && a.axis.as_deref() == axis)
    })
}

fn describe(d: &vjm::diagnose::report::Diagnosis) -> String {
    d.findings
        .iter()
        .map(|f| {
            format!(
                "{}{:?}{:?} p={:.1e} aliases {:?}",
                f.effect,
                f.joint,
                f.axis,
                f.evidence.selection.f_test.p_value,
                f.aliases
                    .iter()
                    .map(|a| format!("{}{:?}{:?}", a.effect, a.joint, a.axis))
                    .collect::<Vec<_>>()
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// Scales a linear effect to the drawn detectability `target` (≥ DETECTABLE), then checks it.
fn run_linear(
    chain: &SerialChain,
    make: &dyn Fn(f64) -> Effect,
    target: f64,
    seed: u64,
) -> Option<(vjm::diagnose::report::Diagnosis, f64)> {
    let (_, l1) = campaign_and_lambda(
        chain,
        &TrueModel::nominal(7).with_effect(make(1.0)),
        &spec(seed),
    );
    if l1 < 1e-9 {
        return None; // in the baseline's span: not testable on these data
    }
    let mut scale = (target / l1).sqrt();
    for _ in 0..4 {
        let truth = TrueModel::nominal(7).with_effect(make(scale));
        let (c, l) = campaign_and_lambda(chain, &truth, &spec(seed));
        if l >= DETECTABLE {
            let d = diagnose(chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
            return Some((d, scale));
        }
        scale *= (target / l).sqrt().max(1.1);
    }
    None
}

proptest! {
    #![proptest_config(config(10))]

    #[test]
    fn hidden_tilt_is_named(joint in 0usize..7, y in any::<bool>(), target in DETECTABLE..400.0, seed in 0u64..1000) {
        let chain = SerialChain::bundled();
        let axis = if y { SpringAxis::Y } else { SpringAxis::X };
        let make = |c: f64| Effect::JointTilt { joint, axis, compliance: 1e-5 * c };
        let Some((d, scale)) = run_linear(&chain, &make, target, seed) else {
            // Tilts J1y, J2y and J5y move the tip exactly like a torsion of the baseline.
            return Ok(());
        };
        if 1e-5 * scale > 5e-4 {
            // Beyond a cobot's torsional compliance: not a realistic tilt; this location is not
            // detectable on this campaign at realistic magnitudes.
            return Ok(());
        }
        let ax = if y { "y" } else { "x" };
        prop_assert!(named(&d, "joint_tilt", Some(joint + 1), Some(ax)),
            "tilt J{}{} (c = {:.2e}) not named: {}", joint + 1, ax, 1e-5 * scale, describe(&d));
    }

    #[test]
    fn hidden_backlash_is_named(joint in 0usize..6, target in DETECTABLE..400.0, seed in 0u64..1000) {
        let chain = SerialChain::bundled();
        let make = |b: f64| Effect::Backlash { joint, lost_motion: 1e-5 * b };
        let Some((d, scale)) = run_linear(&chain, &make, target, seed) else {
            return Err(TestCaseError::fail("backlash never reached the detectability threshold"));
        };
        prop_assert!(named(&d, "joint_backlash", Some(joint + 1), None),
            "backlash J{} (b = {:.2e} rad) not named: {}", joint + 1, 1e-5 * scale, describe(&d));
    }

    #[test]
    fn hidden_wrench_bias_is_named(dir in prop::array::uniform6(-1.0f64..1.0), target in DETECTABLE..400.0, seed in 0u64..1000) {
        let chain = SerialChain::bundled();
        let make = |s: f64| Effect::WrenchBias { bias: [
            s * dir[0], s * dir[1], s * dir[2], 0.1 * s * dir[3], 0.1 * s * dir[4], 0.1 * s * dir[5],
        ] };
        let Some((d, _)) = run_linear(&chain, &make, target, seed) else {
            return Err(TestCaseError::fail("wrench bias never reached the detectability threshold"));
        };
        prop_assert!(named(&d, "wrench_bias", None, None), "bias not named: {}", describe(&d));
    }

    #[test]
    fn hidden_frame_misalignment_is_named(dir in prop::array::uniform3(-1.0f64..1.0), target in DETECTABLE..400.0, seed in 0u64..1000) {
        let chain = SerialChain::bundled();
        let make = |s: f64| Effect::FrameMisalignment { rotation: [1e-3 * s * dir[0], 1e-3 * s * dir[1], 1e-3 * s * dir[2]] };
        let Some((d, _)) = run_linear(&chain, &make, target, seed) else {
            return Err(TestCaseError::fail("misalignment never reached the detectability threshold"));
        };
        prop_assert!(named(&d, "frame_misalignment", None, None), "misalignment not named: {}", describe(&d));
    }

    #[test]
    fn hidden_torsion_nonlinearity_is_named(joint in 0usize..6, ratio in 1.5f64..3.0, seed in 0u64..1000) {
        // Harmonic-drive stiffening at joint j: k2 = r·k1, k3 = r²·k1, split at 0.3 and 0.8 × the
        // joint's RMS torque. The stiffening ratio grows until the effect is detectable.
        let chain = SerialChain::bundled();
        let base = simulate(&chain, &TrueModel::nominal(7), &spec(seed)).unwrap();
        let model = VirtualJointModel::traditional(7);
        let rms = (0..base.dataset.len()).map(|i| {
            let j = jacobian(&chain, &model, base.dataset.q(i)).unwrap();
            let w = base.applied_wrench[i];
            (0..6).map(|k| j[(k, joint)] * w[k]).sum::<f64>().powi(2)
        }).sum::<f64>().sqrt() / (base.dataset.len() as f64).sqrt();
        let mut r = ratio;
        let mut found = None;
        for _ in 0..8 {
            let spring = HarmonicDriveSpring::stiffening(NOMINAL_TORSION[joint], r, 0.3 * rms, 0.8 * rms);
            let truth = TrueModel::nominal(7).with_effect(Effect::TorsionNonlinear { joint, spring });
            let (c, l) = campaign_and_lambda(&chain, &truth, &spec(seed));
            if l >= DETECTABLE {
                found = Some((c, l));
                break;
            }
            r *= 1.5;
        }
        let Some((c, _)) = found else { return Ok(()) };
        let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
        // A stiffening spring also looks like lost motion at large torques: either name counts
        // when the other is listed as its alias, per the output contract.
        prop_assert!(named(&d, "joint_torsion_nonlinear", Some(joint + 1), None)
            || named(&d, "joint_backlash", Some(joint + 1), None) && d.findings.iter().any(|f|
                f.aliases.iter().any(|a| a.effect == "joint_torsion_nonlinear" && a.joint == Some(joint + 1))),
            "torsion non-linearity J{} (ratio {r:.2}) not named: {}", joint + 1, describe(&d));
    }

    #[test]
    fn hidden_geometric_nonlinearity_is_named(seed in 0u64..1000, target in DETECTABLE..200.0) {
        // K_C grows with the load: the force range is scaled up until the effect is detectable.
        let chain = SerialChain::bundled();
        let truth = TrueModel::nominal(7).with_effect(Effect::GeometricNonlinearity);
        let mut s = 1.0f64;
        let mut found = None;
        for _ in 0..12 {
            let sp = CampaignSpec { force_range: (10.0 * s, 80.0 * s), moment_max: 3.0 * s, ..spec(seed) };
            let (c, l) = campaign_and_lambda(&chain, &truth, &sp);
            if l >= target {
                found = Some(c);
                break;
            }
            s *= 1.1;
        }
        let Some(c) = found else {
            return Err(TestCaseError::fail("K_C never reached the detectability threshold at cobot loads"));
        };
        prop_assert!(80.0 * s < 250.0, "loads beyond a cobot's range: {}", 80.0 * s);
        let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
        prop_assert!(named(&d, "geometric_nonlinearity", None, None), "K_C not named (load ×{s:.2}): {}", describe(&d));
    }
}

#[test]
fn clean_data_give_no_finding_in_95_percent_of_seeds() {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7);
    let seeds = 60u64;
    let mut clean = 0;
    let mut unexplained = 0u64;
    for seed in 0..seeds {
        let c = simulate(&chain, &truth, &spec(1000 + seed)).unwrap();
        let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
        if d.findings.is_empty() {
            clean += 1;
        } else {
            println!("seed {}: false finding {}", 1000 + seed, describe(&d));
        }
        unexplained += d.unexplained as u64;
    }
    println!(
        "clean data: {clean}/{seeds} seeds without a finding, {unexplained} flagged unexplained"
    );
    assert!(clean * 100 >= 95 * seeds, "{clean}/{seeds}");
    assert!(
        (seeds - unexplained) * 100 >= 95 * seeds,
        "{unexplained} unexplained"
    );
}

#[test]
fn extending_with_tilts_cuts_held_out_error_by_40_percent() {
    // The seed's situation: tilting springs at every joint (0.3 × its torsional compliance)
    // carry about a third of the deflection the traditional model cannot represent.
    let chain = SerialChain::bundled();
    let truth = TrueModel::with_tilts(&NOMINAL_TORSION, 0.3);
    for seed in 0..3 {
        let c = simulate(&chain, &truth, &spec(seed)).unwrap();
        let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
        println!(
            "seed {seed}: held-out mean relative error {:.2} % → {:.2} % (gain {:.0} %), {} findings",
            100.0 * d.baseline.test_mean_rel_error,
            100.0 * d.extended.test_mean_rel_error,
            100.0 * d.gain,
            d.findings.len()
        );
        assert!(
            d.findings.iter().all(|f| f.effect == "joint_tilt"),
            "{}",
            describe(&d)
        );
        assert!(
            d.extended.test_mean_rel_error <= 0.6 * d.baseline.test_mean_rel_error,
            "gain {}",
            d.gain
        );
        assert!(d.extended.n_params > d.baseline.n_params);
    }
}

#[test]
fn structure_no_candidate_explains_is_flagged() {
    // Pose drift (an independent offset per configuration) is not in the catalogue.
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::PoseDrift { sigma: 1e-4 });
    for seed in 0..3 {
        let c = simulate(&chain, &truth, &spec(seed)).unwrap();
        let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
        assert!(
            d.unexplained,
            "seed {seed}: p = {}",
            d.residuals.extended.per_pose_anova.p_value
        );
        assert!(d.residuals.baseline.per_pose_anova.p_value < 1e-6);
    }
}

#[test]
fn coincident_axes_are_reported_as_aliases() {
    // On the Panda, joint 1's x tilt and joint 2's x tilt both rotate about the same line
    // through the shoulder: a tilt at one is named with the other as alias.
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::JointTilt {
        joint: 1,
        axis: SpringAxis::X,
        compliance: 1e-4,
    });
    let c = simulate(&chain, &truth, &spec(4)).unwrap();
    let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
    let f = &d.findings[0];
    let pair = [(f.joint, f.axis.clone())]
        .into_iter()
        .chain(f.aliases.iter().map(|a| (a.joint, a.axis.clone())))
        .collect::<Vec<_>>();
    assert!(
        pair.contains(&(Some(1), Some("x".into()))),
        "{}",
        describe(&d)
    );
    assert!(
        pair.contains(&(Some(2), Some("x".into()))),
        "{}",
        describe(&d)
    );
    let untestable: Vec<_> = d
        .scores
        .iter()
        .filter(|s| !s.testable)
        .map(|s| s.label.as_str())
        .collect();
    // The y tilts lie in the span of the model's springs; joint 7's hinge and backlash act
    // through its torsion, whose axis passes through the tip point: their columns are rounding
    // (below 1e-12 of the design's largest), not in the data, as the fit's own rule says of
    // the J7 torsion spring.
    assert_eq!(
        untestable,
        [
            "joint_tilt(J1y)",
            "joint_tilt(J2y)",
            "joint_tilt(J5y)",
            "joint_torsion_nonlinear(J7)",
            "joint_backlash(J7)"
        ]
    );
}

#[test]
fn json_follows_the_output_contract() {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::JointTilt {
        joint: 2,
        axis: SpringAxis::X,
        compliance: 5e-5,
    });
    let c = simulate(&chain, &truth, &spec(1)).unwrap();
    let mut calls = 0;
    let d = diagnose_with_progress(&chain, &c.dataset, &DiagnoseOptions::default(), &mut |_| {
        calls += 1
    })
    .unwrap();
    assert!(calls >= 3);
    let v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    for part in ["baseline", "extended"] {
        assert!(v[part]["model"].is_string());
        assert!(v[part]["n_params"].is_u64());
        assert!(v[part]["test_mean_rel_error"].is_f64());
    }
    assert_eq!(v["baseline"]["model"], "traditional");
    assert_eq!(v["baseline"]["n_params"], 7);
    assert!(v["unexplained"].is_boolean());
    let f = &v["findings"][0];
    assert_eq!(f["effect"], "joint_tilt");
    assert_eq!(f["joint"], 3);
    assert_eq!(f["axis"], "x");
    assert!(f["aliases"].is_array());
    assert!(f["evidence"]["f_test"]["p_value"].is_f64());
    // The pose-clustered Wald test agrees that this strong tilt is real, with G − 1 = 29
    // denominator degrees of freedom (30 training poses).
    let cr = &d.findings[0].evidence.selection.cluster_robust.unwrap();
    assert_eq!(cr.df_den, 29.0);
    assert!(cr.p_value < 1e-3, "{cr:?}");
    assert_eq!(v["extended"]["n_params"], 8);
    // The held-out error is the mean of ‖d_pred − d_meas‖/‖d_meas‖ over test rows, recomputed here.
    let rows = v["rows"].as_array().unwrap();
    let (mut sum, mut n) = (0.0, 0);
    for r in rows.iter().filter(|r| r["set"] == "test") {
        let m: Vec<f64> = r["measured"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let p: Vec<f64> = r["extended"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let e = ((m[0] - p[0]).powi(2) + (m[1] - p[1]).powi(2) + (m[2] - p[2]).powi(2)).sqrt();
        sum += e / (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        n += 1;
    }
    assert_eq!(n, d.n_test);
    assert!((sum / n as f64 - d.extended.test_mean_rel_error).abs() < 1e-12);
}

#[test]
fn bad_input_is_rejected_with_a_clear_error() {
    let chain = SerialChain::bundled();
    let c = simulate(&chain, &TrueModel::nominal(7), &spec(2)).unwrap();
    let short =
        SerialChain::from_urdf_str(vjm::BUNDLED_URDF, vjm::BUNDLED_BASE, "panda_link6").unwrap();
    let e = diagnose(&short, &c.dataset, &DiagnoseOptions::default()).unwrap_err();
    assert!(
        matches!(e, DiagnoseError::JointCount { data: 7, chain: 6 }),
        "{e}"
    );
    let selecting = |set: fn(&mut vjm::diagnose::SelectionOptions)| {
        let mut opts = DiagnoseOptions::default();
        set(&mut opts.selection);
        opts
    };
    let e = diagnose(&chain, &c.dataset, &selecting(|s| s.fdr = 1.5)).unwrap_err();
    assert!(e.to_string().contains("fdr"), "{e}");
    // The alias options are checked as the CSJM's are (they were not before issue 26): the
    // message names the option, the range and the value.
    for (opts, expect) in [
        (
            selecting(|s| s.alias_cosine = 1.5),
            "option `alias_cosine`: must be in (0, 1], got 1.5",
        ),
        (
            selecting(|s| s.alias_alpha = f64::NAN),
            "option `alias_alpha`: must be in (0, 1), got NaN",
        ),
    ] {
        let e = diagnose(&chain, &c.dataset, &opts).unwrap_err();
        assert!(e.to_string().contains(expect), "{e}");
    }
    let e = diagnose(
        &chain,
        &c.dataset,
        &DiagnoseOptions {
            baseline: Some(VirtualJointModel::traditional(6)),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("6 joints"), "{e}");
}

#[test]
fn any_model_can_be_the_baseline() {
    // With the extended model as baseline, a tilt is part of the model: nothing to find.
    let chain = SerialChain::bundled();
    let truth = TrueModel::with_tilts(&NOMINAL_TORSION, 0.3);
    let c = simulate(&chain, &truth, &spec(6)).unwrap();
    let d = diagnose(
        &chain,
        &c.dataset,
        &DiagnoseOptions {
            baseline: Some(VirtualJointModel::extended(7)),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(d.baseline.model, "extended");
    assert_eq!(d.baseline.n_params, 21);
    assert!(d.findings.iter().all(|f| f.effect != "joint_tilt"));
    assert!(d.scores.iter().all(|s| s.effect != "joint_tilt"));
}

// ---- statistics -------------------------------------------------------------------------

#[test]
fn distribution_tails_match_closed_forms_and_tables() {
    // I_x(1, 1) = x; I_x(a, 1) = x^a; symmetry I_x(a, b) = 1 − I_{1−x}(b, a).
    for x in [0.01, 0.3, 0.77] {
        assert!((beta_inc(1.0, 1.0, x) - x).abs() < 1e-14);
        assert!((beta_inc(2.5, 1.0, x) - x.powf(2.5)).abs() < 1e-13);
        assert!((beta_inc(3.2, 0.7, x) - (1.0 - beta_inc(0.7, 3.2, 1.0 - x))).abs() < 1e-13);
    }
    // χ² with 2 dof: P(X > x) = exp(−x/2).
    for x in [0.5, 3.0, 20.0] {
        assert!((chi2_sf(x, 2.0) - (-x / 2.0f64).exp()).abs() < 1e-13);
    }
    // Published critical values: F(1,10) 5 % = 4.9646, F(3,20) 5 % = 3.0984,
    // F(6,100) 1 % = 2.9877; t(10) two-sided 5 % = 2.2281; χ²₁ 5 % = 3.8415.
    assert!((f_sf(4.9646, 1.0, 10.0) - 0.05).abs() < 2e-5);
    assert!((f_sf(3.0984, 3.0, 20.0) - 0.05).abs() < 2e-5);
    assert!((f_sf(2.9877, 6.0, 100.0) - 0.01).abs() < 2e-5);
    assert!((t_two_sided(2.2281, 10.0) - 0.05).abs() < 2e-5);
    assert!((chi2_sf(3.8415, 1.0) - 0.05).abs() < 2e-5);
    // F(1, d) = t²(d).
    assert!((f_sf(2.5f64.powi(2), 1.0, 17.0) - t_two_sided(2.5, 17.0)).abs() < 1e-13);
}

#[test]
fn nested_f_test_is_uniform_under_the_null() {
    // Pure-noise regressions: the p-values of a true null are uniform; check the 5 % and
    // 50 % points over 2000 draws (binomial sd ≈ 0.5 % and 1.1 %).
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let normal = rand_distr::StandardNormal;
    let (n, draws) = (40usize, 2000);
    let mut ps = Vec::with_capacity(draws);
    for _ in 0..draws {
        // Model: intercept; candidate: one random regressor x.
        let y: Vec<f64> = (0..n).map(|_| rng.sample::<f64, _>(normal)).collect();
        let x: Vec<f64> = (0..n).map(|_| rng.sample::<f64, _>(normal)).collect();
        let my = y.iter().sum::<f64>() / n as f64;
        let mx = x.iter().sum::<f64>() / n as f64;
        let sse0: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
        let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
        let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
        let sse1 = sse0 - sxy * sxy / sxx;
        ps.push(nested_f_test(sse0, sse1, 1, n - 2).p_value);
    }
    let below = |a: f64| ps.iter().filter(|&&p| p < a).count() as f64 / draws as f64;
    assert!((below(0.05) - 0.05).abs() < 0.015, "{}", below(0.05));
    assert!((below(0.5) - 0.5).abs() < 0.035, "{}", below(0.5));
}

#[test]
fn benjamini_hochberg_step_up() {
    // m = 5, q = 0.05: thresholds 0.01, 0.02, 0.03, 0.04, 0.05. The largest k with
    // p_(k) ≤ kq/m is k = 3 (0.029 ≤ 0.03), so the three smallest are rejected even though
    // p_(2) = 0.025 > 0.02 (and p_(4) = 0.045 > 0.04).
    let p = [0.045, 0.001, 0.5, 0.025, 0.029];
    assert_eq!(
        benjamini_hochberg(&p, 0.05),
        [false, true, false, true, true]
    );
    assert_eq!(benjamini_hochberg(&[0.2, 0.3], 0.05), [false, false]);
    assert_eq!(benjamini_hochberg(&[f64::NAN, 0.001], 0.05), [false, true]);
}

#[test]
fn anova_and_spearman_match_hand_computations() {
    // Groups {1,2,3}, {4,5,6}: grand mean 3.5, SSB = 3·(1.5² + 1.5²) = 13.5, SSW = 4,
    // F = (13.5/1)/(4/4) = 13.5.
    let a = one_way_anova(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &[0, 0, 0, 1, 1, 1]).unwrap();
    assert!((a.f - 13.5).abs() < 1e-12);
    assert_eq!((a.df_between, a.df_within), (1.0, 4.0));
    assert!((a.p_value - f_sf(13.5, 1.0, 4.0)).abs() < 1e-15);
    assert!(one_way_anova(&[1.0, 2.0], &[0, 0]).is_none());
    // Ranks with ties; a monotone relation has ρ = 1.
    assert_eq!(ranks(&[10.0, 20.0, 10.0, 5.0]), [2.5, 4.0, 2.5, 1.0]);
    let s = spearman(&[1.0, 2.0, 3.0, 4.0, 5.0], &[1.0, 8.0, 27.0, 64.0, 125.0]).unwrap();
    assert!((s.rho - 1.0).abs() < 1e-15);
    // x = 1..5, y = (2, 1, 4, 3, 5): Σd² = 4, ρ = 1 − 6·4/(5·24) = 0.8.
    let s = spearman(&[1.0, 2.0, 3.0, 4.0, 5.0], &[2.0, 1.0, 4.0, 3.0, 5.0]).unwrap();
    assert!((s.rho - 0.8).abs() < 1e-14);
}

#[test]
fn cluster_robust_wald_matches_hand_computation() {
    use nalgebra::{DMatrix, DVector};
    use vjm::diagnose::stats::cluster_robust_wald;
    // One regressor, no intercept: β̂ = Σxy/Σx², B = 1/Σx², V = B² Σ_g (Σ_{i∈g} x_i r_i)² · G/(G−1).
    let x = [1.0, 2.0, -1.0, 0.5, 3.0, -2.0];
    let y = [1.2, 1.9, -0.7, 0.8, 2.6, -2.3];
    let cluster = [0, 0, 1, 1, 2, 2];
    let sxx: f64 = x.iter().map(|v| v * v).sum();
    let b = x.iter().zip(&y).map(|(a, c)| a * c).sum::<f64>() / sxx;
    let r: Vec<f64> = x.iter().zip(&y).map(|(a, c)| c - b * a).collect();
    let s: Vec<f64> = (0..3)
        .map(|g| x[2 * g] * r[2 * g] + x[2 * g + 1] * r[2 * g + 1])
        .collect();
    let v = s.iter().map(|v| v * v).sum::<f64>() / (sxx * sxx) * 1.5;
    let w = b * b / v;
    let t = cluster_robust_wald(
        &DMatrix::from_column_slice(6, 1, &x),
        &DVector::from_column_slice(&r),
        &DVector::from_element(1, b),
        &cluster,
        1,
    )
    .unwrap();
    assert!((t.f - w).abs() < 1e-10 * w, "{} vs {w}", t.f);
    assert_eq!((t.df_num, t.df_den), (1.0, 2.0));
    assert!((t.p_value - f_sf(w, 1.0, 2.0)).abs() < 1e-14);
    // Fewer than 3 clusters: no test.
    assert!(cluster_robust_wald(
        &DMatrix::from_column_slice(6, 1, &x),
        &DVector::from_column_slice(&r),
        &DVector::from_element(1, b),
        &[0, 0, 0, 1, 1, 1],
        1
    )
    .is_none());
}

#[test]
fn the_default_noise_assumption_is_the_testbeds_instruments() {
    // The diagnosis no longer imports the testbed; its default must still be its instruments.
    let t = vjm::testbed::TrackerNoise::default();
    let d = NoiseAssumption::default();
    assert_eq!(
        d.displacement_sigma,
        t.displacement_sigma([0.0, 0.0, t.position[2]])
    );
    assert_eq!(
        d.wrench_sigma,
        vjm::testbed::ForceSensorNoise::default().sigma()
    );
}

#[test]
fn a_bad_noise_level_is_refused_naming_it() {
    let chain = SerialChain::bundled();
    let c = simulate(&chain, &TrueModel::nominal(7), &spec(1)).unwrap();
    let cases: [(f64, f64, f64, &str); 5] = [
        (-1e-5, 0.5, 0.05, "tracker_sigma"),
        (f64::NAN, 0.5, 0.05, "tracker_sigma"),
        (0.0, 0.5, 0.05, "tracker_sigma"),
        (2e-5, f64::INFINITY, 0.05, "force_sigma"),
        (2e-5, 0.5, -0.05, "moment_sigma"),
    ];
    for (d, f, m, name) in cases {
        let opts = DiagnoseOptions {
            noise: NoiseAssumption {
                displacement_sigma: d,
                wrench_sigma: [f, f, f, m, m, m],
            },
            noise_known: true,
            ..Default::default()
        };
        let err = diagnose(&chain, &c.dataset, &opts).unwrap_err();
        let text = err.to_string();
        assert!(text.contains(name) && !text.contains('\n'), "{text}");
    }
}

#[test]
fn the_goodness_of_fit_needs_the_true_noise_and_the_lack_of_fit_does_not() {
    // Clean data: with the true noise the χ²/df is ≈ 1 and nothing is flagged; with a noise
    // level stated 3× too small the χ² test rejects (unexplained, in words about the noise),
    // while the lack-of-fit test, which needs no noise level, stays quiet either way.
    let chain = SerialChain::bundled();
    let c = simulate(&chain, &TrueModel::nominal(7), &spec(2)).unwrap();
    let truth = NoiseAssumption::default();
    let known = |scale: f64| DiagnoseOptions {
        noise: NoiseAssumption {
            displacement_sigma: truth.displacement_sigma * scale,
            wrench_sigma: truth.wrench_sigma.map(|s| s * scale),
        },
        noise_known: true,
        ..Default::default()
    };
    let right = diagnose(&chain, &c.dataset, &known(1.0)).unwrap();
    let g = right.verdict.goodness_of_fit.unwrap();
    assert!((0.8..1.2).contains(&g.ratio), "{g:?}");
    assert!(!right.unexplained);
    let wrong = diagnose(&chain, &c.dataset, &known(1.0 / 3.0)).unwrap();
    let g = wrong.verdict.goodness_of_fit.unwrap();
    assert!((7.0..11.0).contains(&g.ratio), "{g:?}");
    assert!(wrong.unexplained);
    assert!(wrong
        .verdict
        .remaining
        .as_deref()
        .unwrap()
        .contains("noise"));
    assert!(wrong.verdict.lack_of_fit.p_value > 0.01);
    let unknown = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
    assert!(unknown.verdict.goodness_of_fit.is_none() && !unknown.unexplained);
}

/// The geometric-non-linearity column's exact response (the diagnosis's own loop) against the
/// testbed's deflected equilibrium, an independent code path, on 32 seeded configurations.
#[test]
fn the_exact_deflection_matches_the_testbeds() {
    let chain = SerialChain::bundled();
    let qs = crate::strategies::random_configurations(&chain, 32, 77);
    let mut rng = ChaCha8Rng::seed_from_u64(78);
    for q in qs.chunks_exact(7) {
        let c: Vec<f64> = (0..21)
            .map(|s| {
                let t = NOMINAL_TORSION[s / 3];
                if s % 3 == 0 {
                    t
                } else {
                    0.3 * t * rng.random::<f64>()
                }
            })
            .collect();
        let w: [f64; 6] = std::array::from_fn(|k| {
            if k < 3 {
                rng.random_range(-80.0..80.0)
            } else {
                rng.random_range(-3.0..3.0)
            }
        });
        let data = vjm::dataset::Dataset::new(
            7,
            q.to_vec(),
            w.to_vec(),
            vec![0.0, 0.0, 1e-3],
            None,
            None,
            None,
        )
        .unwrap();
        let mut b = vjm::diagnose::rows::RowBuilder::new(&chain, [0.0; 6]);
        let mut row = b.empty_row();
        b.row_into(&data, 0, &mut row);
        let d = b.exact_displacement(&row, &c);
        // The lane-wise solve of a batch of one row, against the same truth.
        let mut batch = [b.empty_row()];
        b.rows_into(&data, &[0], Some(&c), &mut batch);
        let dl = batch[0].deflected.expect("deflections below 0.25 rad");
        let truth = TrueModel {
            compliance: c.clone(),
            effects: vec![Effect::GeometricNonlinearity],
        };
        let (e, _) = truth.displacement(&chain, q, &w);
        let lin = vjm::diagnose::candidates::spring_prediction(&row, &c);
        let nonlinear =
            ((e.x - lin[0]).powi(2) + (e.y - lin[1]).powi(2) + (e.z - lin[2]).powi(2)).sqrt();
        for d in [d, dl] {
            let diff = ((d[0] - e.x).powi(2) + (d[1] - e.y).powi(2) + (d[2] - e.z).powi(2)).sqrt();
            assert!(
                nonlinear > 1e-9 && diff <= 1e-9 * nonlinear,
                "diff {diff:e}, non-linear part {nonlinear:e}"
            );
        }
    }
}

/// A batch of rows evaluated lane-wise (`RowBuilder::rows_into`: kinematics, torques, tip frame
/// and the deflected equilibrium) against the same rows one by one (`row_into`, and the scalar
/// `exact_displacement`), on 45 seeded rows (two full batches of 16 and a partial one) with
/// some held out of the batch, as a pass over the training rows does. The nominal compliances
/// put deflections beyond 1e-3 rad, across the scalar code's switch to the library's sine
/// (and up to about 0.02 rad); a hundred times more take a batch past 0.25 rad, which the lane-wise
/// series leaves to the scalar code.
#[test]
fn a_batch_of_rows_equals_the_rows_one_by_one() {
    use vjm::diagnose::rows::{RowBuilder, ROW_BATCH};
    let chain = SerialChain::bundled();
    let n = 45;
    let q = crate::strategies::random_configurations(&chain, n, 91);
    let mut rng = ChaCha8Rng::seed_from_u64(92);
    let w: Vec<f64> = (0..6 * n)
        .map(|k| {
            if k % 6 < 3 {
                rng.random_range(-80.0..80.0)
            } else {
                rng.random_range(-3.0..3.0)
            }
        })
        .collect();
    let data = vjm::dataset::Dataset::new(7, q, w, vec![1e-4; 3 * n], None, None, None).unwrap();
    let c: Vec<f64> = (0..21)
        .map(|s| {
            let t = NOMINAL_TORSION[s / 3];
            if s % 3 == 0 {
                t
            } else if s % 5 == 0 {
                0.0
            } else {
                0.3 * t * rng.random::<f64>()
            }
        })
        .collect();
    let mut b = RowBuilder::new(&chain, [0.5, 0.5, 0.5, 0.05, 0.05, 0.05]);
    let mut one = b.empty_row();
    let mut batch: Vec<_> = (0..ROW_BATCH).map(|_| b.empty_row()).collect();
    let kept: Vec<usize> = (0..n).filter(|i| i % 7 != 3).collect();
    let mut checked = 0;
    let mut largest = 0.0f64;
    for rows in kept.chunks(ROW_BATCH) {
        b.rows_into(&data, rows, Some(&c), &mut batch);
        for (&i, got) in rows.iter().zip(&batch) {
            b.row_into(&data, i, &mut one);
            let close = |a: &[f64], e: &[f64], what: &str| {
                let worst = a
                    .iter()
                    .zip(e)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                let scale = e.iter().fold(1.0f64, |m, y| m.max(y.abs()));
                assert!(worst <= 1e-14 * scale, "row {i}, {what}: {worst:e}");
            };
            assert_eq!(got.q, one.q, "row {i}");
            close(got.jacobian.as_slice(), one.jacobian.as_slice(), "Jacobian");
            close(&got.tau, &one.tau, "torques");
            close(&got.tau_sigma, &one.tau_sigma, "torque noise");
            close(&got.tip, &one.tip, "tip");
            close(
                got.tip_rotation.as_slice(),
                one.tip_rotation.as_slice(),
                "tip rotation",
            );
            assert_eq!(
                (got.wrench, got.displacement),
                (one.wrench, one.displacement)
            );
            let scalar = b.exact_displacement(&one, &c);
            let lanes = got.deflected.expect("deflections below 0.25 rad");
            let lin = vjm::diagnose::candidates::spring_prediction(&one, &c);
            let nonlinear = (0..3)
                .map(|k| (scalar[k] - lin[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            let diff = (0..3)
                .map(|k| (scalar[k] - lanes[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(
                nonlinear > 0.0 && diff <= 1e-10 * nonlinear,
                "row {i}: lane-wise and scalar equilibria differ by {diff:e} (non-linear part {nonlinear:e})"
            );
            largest = largest.max(
                one.tau
                    .iter()
                    .zip(&c)
                    .fold(0.0, |m, (t, c)| m.max((t * c).abs())),
            );
            checked += 1;
        }
    }
    assert_eq!(checked, kept.len());
    assert!(
        largest > 1e-3,
        "the rows stay below the scalar switch: {largest:e} rad"
    );
    // Deflections past the series' range: the batch is left to the scalar code.
    let huge: Vec<f64> = c.iter().map(|v| 100.0 * v).collect();
    b.rows_into(&data, &kept[..ROW_BATCH], Some(&huge), &mut batch);
    assert!(batch.iter().all(|r| r.deflected.is_none()));
    // No compliance, no solve.
    b.rows_into(&data, &kept[..3], None, &mut batch);
    assert!(batch[..3].iter().all(|r| r.deflected.is_none()));
}

/// The backlash candidate's error function against an independent route, the regularised
/// incomplete gamma function (erf(x) = sign(x)·P(½, x²)), and against tabulated values
/// (30-digit values), across the range its argument takes (|τ|/(√2 σ_τ) from 0 to far beyond
/// the point where erf is 1 in double precision). The gamma route is the less accurate of the
/// two (at x = 1.138 it is 1.1e-15 off, `libm` 1e-17: it forms 1 − Q near the switch from
/// its series to its continued fraction), hence 8 ulp of 1 between them.
#[test]
fn backlash_erf_agrees_with_the_incomplete_gamma_function() {
    use vjm::diagnose::candidates::erf;
    for (x, want) in [
        (0.5, 0.520_499_877_813_046_5),
        (1.0, 0.842_700_792_949_714_9),
        (2.0, 0.995_322_265_018_952_7),
        (1.142, 0.893_696_210_553_441),
        (1.138, 0.892_465_639_009_885_3),
    ] {
        assert!((erf(x) - want).abs() <= 2e-16, "erf({x}) = {}", erf(x));
        assert_eq!(erf(-x), -erf(x));
    }
    for k in 0..=4000 {
        let x = k as f64 * 2e-3 - 4.0;
        let via_gamma = (1.0 - vjm::stats::gamma_q(0.5, x * x)).copysign(x);
        assert!(
            (erf(x) - via_gamma).abs() <= 8.0 * f64::EPSILON,
            "x = {x}: {} against {via_gamma}",
            erf(x)
        );
    }
    assert_eq!(erf(0.0), 0.0);
    assert_eq!(erf(40.0), 1.0);
}

/// The baseline's pass makes the compressed design and its verdict's within-pose factor
/// together, and the pre-fit's pass the RMS torsion torques: each equals what a pass of its
/// own makes (to the bit: the same rows, in the same parts, in the same order), on 10⁴ rows
/// so that the passes run in two parts. A different selection is a different factor. A
/// bilinear fit's iterations read their own columns in a pass of their own: the inner
/// products are those of the whole design.
#[test]
fn a_fused_pass_makes_what_separate_passes_make() {
    use std::sync::Arc;
    use stiffness_core::engine::Problem as _;
    use vjm::diagnose::candidates::Linearisation;
    use vjm::diagnose::problem::{VjmProblem, Whitening};
    use vjm::diagnose::NoiseAssumption;

    let (chain, data) = crate::strategies::nominal_panda_campaign(1000, 10, 21);
    let noise = NoiseAssumption::default();
    let labels = data.split(0.25, 0).unwrap();
    let make = |propagate: Vec<f64>, tau_scale: Vec<f64>| {
        VjmProblem::new(
            &chain,
            &data,
            labels.clone(),
            tau_scale,
            Whitening {
                displacement_sigma: noise.displacement_sigma,
                wrench_sigma: noise.wrench_sigma,
                propagate_abs: propagate,
            },
            noise.wrench_sigma,
            stiffness_core::Cancel::new(),
        )
    };
    let compliance: Vec<f64> = (0..21)
        .map(|s| if s % 3 == 0 { 1.5e-4 } else { 0.0 })
        .collect();
    let lin = Linearisation {
        compliance: compliance.clone(),
    };
    // The RMS torques, by hand from the crate's Jacobian, against the pre-fit pass's.
    let mut sq = [0.0; 7];
    let mut n_train = 0;
    for (i, label) in labels.iter().enumerate() {
        if *label != vjm::dataset::SetLabel::Train {
            continue;
        }
        n_train += 1;
        let j = jacobian(&chain, &VirtualJointModel::traditional(7), data.q(i)).unwrap();
        let w = data.wrench(i);
        for (k, s) in sq.iter_mut().enumerate() {
            let tau: f64 = (0..6).map(|r| j[(r, k)] * w[r]).sum();
            *s += tau * tau;
        }
    }
    let pre = make(vec![0.0; 21], Vec::new()).springs_only(Whitening {
        displacement_sigma: noise.displacement_sigma,
        wrench_sigma: [0.0; 6],
        propagate_abs: vec![0.0; 21],
    });
    let rms = pre.compress_with_torque_rms(&lin).unwrap();
    for (k, r) in rms.iter().enumerate() {
        let want = (sq[k] / n_train as f64).sqrt();
        assert!(
            (r - want).abs() <= 1e-12 * want,
            "joint {k}: {r} against {want}"
        );
    }
    // The fused pass against a compress pass and a within-pose pass of their own.
    let alone = make(compliance.clone(), rms.clone());
    let fused = make(compliance.clone(), rms.clone());
    let mut sel: Vec<usize> = (0..21).collect();
    sel.push(alone.observation_column());
    fused.compress_with_within(&lin, &sel).unwrap();
    let c_alone = alone.compress(&lin).unwrap();
    let w_alone = alone.within_pose(&lin, &sel).unwrap();
    let c_fused = fused.compress(&lin).unwrap();
    let w_fused = fused.within_pose(&lin, &sel).unwrap();
    assert_eq!(*c_fused, *c_alone);
    assert_eq!(w_fused.factor, w_alone.factor);
    assert_eq!(w_fused.n_offsets, w_alone.n_offsets);
    assert_eq!(w_fused.n_offsets, 3 * 750, "one offset per training pose");
    // The unprojected factor, made from the projected rows and three rows per pose, has the
    // inner products of the training design's columns, read here from the compressed design.
    let dot = |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(u, v)| u * v).sum() };
    let q = sel.len();
    let plain_col =
        |k: usize| -> Vec<f64> { (0..q).map(|i| w_fused.plain.r()[i * q + k]).collect() };
    let train = c_alone.columns(stiffness_core::engine::RowSet::Train, &sel);
    for a in 0..q {
        for b in 0..q {
            let (ours, want) = (dot(&plain_col(a), &plain_col(b)), dot(&train[a], &train[b]));
            let tol = 1e-11 * dot(&train[a], &train[a]).sqrt() * dot(&train[b], &train[b]).sqrt();
            assert!(
                (ours - want).abs() <= tol,
                "columns {a}, {b}: {ours} against {want}"
            );
        }
    }
    assert_eq!(w_fused.plain.nrows(), 3 * n_train);
    // Asked again, the same factor (cached); asked for other columns, another one.
    assert!(Arc::ptr_eq(
        &fused.within_pose(&lin, &sel).unwrap(),
        &w_fused
    ));
    let fewer = &sel[3..];
    let w_fewer = fused.within_pose(&lin, fewer).unwrap();
    assert_eq!(w_fewer.factor.ncols(), sel.len() - 3);
    // A bilinear fit iterates on its own columns (training rows only): their inner products
    // are the whole design's, here for the torsions and the wrench bias's six columns.
    let bias = alone.columns(vjm::diagnose::problem::Term::Cand(
        vjm::diagnose::candidates::Candidate::WrenchBias,
    ));
    let cols: Vec<usize> = (0..21).step_by(3).chain(bias).collect();
    let (x, y) = alone.model_columns(&lin, &cols).unwrap();
    let full = c_alone.columns(stiffness_core::engine::RowSet::Train, &cols);
    let full_y = c_alone.column(
        stiffness_core::engine::RowSet::Train,
        alone.observation_column(),
    );
    for a in 0..cols.len() {
        let scale = dot(&full[a], &full[a]).sqrt();
        for b in 0..cols.len() {
            let (ours, want) = (dot(&x[a], &x[b]), dot(&full[a], &full[b]));
            let tol = 1e-11 * scale * dot(&full[b], &full[b]).sqrt();
            assert!(
                (ours - want).abs() <= tol,
                "columns {a}, {b}: {ours} against {want}"
            );
        }
        let (ours, want) = (dot(&x[a], &y), dot(&full[a], &full_y));
        assert!((ours - want).abs() <= 1e-11 * scale * dot(&full_y, &full_y).sqrt());
    }
    assert!((dot(&y, &y) - dot(&full_y, &full_y)).abs() <= 1e-11 * dot(&full_y, &full_y));
}

/// A row's kinematics moved to a deflected state in place (`rows::deflect_row`, the sag under
/// gravity in a diagnosis) against the slow, independent deflected chain
/// (`vjm::kinematics::jacobian_deflected`, `forward_kinematics_deflected`) at 20 seeded
/// configurations and deflections of 1e-3 rad (a sag) and 0.2 rad (where a first-order
/// shortcut would be off by 2 %): the same Jacobian and tip to rounding; and θ = 0 leaves the
/// row as it was.
#[test]
fn a_row_deflected_in_place_equals_the_deflected_chain() {
    use vjm::{forward_kinematics_deflected, jacobian_deflected};
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut b = vjm::diagnose::rows::RowBuilder::new(&chain, [0.0; 6]);
    let mut row = b.empty_row();
    for case in 0..20 {
        let q: Vec<f64> = chain
            .joints()
            .iter()
            .map(|j| rng.random_range(j.limits().0 * 0.9..j.limits().1 * 0.9))
            .collect();
        let scale = if case % 2 == 0 { 1e-3 } else { 0.2 };
        let theta: Vec<f64> = (0..21).map(|_| rng.random_range(-scale..scale)).collect();
        let data = vjm::dataset::Dataset::new(
            7,
            q.clone(),
            vec![1.0; 6],
            vec![0.0, 0.0, 1e-3],
            None,
            None,
            None,
        )
        .unwrap();
        b.row_into(&data, 0, &mut row);
        let before = row.jacobian.clone();
        vjm::diagnose::rows::deflect_row(&mut row, &[0.0; 21]);
        assert_eq!(row.jacobian, before, "θ = 0 changes nothing");
        vjm::diagnose::rows::deflect_row(&mut row, &theta);
        let want = jacobian_deflected(&chain, &model, &q, &theta).unwrap();
        let tip = forward_kinematics_deflected(&chain, &model, &q, &theta).unwrap();
        let moved = (&want - &before).amax();
        let off = (&row.jacobian - &want).amax();
        assert!(
            moved > 1e-4 * scale && off <= 1e-13,
            "case {case}: Jacobian off by {off:e} (moved {moved:e})"
        );
        let dt = (nalgebra::Vector3::from(row.tip) - tip.translation.vector).amax();
        assert!(dt <= 1e-13, "case {case}: tip off by {dt:e}");
        let rot = tip.rotation.to_rotation_matrix();
        let dr = (row.tip_rotation - rot.matrix()).amax();
        assert!(dr <= 1e-13, "case {case}: tip rotation off by {dr:e}");
    }
}

/// A campaign measured under gravity with linear torsion springs only: the testbed's poses and
/// loads, displacements from the exact static equilibrium of the deflected chain
/// (`vjm::gravity::deflection_under_gravity`, loaded − unloaded, both under the weight: an
/// independent code path from the diagnosis' linearisation) plus seeded 10 µm tracker noise.
fn campaign_under_gravity(seed: u64) -> vjm::dataset::Dataset<'static> {
    use rand_distr::{Distribution, Normal};
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let base = simulate(
        &chain,
        &TrueModel::nominal(7),
        &CampaignSpec {
            noise: false,
            ..spec(seed)
        },
    )
    .unwrap();
    let compliance = TrueModel::nominal(7).compliance;
    let g = vjm::gravity::Gravity::default();
    let noise = Normal::new(0.0, 10e-6).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
    let data = &base.dataset;
    let mut d = Vec::with_capacity(3 * data.len());
    for i in 0..data.len() {
        let w = data.wrench(i);
        let x = vjm::gravity::deflection_under_gravity(
            &chain,
            &model,
            &compliance,
            data.q(i),
            &w,
            &g,
            None,
        )
        .unwrap();
        d.extend((0..3).map(|k| x[k] + noise.sample(&mut rng)));
    }
    let pose: Vec<i64> = (0..data.len()).map(|i| data.pose(i).unwrap()).collect();
    let set: Vec<_> = (0..data.len()).map(|i| data.set(i).unwrap()).collect();
    vjm::dataset::Dataset::new(
        7,
        data.q_flat().to_vec(),
        data.wrench_flat().to_vec(),
        d,
        None,
        Some(pose),
        Some(set),
    )
    .unwrap()
}

/// Clean springs measured under gravity: diagnosed under the same gravity, nothing is named
/// but the load's geometric non-linearity (which the exact equilibrium really has) and no
/// structure remains, in at least 9 of 10 seeds; diagnosed weightless, the weight's stiffness
/// and sag are mistaken for effects or leave structure in most seeds, so the gravity model is
/// what makes the difference. The noise level is given (the χ² test is part of the verdict).
#[test]
fn clean_springs_under_gravity_raise_no_alarm_when_gravity_is_modelled() {
    let chain = SerialChain::bundled();
    let (mut quiet_gravity, mut quiet_weightless) = (0, 0);
    let mut seen = Vec::new();
    for seed in 0..10 {
        let data = campaign_under_gravity(seed);
        for (gravity, quiet) in [
            (Some(vjm::gravity::Gravity::default()), &mut quiet_gravity),
            (None, &mut quiet_weightless),
        ] {
            // The noise is known (10 µm, exact wrenches): the verdict adds the χ² test.
            let opts = DiagnoseOptions {
                gravity,
                per_row: false,
                noise: NoiseAssumption {
                    displacement_sigma: 10e-6,
                    wrench_sigma: [0.0; 6],
                },
                noise_known: true,
                ..Default::default()
            };
            let d = diagnose(&chain, &data, &opts).unwrap();
            let alarm = d.unexplained
                || d.findings
                    .iter()
                    .any(|f| f.effect != "geometric_nonlinearity");
            if !alarm {
                *quiet += 1;
            } else if gravity.is_some() {
                seen.push((seed, describe(&d)));
            }
        }
    }
    assert!(quiet_gravity >= 9, "alarms under gravity: {seen:?}");
    assert!(
        quiet_weightless <= 5,
        "weightless diagnosis quiet in {quiet_weightless} of 10: the test would not see gravity missing"
    );
}

/// Two findings that interact (issue 23): a wrench bias (whose column `−J C Jᵀ β` depends on
/// every compliance) and a tilt hidden together, at the tracker noise of the default testbed
/// (15 µm) and at 1 µm. Both are named (as a finding or an alias) and nothing is left
/// `unexplained` on every one of 20 seeds. Two mechanisms make it so: the bias' column is
/// evaluated at compliances that contain the tilt (before: `unexplained` on 6 and 13 of 20
/// seeds, per-pose offsets `J ΔC Jᵀ β` remaining), and the selection's exchange step
/// (`stiffness_core::engine`): on seed 0 at 15 µm the hidden J3x tilt was first accepted as its
/// alias J4x, which fits a little better before the bias is in the model; once the bias was in,
/// J3x fitted better but stayed out, a spurious J4y tilt (p = 1e-9) was accepted to make up the
/// difference and a lack of fit remained. The exchange swaps J4x for J3x after the bias is
/// accepted. Measured on seeds 0..100 (docs/diagnose.md §3.5, step 6): `unexplained` on 2 and 1 of 100
/// with the exchange, 4 and 3 without.
#[test]
fn a_bias_and_a_tilt_together_are_both_named_and_nothing_remains() {
    let chain = SerialChain::bundled();
    for mpe in [15e-6, 1e-6] {
        let mut unexplained = Vec::new();
        for seed in 0..20 {
            let truth = TrueModel::nominal(7)
                .with_effect(Effect::WrenchBias {
                    bias: [3.0, -2.0, 4.0, 0.2, -0.1, 0.15],
                })
                .with_effect(Effect::JointTilt {
                    joint: 2,
                    axis: SpringAxis::X,
                    compliance: 6e-5,
                });
            let mut s = spec(seed);
            s.tracker.mpe_const = mpe;
            s.tracker.mpe_per_m = 0.4 * mpe;
            let c = simulate(&chain, &truth, &s).unwrap();
            let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
            assert!(
                named(&d, "wrench_bias", None, None) && named(&d, "joint_tilt", Some(3), Some("x")),
                "tracker {mpe:e} m, seed {seed}: {}",
                describe(&d)
            );
            if d.unexplained {
                let blocks: Vec<String> = d
                    .verdict
                    .blocks
                    .iter()
                    .map(|b| format!("{} p={:.1e}", b.block, b.f_test.p_value))
                    .collect();
                unexplained.push((
                    seed,
                    describe(&d),
                    d.verdict.lack_of_fit.p_value,
                    d.verdict.alpha,
                    blocks,
                ));
            }
        }
        assert!(
            unexplained.is_empty(),
            "tracker {mpe:e} m: unexplained on {unexplained:?}"
        );
    }
}

/// A hardening gear preloaded by the weight (the testbed under gravity: the shoulder's gear
/// carries the arm, ≈ 45 N·m on the Panda, beyond its first knee): diagnosed under the same
/// gravity it is named at its joint, and its extended model predicts the held-out poses
/// better than the baseline, on at least 9 of 10 seeds (measured 10). Weightless, the
/// candidate's knots sit about the wrong torque (the load's alone): named on 1 of 10.
#[test]
fn a_gear_preloaded_by_gravity_is_named_when_gravity_is_modelled() {
    let chain = SerialChain::bundled();
    let g = vjm::gravity::Gravity::default();
    let truth = TrueModel::nominal(7).with_effect(Effect::TorsionNonlinear {
        joint: 1,
        spring: HarmonicDriveSpring::stiffening(1e-4, 2.4, 30.0, 70.0),
    });
    let (mut named_g, mut named_w, mut better) = (0, 0, 0);
    let mut misses = Vec::new();
    for seed in 0..10 {
        let s = CampaignSpec {
            gravity: Some(g),
            ..spec(seed)
        };
        let c = simulate(&chain, &truth, &s).unwrap();
        for gravity in [Some(g), None] {
            let opts = DiagnoseOptions {
                gravity,
                per_row: false,
                ..Default::default()
            };
            let d = diagnose(&chain, &c.dataset, &opts).unwrap();
            let hit = named(&d, "joint_torsion_nonlinear", Some(2), None);
            if gravity.is_some() {
                named_g += usize::from(hit);
                better +=
                    usize::from(d.extended.test_mean_rel_error < d.baseline.test_mean_rel_error);
                if !hit {
                    misses.push((seed, describe(&d)));
                }
            } else {
                named_w += usize::from(hit);
            }
        }
    }
    assert!(named_g >= 9 && better >= 9, "{misses:?}");
    assert!(
        named_w <= 3,
        "weightless named it on {named_w} of 10 (measured 1 when written)"
    );
}

/// The verdict's block `name` of a diagnosis.
fn block<'d>(
    d: &'d vjm::diagnose::report::Diagnosis,
    name: &str,
) -> &'d vjm::diagnose::report::BlockTest {
    d.verdict
        .blocks
        .iter()
        .find(|b| b.block == name)
        .unwrap_or_else(|| panic!("the verdict tests the {name} block"))
}

/// The `pose_compliance` block of a diagnosis.
fn pose_compliance(d: &vjm::diagnose::report::Diagnosis) -> &vjm::diagnose::report::BlockTest {
    block(d, vjm::diagnose::POSE_COMPLIANCE)
}

/// The `angle_compliance` block of a diagnosis.
fn angle_compliance(d: &vjm::diagnose::report::Diagnosis) -> &vjm::diagnose::report::BlockTest {
    block(d, "angle_compliance")
}

/// Diagnosis options with the testbed's default noise, stated (`given`) or assumed.
fn noise_options(given: bool) -> DiagnoseOptions {
    DiagnoseOptions {
        per_row: false,
        noise_known: given,
        ..Default::default()
    }
}

/// The diagnoses, the noise level not given, of `truth` simulated on the bundled Panda with
/// each of `specs`.
fn diagnoses_not_given<'a>(
    truth: &'a TrueModel,
    specs: impl IntoIterator<Item = CampaignSpec> + 'a,
) -> impl Iterator<Item = vjm::diagnose::report::Diagnosis> + 'a {
    let chain = SerialChain::bundled();
    specs.into_iter().map(move |spec| {
        let c = simulate(&chain, truth, &spec).unwrap();
        diagnose(&chain, &c.dataset, &noise_options(false)).unwrap()
    })
}

/// Over `seeds` campaigns of a Panda whose torsion at `joint` (0-based) has compliance
/// c·(1 + amplitude·sin q), with the testbed's default noise, its level `given` or not:
/// runs `unexplained`, runs with the `pose_compliance` block's p below 0.01, and with the
/// `angle_compliance` block's.
fn angle_dependent_rates(joint: usize, amplitude: f64, seeds: u64, given: bool) -> (u64, u64, u64) {
    let chain = SerialChain::bundled();
    let truth =
        TrueModel::nominal(7).with_effect(Effect::TorsionAngleDependent { joint, amplitude });
    let (mut flagged, mut pose_block, mut angle_block) = (0, 0, 0);
    for seed in 0..seeds {
        let c = simulate(&chain, &truth, &spec(3000 + seed)).unwrap();
        let d = diagnose(&chain, &c.dataset, &noise_options(given)).unwrap();
        let b = pose_compliance(&d);
        let a = angle_compliance(&d);
        flagged += u64::from(d.unexplained);
        pose_block += u64::from(b.f_test.p_value < 0.01);
        angle_block += u64::from(a.wild_cluster_p_value.unwrap_or(a.f_test.p_value) < 0.01);
        // When a block with a test of its own decided, the words name the more significant
        // one (not a descriptive block with a smaller p); the angle block decides on its F
        // test when the noise level is given, on its wild cluster bootstrap when not.
        let angle_p = a.wild_cluster_p_value.unwrap_or(a.f_test.p_value);
        assert_eq!(a.wild_cluster_p_value.is_some(), !given);
        let (own, own_p) = if angle_p < b.f_test.p_value {
            (a, angle_p)
        } else {
            (b, b.f_test.p_value)
        };
        if d.unexplained && own_p < d.verdict.lack_of_fit.p_value {
            let words = d.verdict.remaining.clone().unwrap_or_default();
            assert!(
                words.contains(&format!("{} block", own.block)),
                "seed {}: {words}",
                3000 + seed
            );
        }
        println!(
            "J{} ±{:.0} % seed {} given {given}: unexplained {} pose_compliance p {:.1e} \
             (F {:.2}, {} / {}), angle_compliance p {:.1e} (F {:.2}, {} / {}), lack_of_fit p \
             {:.1e}, {}; {:?}",
            joint + 1,
            100.0 * amplitude,
            3000 + seed,
            d.unexplained,
            b.f_test.p_value,
            b.f_test.f,
            b.f_test.df_num,
            b.f_test.df_den,
            a.f_test.p_value,
            a.f_test.f,
            a.f_test.df_num,
            a.f_test.df_den,
            d.verdict.lack_of_fit.p_value,
            describe(&d),
            d.verdict.remaining
        );
    }
    (flagged, pose_block, angle_block)
}

/// A gear whose compliance varies ±40 % with its angle (joint 2, joint 4) is outside the
/// catalogue; with the noise level not given it is flagged `unexplained` (before the
/// `pose_compliance` block: `unexplained: false`, no block saw it; with it 20/20 at both
/// joints). At ±20 % the per-pose block, spending n columns per pose, misses some of the
/// wrist-side gear (its p below 0.01 in 16/20 at J4); the `angle_compliance` block (2n
/// columns: each torsion column times sin q_j, cos q_j) sees all of it, on its F test when
/// the noise level is given and on its wild cluster bootstrap when not (measured 20/20
/// `unexplained` at both joints either way; J4 not given was 12/20 while the block decided
/// only when given).
#[test]
fn angle_dependent_torsion_is_unexplained_through_the_compliance_blocks() {
    for joint in [1, 3] {
        let (flagged, pose_block, angle_block) = angle_dependent_rates(joint, 0.4, 20, false);
        println!(
            "J{} ±40 %: unexplained {flagged}/20, p < 0.01: pose_compliance {pose_block}/20, \
             angle_compliance {angle_block}/20",
            joint + 1
        );
        assert!(
            flagged >= 18 && pose_block >= 18 && angle_block >= 18,
            "J{}: {flagged}, {pose_block}, {angle_block}",
            joint + 1
        );
    }
    for (joint, given, min_flagged, min_angle) in [
        (1, false, 19, 19),
        (3, false, 19, 19),
        (1, true, 19, 19),
        (3, true, 19, 19),
    ] {
        let (flagged, pose_block, angle_block) = angle_dependent_rates(joint, 0.2, 20, given);
        println!(
            "J{} ±20 % given {given}: unexplained {flagged}/20, p < 0.01: pose_compliance \
             {pose_block}/20, angle_compliance {angle_block}/20",
            joint + 1
        );
        assert!(
            flagged >= min_flagged && angle_block >= min_angle,
            "J{} ±20 % given {given}: {flagged}, {pose_block}, {angle_block}",
            joint + 1
        );
    }
}

/// Clean nominal campaigns, the noise level given or not: the verdict's own-block tests
/// (`pose_compliance`, and `angle_compliance` on its F test when the noise is given, on its
/// wild cluster bootstrap when not) keep the rate of
/// `unexplained` at the verdict's level, 1 % (measured 0/100 with the per-pose block alone;
/// over 1000 seeds 0 `unexplained`, its p below 0.05 in 3.3 % and below 0.5 in 46 %), and
/// both blocks' p-values are calibrated at the testbed's default noise: under the null each is
/// uniform, so below 0.5 in 50 ± 15 of 100 and below 0.05 in at most 12.
#[test]
fn clean_data_are_rarely_unexplained_with_the_compliance_blocks() {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7);
    for given in [false, true] {
        let (mut flagged, mut block, mut finding) = (0, 0, 0);
        let mut ps = Vec::new();
        let mut angle_ps = Vec::new();
        for seed in 0..100u64 {
            let c = simulate(&chain, &truth, &spec(5000 + seed)).unwrap();
            let d = diagnose(&chain, &c.dataset, &noise_options(given)).unwrap();
            flagged += u64::from(d.unexplained);
            finding += u64::from(!d.findings.is_empty());
            let p = pose_compliance(&d).f_test.p_value;
            let a = angle_compliance(&d);
            // The p the block decides on: the wild cluster bootstrap's when not given.
            assert_eq!(a.wild_cluster_p_value.is_some(), !given);
            let pa = a.wild_cluster_p_value.unwrap_or(a.f_test.p_value);
            block += u64::from(p.min(pa) <= d.verdict.alpha);
            ps.push(p);
            angle_ps.push(pa);
            if d.unexplained || !d.findings.is_empty() {
                println!(
                    "given {given} seed {}: {} {:?}",
                    5000 + seed,
                    describe(&d),
                    d.verdict.remaining
                );
            }
        }
        let below = |ps: &[f64], x: f64| ps.iter().filter(|p| **p < x).count();
        println!(
            "clean, given {given}: unexplained {flagged}/100, an own block rejects {block}/100, \
             a finding {finding}/100; pose_compliance p below 0.05: {}, 0.1: {}, 0.5: {}; \
             angle_compliance p below 0.05: {}, 0.1: {}, 0.5: {}",
            below(&ps, 0.05),
            below(&ps, 0.1),
            below(&ps, 0.5),
            below(&angle_ps, 0.05),
            below(&angle_ps, 0.1),
            below(&angle_ps, 0.5)
        );
        assert!(flagged <= 2, "given {given}: {flagged} of 100 unexplained");
        for (name, ps) in [("pose_compliance", &ps), ("angle_compliance", &angle_ps)] {
            let half = below(ps, 0.5);
            assert!(
                (35..=65).contains(&half),
                "given {given}, {name}: {half} of 100 below 0.5"
            );
            assert!(
                below(ps, 0.05) <= 12,
                "given {given}, {name}: {} of 100 below 0.05",
                below(ps, 0.05)
            );
        }
    }
}

/// The `pose_compliance` projection (per run of a pose's rows, its offsets and its own scale of
/// every joint's torsion response projected out by Gram–Schmidt on the run's local columns)
/// against a dense least-squares fit with those per-pose columns written out explicitly and a
/// rank read from an SVD, on six poses of which one has a single wrench (its 3 rows carry its
/// offsets only) and one has two (6 rows: offsets and three torsion scales).
#[test]
fn the_pose_compliance_projection_equals_explicit_per_pose_columns() {
    use nalgebra::{DMatrix, DVector, Vector3};
    use stiffness_core::engine::verdict::factor_sse;
    use stiffness_core::engine::Problem as _;
    use vjm::diagnose::candidates::Linearisation;
    use vjm::diagnose::problem::{Term, VjmProblem, Whitening};

    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::TorsionAngleDependent {
        joint: 1,
        amplitude: 0.4,
    });
    let s = CampaignSpec {
        n_poses: 6,
        wrenches_per_pose: 6,
        ..spec(17)
    };
    let full = simulate(&chain, &truth, &s).unwrap().dataset;
    // Keep 6, 1, 2, 6, 6, 6 wrenches of the six poses.
    let keep_per_pose = [6usize, 1, 2, 6, 6, 6];
    let groups = full.pose_groups();
    let mut seen = [0usize; 6];
    let rows: Vec<usize> = (0..full.len())
        .filter(|&i| {
            let g = groups[i];
            seen[g] += 1;
            seen[g] <= keep_per_pose[g]
        })
        .collect();
    let flat =
        |f: &dyn Fn(usize) -> Vec<f64>| -> Vec<f64> { rows.iter().flat_map(|&i| f(i)).collect() };
    let data = vjm::dataset::Dataset::new(
        7,
        flat(&|i| full.q(i).to_vec()),
        flat(&|i| full.wrench(i).to_vec()),
        flat(&|i| full.displacement(i).to_vec()),
        None,
        Some(rows.iter().map(|&i| groups[i] as i64).collect()),
        None,
    )
    .unwrap();
    let noise = NoiseAssumption::default();
    let compliance: Vec<f64> = (0..21)
        .map(|s| {
            if s % 3 == 0 {
                NOMINAL_TORSION[s / 3]
            } else {
                0.0
            }
        })
        .collect();
    let problem = VjmProblem::new(
        &chain,
        &data,
        vec![vjm::dataset::SetLabel::Train; data.len()],
        vec![1.0; 7],
        Whitening {
            displacement_sigma: noise.displacement_sigma,
            wrench_sigma: noise.wrench_sigma,
            propagate_abs: compliance.clone(),
        },
        noise.wrench_sigma,
        stiffness_core::Cancel::new(),
    );
    let lin = Linearisation { compliance };
    let y = problem.observation_column();
    let mut sel: Vec<usize> = (0..21).collect();
    sel.push(y);
    let within = problem.within_pose(&lin, &sel).unwrap();

    // The dense design: the 21 springs, then per pose 3 offsets and 7 torsion columns.
    let pose_of = data.pose_groups();
    let n_rows = 3 * data.len();
    let n_local_cols = 6 * 10;
    let mut x = DMatrix::<f64>::zeros(n_rows, 21 + n_local_cols);
    let mut yv = DVector::<f64>::zeros(n_rows);
    let springs: Vec<Term> = (0..21).map(Term::Spring).collect();
    let want = problem.mask(&springs);
    problem
        .for_each_row(&lin, Some(&want), |i, _, w, _, cols| {
            let wh = |v: &[f64; 3]| w * Vector3::new(v[0], v[1], v[2]);
            let g = pose_of[i];
            let yw = wh(&cols[y]);
            for r in 0..3 {
                yv[3 * i + r] = yw[r];
                for s in 0..21 {
                    x[(3 * i + r, s)] = wh(&cols[s])[r];
                }
                for k in 0..3 {
                    x[(3 * i + r, 21 + 10 * g + k)] = w[(r, k)];
                }
                for j in 0..7 {
                    x[(3 * i + r, 21 + 10 * g + 3 + j)] = wh(&cols[3 * j])[r];
                }
            }
        })
        .unwrap();
    // Least squares by SVD on unit-norm columns (a column of rounding — J7's torsion, whose
    // axis passes through the tip point — left out), rank at 1e-9 of the largest singular value.
    let dense = |cols: &[usize]| -> (f64, usize) {
        let largest = cols.iter().map(|&c| x.column(c).norm()).fold(0.0, f64::max);
        let kept: Vec<usize> = cols
            .iter()
            .copied()
            .filter(|&c| x.column(c).norm() > 1e-10 * largest)
            .collect();
        let mut a = DMatrix::<f64>::zeros(n_rows, kept.len());
        for (k, &c) in kept.iter().enumerate() {
            let col = x.column(c);
            a.set_column(k, &(col / col.norm()));
        }
        let svd = a.clone().svd(true, true);
        let smax = svd.singular_values.max();
        let rank = svd
            .singular_values
            .iter()
            .filter(|s| **s > 1e-9 * smax)
            .count();
        let beta = svd.solve(&yv, 1e-9 * smax).unwrap();
        ((&yv - &a * beta).norm_squared(), rank)
    };
    let local: Vec<usize> = (21..21 + n_local_cols).collect();
    let (_, local_rank) = dense(&local);
    assert_eq!(within.n_local, local_rank);
    // 3 + 6 torsions (J7's is zero) on a full pose, offsets only on one wrench, 6 on two.
    assert_eq!(within.n_local, 9 + 3 + 6 + 3 * 9);
    let at = |c: usize| sel.iter().position(|&s| s == c).unwrap();
    for model in [
        (0..21).step_by(3).collect::<Vec<usize>>(),
        (0..21).collect(),
    ] {
        let model_w: Vec<usize> = model.iter().map(|&c| at(c)).collect();
        let kept = within.pose_compliance_columns(&model_w);
        let (sse, rank_w) = factor_sse(&within.pose_compliance, &kept, at(y));
        let cols: Vec<usize> = model.iter().copied().chain(local.iter().copied()).collect();
        let (sse_dense, rank_dense) = dense(&cols);
        assert_eq!(rank_w + within.n_local, rank_dense, "model {model:?}");
        assert!(
            rank_dense + 10 <= n_rows,
            "residual degrees of freedom left to compare"
        );
        assert!(
            (sse - sse_dense).abs() <= 1e-8 * sse_dense,
            "model {model:?}: {sse} against {sse_dense}"
        );
    }
}

#[test]
fn a_compliant_link_is_named_as_a_link_translation_at_its_link_or_an_alias() {
    // Issue 23: a translational compliance in a link, hidden in the truth, on ten seeds each,
    // the noise given and not. On the Panda the link after joint 4 along its z is the link
    // after joint 3 along its y (joint 4 turns about that line): an exact alias, which the
    // finding must list when it names the other.
    let chain = SerialChain::bundled();
    let cases = [(3, SpringAxis::Z, 4e-6), (1, SpringAxis::X, 2e-6)];
    for (joint, axis, compliance) in cases {
        let truth = TrueModel::nominal(7).with_effect(Effect::LinkTranslation {
            joint,
            axis,
            compliance,
        });
        let want = (joint + 1, axis.to_string());
        let mut named = 0;
        let mut clean_verdict = 0;
        let mut single = 0;
        for seed in 0..10 {
            let c = simulate(&chain, &truth, &spec(300 + seed)).unwrap();
            for noise_known in [false, true] {
                let opts = DiagnoseOptions {
                    noise_known,
                    ..Default::default()
                };
                let d = diagnose(&chain, &c.dataset, &opts).unwrap();
                // Named, or among a finding's aliases (the study's "named or alias"): on some
                // seeds a tilt at joint 3 is named with this translation as its alias.
                let is_truth = |effect: &str, j: Option<usize>, a: &Option<String>| {
                    effect == "link_translation"
                        && (j, a.clone()) == (Some(want.0), Some(want.1.clone()))
                };
                let hit = d.findings.iter().any(|f| {
                    is_truth(f.effect, f.joint, &f.axis)
                        || f.aliases
                            .iter()
                            .any(|a| is_truth(a.effect, a.joint, &a.axis))
                });
                named += hit as usize;
                clean_verdict += !d.unexplained as usize;
                single += (d.findings.len() == 1) as usize;
                if !hit || d.unexplained || d.findings.len() != 1 {
                    println!("J{}{axis} seed {seed}: {}", joint + 1, describe(&d));
                }
                assert!(d.gain > 0.05, "gain {}", d.gain);
            }
        }
        println!(
            "link after J{}{axis}: named (or alias) in {named}/20, nothing unexplained in \
             {clean_verdict}/20, one finding in {single}/20",
            joint + 1
        );
        assert!(named >= 19, "{named}/20");
        assert!(clean_verdict >= 18, "{clean_verdict}/20");
        assert!(single >= 14, "{single}/20");
    }
}

#[test]
fn design_states_the_wrenches_per_pose_the_pose_compliance_block_needs() {
    // 3W equations per pose against 3 offsets and n torsion scales: W = ⌊(3 + n)/3⌋ + 1.
    assert_eq!(vjm::pose_compliance_wrenches(7), 4);
    assert_eq!(vjm::pose_compliance_wrenches(6), 4);
    assert_eq!(vjm::pose_compliance_wrenches(2), 2);
    // Checked against the diagnosis itself: on the Panda the block has degrees of freedom
    // (its F test a finite p) with 4 wrenches per pose and none with 3.
    let chain = SerialChain::bundled();
    for (w, testable) in [(3, false), (4, true)] {
        let spec = CampaignSpec {
            seed: 77,
            wrenches_per_pose: w,
            ..Default::default()
        };
        let c = simulate(&chain, &TrueModel::nominal(7), &spec).unwrap();
        let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
        let b = pose_compliance(&d);
        println!("W = {w}: pose_compliance {:?}", b.f_test);
        assert_eq!(
            b.f_test.df_num > 0.0 && b.f_test.df_den > 0.0,
            testable,
            "W = {w}"
        );
    }
}

/// On a tracker of 3 µm with the noise level not given (rows whitened as if 21 µm), the
/// whitened residuals' variance follows the force sensor's noise through each pose's
/// Jacobian, and the angle block's F test rejects clean campaigns far above its level; the
/// p it decides on, a wild cluster bootstrap of its cluster-robust Wald statistic, stays
/// calibrated (measured on 300 seeds: F below 0.01 in 22 and below 0.05 in 54; the bootstrap
/// 4 and 26, below 0.5 in 164), and a gear varying ±10 % with its angle at joint 2 is still
/// `unexplained` (measured 19/20; 9/20 while the block decided only when the noise was given).
#[test]
fn without_the_noise_level_the_angle_block_decides_on_a_wild_cluster_bootstrap() {
    let chain = SerialChain::bundled();
    let with_tracker = |seed: u64| {
        let mut s = spec(seed);
        s.tracker = vjm::testbed::TrackerNoise::isotropic(3e-6);
        s
    };
    let (mut f_05, mut w_01, mut w_05, mut w_50, mut flagged) = (0, 0, 0, 0, 0);
    for seed in 0..200 {
        let c = simulate(&chain, &TrueModel::nominal(7), &with_tracker(10_000 + seed)).unwrap();
        let d = diagnose(&chain, &c.dataset, &noise_options(false)).unwrap();
        let a = angle_compliance(&d);
        let w = a
            .wild_cluster_p_value
            .expect("not given: the bootstrap decides");
        f_05 += u64::from(a.f_test.p_value < 0.05);
        w_01 += u64::from(w < 0.01);
        w_05 += u64::from(w < 0.05);
        w_50 += u64::from(w < 0.5);
        flagged += u64::from(d.unexplained);
    }
    println!(
        "clean, 3 um, not given: F p < 0.05 in {f_05}/200; bootstrap p < 0.01 {w_01}, < 0.05 \
         {w_05}, < 0.5 {w_50}; unexplained {flagged}"
    );
    assert!(
        f_05 >= 25,
        "the F test was expected to be liberal here: {f_05}/200"
    );
    assert!(w_01 <= 6 && w_05 <= 20, "bootstrap: {w_01}, {w_05} of 200");
    assert!(
        (75..=125).contains(&w_50),
        "bootstrap: {w_50} of 200 below 0.5"
    );
    assert!(flagged <= 2, "{flagged} of 200 unexplained");

    let truth = TrueModel::nominal(7).with_effect(Effect::TorsionAngleDependent {
        joint: 1,
        amplitude: 0.1,
    });
    let found = diagnoses_not_given(&truth, (0..20).map(|seed| spec(3000 + seed)))
        .filter(|d| d.unexplained)
        .count();
    println!("J2 ±10 %, not given: unexplained {found}/20");
    assert!(found >= 16, "J2 ±10 %, not given: unexplained {found}/20");
}

/// Beyond `MAX_CLUSTERS` rows the bootstrap's clusters are runs of consecutive rows (here 1000
/// rows, 100 poses × 10 wrenches, ~3 training rows per cluster). The grouping keeps the test
/// calibrated on clean campaigns (release build, 200 seeds of 400 rows and 100 of 2000 rows:
/// p below 0.01 in 3 and 2, below 0.05 in 12 and 8, below 0.5 in 110 and 51) and able to see a
/// gear varying ±5 % with its angle at joint 2, where its λ is ~6 × that of the default
/// campaign's 160 rows.
#[test]
fn beyond_max_clusters_the_bootstrap_groups_consecutive_rows() {
    use stiffness_core::engine::wild_cluster::MAX_CLUSTERS;
    let big = |seed: u64| CampaignSpec {
        n_poses: 100,
        wrenches_per_pose: 10,
        seed,
        ..Default::default()
    };
    assert!(big(0).n_poses * big(0).wrenches_per_pose > 3 * MAX_CLUSTERS);
    let (mut w_01, mut w_50) = (0, 0);
    for d in diagnoses_not_given(&TrueModel::nominal(7), (0..40).map(|s| big(40_000 + s))) {
        let w = angle_compliance(&d)
            .wild_cluster_p_value
            .expect("not given: the bootstrap decides");
        w_01 += u64::from(w < 0.01);
        w_50 += u64::from(w < 0.5);
    }
    println!("clean, 1000 rows, not given: bootstrap p < 0.01 {w_01}, < 0.5 {w_50} of 40");
    assert!(w_01 <= 3, "bootstrap: {w_01} of 40 below 0.01");
    assert!(
        (10..=30).contains(&w_50),
        "bootstrap: {w_50} of 40 below 0.5"
    );

    let truth = TrueModel::nominal(7).with_effect(Effect::TorsionAngleDependent {
        joint: 1,
        amplitude: 0.05,
    });
    let found = diagnoses_not_given(&truth, (0..10).map(|s| big(41_000 + s)))
        .filter(|d| {
            let w = angle_compliance(d).wild_cluster_p_value.expect("decides");
            d.unexplained && w < 1e-3
        })
        .count();
    println!("J2 ±5 %, 1000 rows, not given: unexplained with bootstrap p < 1e-3 in {found}/10");
    assert!(found >= 9, "J2 ±5 %, 1000 rows: {found}/10");
}
