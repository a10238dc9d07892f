//! The CSJM diagnosis on the shared engine (issue 11): the whitened design and the
//! coefficients' covariance checked against an independent dense fit rebuilt from the
//! reported rows, progress and cancellation, the engine's options and its robust test.
//!
//! All randomness is seeded (campaign seeds below; the split seed is the options' default).

use nalgebra::{DMatrix, DVector, Vector3};
use so3_stiffness::diagnose::{
    diagnose, diagnose_monitored, diagnose_with_progress, DiagnoseError, DiagnoseOptions, Evidence,
};
use so3_stiffness::testbed::{simulate_campaign, CsjmCampaignSpec, CsjmEffects};
use stiffness_core::{Cancel, Monitor, Progress};

fn campaign(effects: CsjmEffects, seed: u64) -> so3_stiffness::identification::CsjmDataset {
    simulate_campaign(&CsjmCampaignSpec::new(effects, seed))
        .expect("campaign")
        .dataset
}

#[test]
fn baseline_estimates_noise_and_standard_errors_match_a_dense_weighted_fit_of_the_rows() {
    let data = campaign(CsjmEffects::friction(1.0), 9100);
    let d = diagnose(&data, &DiagnoseOptions::default()).unwrap();
    let v: serde_json::Value = serde_json::from_str(&d.to_json()).unwrap();
    let vec3 = |x: &serde_json::Value| {
        Vector3::from_iterator(x.as_array().unwrap().iter().map(|e| e.as_f64().unwrap()))
    };
    // The training samples: the reference (Δζ = 0, Δτ = 0) and the rows marked `train`.
    let mut train: Vec<(Vector3<f64>, Vector3<f64>)> = vec![(Vector3::zeros(), Vector3::zeros())];
    for r in v["rows"].as_array().unwrap() {
        if r["set"] == "train" {
            train.push((vec3(&r["dzeta"]), vec3(&r["dtau"])));
        }
    }
    assert_eq!(train.len(), d.n_train);
    // Unweighted per-component fit: each component has its own offset and row of K_D, so
    // the noise level of component i is the RMS of its residuals over n − 4 dof.
    let n = train.len();
    let design = DMatrix::from_fn(n, 4, |r, j| if j == 0 { 1.0 } else { train[r].0[j - 1] });
    let mut sigma = [0.0; 3];
    for (i, s) in sigma.iter_mut().enumerate() {
        let y = DVector::from_fn(n, |r, _| train[r].1[i]);
        let beta = (design.transpose() * &design)
            .lu()
            .solve(&(design.transpose() * &y))
            .unwrap();
        *s = ((&y - &design * beta).norm_squared() / (n - 4) as f64).sqrt();
        assert!(
            (*s - d.noise_sigma[i]).abs() <= 1e-9 * *s,
            "σ_{i}: {s} vs {}",
            d.noise_sigma[i]
        );
    }
    // The whitened 12-parameter fit on all 3n observations, and s²(XᵀX)⁻¹.
    let mut x = DMatrix::zeros(3 * n, 12);
    let mut y = DVector::zeros(3 * n);
    for (r, (z, t)) in train.iter().enumerate() {
        for i in 0..3 {
            let w = 1.0 / sigma[i];
            x[(3 * r + i, 4 * i)] = w;
            for j in 0..3 {
                x[(3 * r + i, 4 * i + 1 + j)] = w * z[j];
            }
            y[3 * r + i] = w * t[i];
        }
    }
    let xtx_inv = (x.transpose() * &x).try_inverse().unwrap();
    let beta = &xtx_inv * (x.transpose() * &y);
    let s2 = (&y - &x * &beta).norm_squared() / (3 * n - 12) as f64;
    let labels = |i: usize, j: usize| {
        if j == 0 {
            format!("offset.{}", ["x", "y", "z"][i])
        } else {
            format!("K_D[{i}][{}]", j - 1)
        }
    };
    for i in 0..3 {
        for j in 0..4 {
            let k = 4 * i + j;
            let p = d
                .baseline
                .parameters
                .iter()
                .find(|p| p.label == labels(i, j))
                .unwrap();
            let se = (s2 * xtx_inv[(k, k)]).sqrt();
            let (value, stderr) = (p.value.expect("a value"), p.stderr.expect("a stderr"));
            assert!(
                (value - beta[k]).abs() <= 1e-7 * beta[k].abs().max(se),
                "{}: {value} vs {}",
                p.label,
                beta[k]
            );
            assert!(
                (stderr - se).abs() <= 1e-6 * se,
                "{}: stderr {stderr} vs {se}",
                p.label,
            );
        }
    }
}

#[test]
fn progress_reports_each_stage_and_a_cancel_stops_the_run() {
    let data = campaign(CsjmEffects::friction(2.0), 9200);
    let mut stages = Vec::new();
    let d = diagnose_with_progress(&data, &DiagnoseOptions::default(), &mut |p: Progress| {
        stages.push((p.stage, p.done))
    })
    .unwrap();
    assert!(d.names("cable_hysteresis"));
    assert_eq!(stages.first(), Some(&("baseline", 1)), "{stages:?}");
    assert!(stages.contains(&("selection", 1)), "{stages:?}");
    assert_eq!(stages.last(), Some(&("residuals", 1)), "{stages:?}");

    // Cancelled before the start.
    let cancel = Cancel::new();
    cancel.cancel();
    let err =
        diagnose_monitored(&data, &DiagnoseOptions::default(), &Monitor::new(cancel)).unwrap_err();
    assert!(matches!(err, DiagnoseError::Cancelled(_)), "{err}");
    assert_eq!(err.to_string(), "diagnosis cancelled");

    // Cancelled by the progress sink at its first report.
    let cancel = Cancel::new();
    let token = cancel.clone();
    let sink = move |_: Progress| token.cancel();
    let monitor = Monitor::new(cancel).with_progress(&sink);
    let err = diagnose_monitored(&data, &DiagnoseOptions::default(), &monitor).unwrap_err();
    assert!(matches!(err, DiagnoseError::Cancelled(_)), "{err}");
}

#[test]
fn alias_options_out_of_range_are_refused_by_name() {
    let data = campaign(CsjmEffects::none(), 9300);
    for (cosine, alpha, name) in [
        (0.0, 0.05, "alias_cosine"),
        (1.5, 0.05, "alias_cosine"),
        (f64::NAN, 0.05, "alias_cosine"),
        (0.99, 0.0, "alias_alpha"),
        (0.99, 1.0, "alias_alpha"),
        (0.99, f64::INFINITY, "alias_alpha"),
    ] {
        let mut o = DiagnoseOptions::default();
        o.selection.alias_cosine = cosine;
        o.selection.alias_alpha = alpha;
        let err = diagnose(&data, &o).unwrap_err();
        assert!(
            matches!(err, DiagnoseError::InvalidOption { option, .. } if option == name),
            "{err}"
        );
        assert!(err.to_string().contains(name), "{err}");
    }
}

#[test]
fn the_default_fdr_is_the_shared_engines_and_a_finding_carries_the_robust_test() {
    assert_eq!(DiagnoseOptions::default().selection.fdr, 0.01);
    let d = diagnose(
        &campaign(CsjmEffects::friction(2.0), 9400),
        &DiagnoseOptions::default(),
    )
    .unwrap();
    let f = d
        .findings
        .iter()
        .find(|f| f.effect == "cable_hysteresis")
        .expect("friction of 2 N is named");
    let Evidence::Selection(e) = &f.evidence else {
        panic!("a catalogue finding has selection evidence");
    };
    let e = &e.selection;
    // 9 parameters, clustered by sample: still far beyond chance for 2 N of friction.
    let robust = e.cluster_robust.expect("≥ 3 training samples");
    assert!(robust.p_value < 1e-4, "{robust:?}");
    assert!(e.f_test.p_value < 1e-6, "{:?}", e.f_test);
    assert!(e.heldout_sse_after < e.heldout_sse_before);
}

#[test]
fn an_effect_is_a_finding_or_an_alias_never_both_and_engine_aliases_state_their_test() {
    // Weak unbalanced stiffening with large increments at q = 0.05: the gravity and curvature
    // candidates compete (in seed 9018 `platform_gravity` is accepted first, with the
    // curvature as its alias; the selection before issue 11 also accepted the curvature as a
    // second finding).
    let mut effects = CsjmEffects::none();
    effects.cable_stiffening = [1.0e5, 0.0, 1.0e5, 0.0, 1.0e5, 0.0];
    let mut options = DiagnoseOptions::default();
    options.selection.fdr = 0.05;
    let mut engine_aliases = 0;
    for seed in 9000..9020 {
        let mut spec = CsjmCampaignSpec::new(effects, seed);
        spec.schedule.max_increment = 3.0;
        let data = simulate_campaign(&spec).unwrap().dataset;
        let d = diagnose(&data, &options).unwrap();
        let found = d.defect_effects();
        for f in &d.findings {
            for a in &f.aliases {
                assert!(
                    !found.contains(&a.effect),
                    "seed {seed}: {} is a finding and an alias of {}",
                    a.effect,
                    f.effect
                );
                if a.delta_chi2.is_finite() {
                    engine_aliases += 1;
                    assert!(
                        a.p_finding_given_alias > options.selection.alias_alpha
                            || a.cosine
                                .is_some_and(|c| c >= options.selection.alias_cosine),
                        "seed {seed}: {a:?}"
                    );
                }
            }
        }
    }
    assert!(engine_aliases >= 1, "no alias from the engine in 20 seeds");
}
