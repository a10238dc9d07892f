//! Diagnosis of CSJM campaigns (issue 5, CSJM half): the testbed's effects checked
//! numerically, hidden effects named above their stated detectability thresholds, clean data
//! without findings, the connection term, the JSON contract and bad input.
//!
//! All randomness is seeded (campaign seeds below; the train/test split seed is the options'
//! default).

use nalgebra::{Rotation3, Vector3};
use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator, PointLoad, CABLES};
use so3_stiffness::diagnose::stats::{benjamini_hochberg, chi2_sf, f_sf, t_two_sided};
use so3_stiffness::diagnose::{
    diagnose, diagnose_file, CsjmDiagnosis, DiagnoseError, DiagnoseOptions, CONNECTION_TERM,
};
use so3_stiffness::identification::campaign::{
    prototype_simulator, GravityRecording, MomentNoise, TrackerNoise,
};
use so3_stiffness::identification::{identify, CsjmDataset, CsjmMeasurement, FitOptions};
use so3_stiffness::so3;
use so3_stiffness::testbed::{
    simulate_campaign, CsjmCampaignSpec, CsjmEffects, EffectSimulator, PathState,
};

fn run(spec: &CsjmCampaignSpec) -> CsjmDiagnosis {
    let campaign = simulate_campaign(spec).expect("campaign");
    diagnose(&campaign.dataset, &DiagnoseOptions::default()).expect("diagnosis")
}

fn spec(effects: CsjmEffects, seed: u64, max_increment: f64) -> CsjmCampaignSpec {
    let mut s = CsjmCampaignSpec::new(effects, seed);
    s.schedule.max_increment = max_increment;
    s
}

/// Stiffening on the alternate cables 1, 3, 5 only (one batch of cables or drive springs
/// differs): the quadratic law is not cancelled by an antagonistic partner.
fn unbalanced_stiffening(k2: f64) -> CsjmEffects {
    let mut e = CsjmEffects::none();
    e.cable_stiffening = [k2, 0.0, k2, 0.0, k2, 0.0];
    e
}

// ---------------------------------------------------------------- statistics

#[test]
fn distribution_tails_match_closed_forms() {
    // χ² with 2 dof: P(X > x) = exp(−x/2).
    for x in [0.1, 1.0, 5.0, 20.0] {
        assert!((chi2_sf(x, 2.0) - (-x / 2.0f64).exp()).abs() < 1e-12);
    }
    // F(1, d) is t² with d dof.
    for (t, d) in [(0.5, 5.0), (2.0, 10.0), (3.5, 40.0)] {
        assert!((f_sf(t * t, 1.0, d) - t_two_sided(t, d)).abs() < 1e-10);
    }
    // F(2, ∞)-like: F(2, d2) upper tail = (1 + 2f/d2)^(−d2/2).
    let (f, d2) = (3.0, 30.0);
    assert!((f_sf(f, 2.0, d2) - (1.0 + 2.0 * f / d2).powf(-d2 / 2.0)).abs() < 1e-12);
    // Benjamini–Hochberg, q = 0.05, m = 4: thresholds 0.0125, 0.025, 0.0375, 0.05.
    assert_eq!(
        benjamini_hochberg(&[0.01, 0.035, 0.02, 0.2], 0.05),
        vec![true, true, true, false]
    );
    assert_eq!(
        benjamini_hochberg(&[0.02, 0.04, 0.2], 0.05),
        vec![false, false, false]
    );
}

// ---------------------------------------------------------------- testbed physics

fn prototype_at_pretension() -> CsjmSimulator {
    CsjmSimulator::with_pretension(
        CsjmGeometry::prototype(),
        [5000.0; CABLES],
        [80.0; CABLES],
        &Rotation3::identity(),
    )
    .unwrap()
}

#[test]
fn stiffening_cable_law_tangent_stiffness_matches_finite_differences() {
    let home = Rotation3::identity();
    let k2 = [2.0e5, 0.0, 5.0e5, 1.0e5, 0.0, 3.0e5];
    let sim = prototype_at_pretension()
        .with_cable_stiffening(k2, &home)
        .unwrap();
    // The pre-tension is kept.
    for t in sim.tensions(&home).unwrap() {
        assert!((t - 80.0).abs() < 1e-9, "tension {t}");
    }
    let pose = so3::exp(&Vector3::new(0.03, -0.02, 0.05));
    let tangent = sim.tangent_cable_stiffness(&pose).unwrap();
    // Cable lengths change along a body perturbation as −J δ, so dt_s/dε = −k_t,s (J δ)_s.
    let delta = Vector3::new(0.3, -0.5, 0.8).normalize();
    let h = 1e-6;
    let tp = sim.tensions(&(pose * so3::exp(&(h * delta)))).unwrap();
    let tm = sim.tensions(&(pose * so3::exp(&(-h * delta)))).unwrap();
    let lp = so3_stiffness::csjm::cable_lengths(sim.geometry(), &(pose * so3::exp(&(h * delta))))
        .unwrap();
    let lm = so3_stiffness::csjm::cable_lengths(sim.geometry(), &(pose * so3::exp(&(-h * delta))))
        .unwrap();
    for s in 0..CABLES {
        let fd = (tp[s] - tm[s]) / (lp[s] - lm[s]);
        assert!(
            (fd - tangent[s]).abs() < 1e-6 * tangent[s],
            "cable {}: FD {fd} vs tangent {}",
            s + 1,
            tangent[s]
        );
        // Stiffening cables are stiffer than the linear coefficient where they are stretched.
        if k2[s] > 0.0 {
            assert!(tangent[s] > 5000.0 * 1.01);
        }
    }
}

#[test]
fn stiffening_and_offsets_keep_moment_and_stiffness_consistent_with_the_potential() {
    let home = Rotation3::identity();
    let sim = prototype_at_pretension()
        .with_cable_stiffening([3.0e5, 1.0e5, 0.0, 2.0e5, 4.0e5, 0.0], &home)
        .unwrap()
        .with_tension_offsets([1.5, -1.5, 1.5, 1.5, -1.5, -1.5])
        .unwrap()
        .with_load(PointLoad::prototype_gravity());
    let pose = so3::exp(&Vector3::new(-0.02, 0.04, 0.03));
    let tau = sim.holding_moment(&pose).unwrap();
    let k = sim.stiffness(&pose).unwrap();
    let h = 1e-5;
    for i in 0..3 {
        let mut e = Vector3::zeros();
        e[i] = h;
        // τ_i = L_i Φ (body gradient of the potential).
        let dphi = (sim.potential(&(pose * so3::exp(&e))).unwrap()
            - sim.potential(&(pose * so3::exp(&-e))).unwrap())
            / (2.0 * h);
        assert!(
            (dphi - tau[i]).abs() < 1e-6 * tau.norm().max(1.0),
            "τ_{i}: {dphi} vs {}",
            tau[i]
        );
        // Column i of K_D is the derivative of τ along σ_i.
        let dtau = (sim.holding_moment(&(pose * so3::exp(&e))).unwrap()
            - sim.holding_moment(&(pose * so3::exp(&-e))).unwrap())
            / (2.0 * h);
        let col = k.euclidean.column(i).into_owned();
        assert!(
            (dtau - col).norm() < 1e-5 * k.euclidean.norm(),
            "K_D column {i}: FD {dtau:?} vs {col:?}"
        );
    }
    // And the covariant K is symmetric.
    assert!((k.covariant - k.covariant.transpose()).norm() < 1e-9 * k.covariant.norm());
}

/// Loads the platform from the pre-load up by `step` along x and back, returns the pose
/// difference (rad) between the way up and the way down at the same load, and checks that
/// the elastic moments at the two poses differ by exactly the friction moments `Jᵀ(f∘σ)`.
fn hysteresis_loop_width(friction: f64) -> f64 {
    let cables = prototype_simulator().unwrap();
    let physics = EffectSimulator::new(cables.clone(), [friction; CABLES], None).unwrap();
    let preload = Vector3::new(-0.06, -3.08, 1.07);
    let mid = preload + Vector3::new(0.5, 0.0, 0.0);
    let top = preload + Vector3::new(1.0, 0.0, 0.0);
    let s0 = physics
        .apply(&PathState::at(Rotation3::identity()), &preload)
        .unwrap();
    let up = physics.apply(&s0, &mid).unwrap();
    let top_state = physics.apply(&up, &top).unwrap();
    let down = physics.apply(&top_state, &mid).unwrap();
    // Equilibrium with offsets f σ: τ_elastic(R) − Jᵀ(f∘σ) … in this crate's sign:
    // τ_hold = −Jᵀ T, T = T_elastic + f σ ⇒ τ_elastic(R) = τ + Jᵀ(f σ).
    for state in [&up, &down] {
        let elastic = cables.holding_moment(&state.pose).unwrap();
        let j = so3_stiffness::csjm::jacobian(cables.geometry(), &state.pose).unwrap();
        let offsets = nalgebra::Vector6::from_fn(|s, _| friction * f64::from(state.sliding[s]));
        let expected = mid + j.transpose() * offsets;
        assert!(
            (elastic - expected).norm() < 1e-8,
            "elastic moment {elastic:?} vs τ + Jᵀ(fσ) {expected:?}"
        );
    }
    if friction > 0.0 {
        assert_ne!(
            up.sliding, down.sliding,
            "loading and unloading slide the same way"
        );
    }
    // Independent prediction of the loop width: K_D (ζ_up − ζ_down) ≈ Jᵀ f (σ_up − σ_down),
    // K_D and J from the analytic model at the midpoint of the two poses.
    let width = so3::distance(&up.pose, &down.pose);
    let midpoint = up.pose * so3::exp(&(0.5 * so3::log(&(up.pose.inverse() * down.pose))));
    let k_d = cables.stiffness(&midpoint).unwrap().euclidean;
    let j = so3_stiffness::csjm::jacobian(cables.geometry(), &midpoint).unwrap();
    let dsigma =
        nalgebra::Vector6::from_fn(|s, _| friction * f64::from(up.sliding[s] - down.sliding[s]));
    let predicted = k_d.lu().solve(&(j.transpose() * dsigma)).unwrap().norm();
    assert!(
        (width - predicted).abs() <= 0.05 * predicted + 1e-12,
        "f = {friction} N: loop width {width} rad, predicted {predicted} rad"
    );
    width
}

#[test]
fn hysteresis_loop_width_follows_the_friction_moment() {
    let w0 = hysteresis_loop_width(0.0);
    let w1 = hysteresis_loop_width(0.5);
    let w2 = hysteresis_loop_width(1.0);
    assert!(w0 < 1e-9, "no friction, no loop: {w0}");
    // Friction moment ~ |J| f ~ 0.05 m × 1 N per cable against K ~ 20–30 N·m/rad: mrad loops.
    assert!(w1 > 1e-4, "loop width {w1} rad at f = 0.5 N");
    assert!(w2 > w1, "width(1 N) = {w2} ≤ width(0.5 N) = {w1}");
}

// ---------------------------------------------------------------- diagnosis

#[test]
fn effect_free_campaigns_give_no_defect_finding_in_95_percent_of_40_seeds() {
    let seeds = 40;
    let mut with_defect = Vec::new();
    let mut connection_found = 0;
    let mut lambdas = Vec::new();
    let mut unexplained = 0;
    for seed in 0..seeds {
        let d = run(&spec(CsjmEffects::none(), 1000 + seed, 1.0));
        if !d.defect_effects().is_empty() {
            with_defect.push((seed, d.defect_effects()));
        }
        if d.findings.iter().any(|f| f.effect == CONNECTION_TERM) {
            connection_found += 1;
        }
        lambdas.push(d.connection_term.lambda);
        if d.unexplained {
            unexplained += 1;
        }
        assert!(d.gain.abs() < 1e-12 || !d.defect_effects().is_empty());
    }
    assert!(
        with_defect.len() * 20 <= seeds as usize,
        "defect findings on clean data: {with_defect:?}"
    );
    // Residual-structure tests at p < 0.01 (Bonferroni) rarely fire on clean data.
    assert!(
        unexplained <= 2,
        "unexplained on {unexplained}/40 clean campaigns"
    );
    println!("clean: unexplained on {unexplained}/{seeds}");
    // The seed's pre-load makes K_D measurably asymmetric in (almost) every campaign, and its
    // asymmetry is the Levi-Civita one (λ = 1), not the seed's eq. 48b (λ = 2).
    assert!(
        connection_found >= 38,
        "connection term found in {connection_found}/40"
    );
    let mean = lambdas.iter().sum::<f64>() / lambdas.len() as f64;
    let sd = (lambdas.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / 39.0).sqrt();
    let se = sd / (lambdas.len() as f64).sqrt();
    println!(
        "clean: defect findings in {}/{seeds} seeds {with_defect:?}; connection_term in \
         {connection_found}/{seeds}; mean λ = {mean:.4} ± {se:.4} (sd {sd:.3})",
        with_defect.len()
    );
    assert!(
        (mean - 1.0).abs() < 3.0 * se + 0.02,
        "mean λ = {mean} ± {se}"
    );
    assert!((mean - 2.0).abs() > 10.0 * se, "mean λ = {mean} ± {se}");
}

#[test]
fn cable_friction_of_one_newton_is_named_and_the_extension_gains_on_held_out_rows() {
    // Threshold: f_s ≥ 1 N per cable (80 N pre-tension, 85 increments ≤ 1 N·m).
    let mut gains = Vec::new();
    for seed in 0..10 {
        let d = run(&spec(CsjmEffects::friction(1.0), 2000 + seed, 1.0));
        assert!(
            d.names("cable_hysteresis"),
            "seed {seed}: {:?}",
            d.defect_effects()
        );
        assert!(
            !d.defect_effects().contains(&"platform_gravity"),
            "seed {seed}"
        );
        gains.push(d.gain);
    }
    let mean_gain = gains.iter().sum::<f64>() / gains.len() as f64;
    println!("friction 1 N: held-out gains {gains:.3?}, mean {mean_gain:.3}");
    assert!(
        mean_gain > 0.05,
        "mean held-out gain {mean_gain}, gains {gains:?}"
    );
}

#[test]
fn unbalanced_cable_stiffening_is_named_with_large_increments() {
    // Threshold: k₂ ≥ 3e5 N/m² on cables 1, 3, 5 (tangent stiffness +170 % at 80 N), with
    // increments up to 3 N·m. Balanced stiffening (all six cables) is not detectable: see
    // `balanced_stiffening_leaves_tau_of_dzeta_almost_linear`.
    for seed in 0..8 {
        let d = run(&spec(unbalanced_stiffening(3.0e5), 3000 + seed, 3.0));
        assert!(
            d.names("cable_nonlinearity"),
            "seed {seed}: {:?}",
            d.findings.iter().map(|f| f.effect).collect::<Vec<_>>()
        );
    }
}

#[test]
fn balanced_stiffening_leaves_tau_of_dzeta_almost_linear() {
    // Noise-free: the first-order fit's moment residual with stiffening on all six cables
    // (antagonistic pairs cancel the quadratic law's curvature) stays below the F/T noise
    // (0.032 N·m), while the same k₂ on three cables leaves a larger misfit.
    let noiseless = |effects: CsjmEffects| {
        let mut s = spec(effects, 7, 3.0);
        s.schedule.tracker = TrackerNoise::none();
        s.schedule.moment_noise = MomentNoise::none();
        let campaign = simulate_campaign(&s).unwrap();
        let fit = identify(&campaign.dataset, &FitOptions::default()).unwrap();
        fit.residual_rms.norm()
    };
    let clean = noiseless(CsjmEffects::none());
    let balanced = noiseless(CsjmEffects::stiffening(3.0e5));
    let unbalanced = noiseless(unbalanced_stiffening(3.0e5));
    assert!(
        balanced < 0.032,
        "balanced misfit {balanced} N·m (clean {clean})"
    );
    assert!(
        unbalanced > 2.0 * balanced,
        "unbalanced {unbalanced} vs balanced {balanced}"
    );
}

#[test]
fn omitted_gravity_is_aliased_with_the_linear_stiffness_and_biases_k_by_the_gravity_stiffness() {
    // The omitted weight moment changes (to first order) linearly with Δζ: its column lies
    // in the span of K_D.
    let d = run(&spec(
        CsjmEffects::omitted_gravity(PointLoad::prototype_gravity()),
        4000,
        1.0,
    ));
    let score = d
        .scores
        .iter()
        .find(|s| s.effect == "platform_gravity")
        .unwrap();
    assert!(
        score.fraction_outside_baseline < 0.01,
        "{}",
        score.fraction_outside_baseline
    );
    assert!(score
        .note
        .as_deref()
        .unwrap_or("")
        .contains("absorbed into K_D"));

    // Noise-free, tiny increments: the identified K is the cables' K plus the weight's
    // stiffness contribution (computed independently by the simulator with the weight).
    let mut s = spec(
        CsjmEffects::omitted_gravity(PointLoad::prototype_gravity()),
        4001,
        0.02,
    );
    s.schedule.tracker = TrackerNoise::none();
    s.schedule.moment_noise = MomentNoise::none();
    let campaign = simulate_campaign(&s).unwrap();
    let k_id = identify(&campaign.dataset, &FitOptions::default())
        .unwrap()
        .k;
    let cables = prototype_simulator().unwrap();
    let with_weight = cables.clone().with_load(PointLoad::prototype_gravity());
    let k_cables = cables.stiffness(&campaign.true_r0).unwrap().covariant;
    let k_total = with_weight.stiffness(&campaign.true_r0).unwrap().covariant;
    let gravity_stiffness = k_total - k_cables;
    assert!(
        gravity_stiffness.norm() > 0.1,
        "{}",
        gravity_stiffness.norm()
    );
    assert!(
        (k_id - k_total).norm() < 0.1 * gravity_stiffness.norm(),
        "identified K misses K_cables + K_G by {} (K_G {})",
        (k_id - k_total).norm(),
        gravity_stiffness.norm()
    );
    // Recorded (eq. 56 applied) gives the cables' K.
    s.effects.gravity = GravityRecording::Recorded(PointLoad::prototype_gravity());
    let campaign = simulate_campaign(&s).unwrap();
    let k_rec = identify(&campaign.dataset, &FitOptions::default())
        .unwrap()
        .k;
    assert!((k_rec - k_cables).norm() < 0.1 * gravity_stiffness.norm());
}

#[test]
fn a_platform_gravity_finding_is_listed_with_its_aliases() {
    // With 3 N·m increments the mechanism's own curvature is visible; the one-column gravity
    // candidate picks it up, and the diagnosis must say it cannot be told apart from the
    // linear stiffness and from a curvature of τ(Δζ).
    // The gravity column's testable part is weak (a curvature): at the default FDR of 0.01
    // it is named in few of these campaigns, at 0.05 (the former default) in 5 of 12 with the
    // default split (8 of 12 with the split seed 0x5eed_d1a6 the CSJM had before the one
    // default). This test is about the aliases listed with such a finding, so it runs at
    // 0.05, on 12 campaigns, and asks for a third of them named.
    let mut options = DiagnoseOptions::default();
    options.selection.fdr = 0.05;
    let mut named = 0;
    for seed in 0..12 {
        let campaign = simulate_campaign(&spec(
            CsjmEffects::omitted_gravity(PointLoad::prototype_gravity()),
            5000 + seed,
            3.0,
        ))
        .expect("campaign");
        let d = diagnose(&campaign.dataset, &options).expect("diagnosis");
        if let Some(f) = d.findings.iter().find(|f| f.effect == "platform_gravity") {
            named += 1;
            let aliases: Vec<&str> = f.aliases.iter().map(|a| a.effect).collect();
            assert!(aliases.contains(&"linear_stiffness"), "{aliases:?}");
            assert!(aliases.contains(&"cable_nonlinearity"), "{aliases:?}");
        }
    }
    assert!(named >= 4, "platform_gravity named in {named}/12");
}

// ---------------------------------------------------------------- contract and bad input

#[test]
fn json_follows_the_output_contract() {
    let d = run(&spec(CsjmEffects::friction(2.0), 6000, 1.0));
    let json = d.to_json();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let short = serde_json::json!({
        "baseline": {"model": v["baseline"]["model"], "n_params": v["baseline"]["n_params"],
                     "test_mean_rel_error": v["baseline"]["test_mean_rel_error"]},
        "findings": v["findings"].as_array().unwrap().iter().map(|f| serde_json::json!({
            "effect": f["effect"], "joint": f["joint"], "axis": f["axis"], "aliases": f["aliases"],
            "evidence": {"f_test": f["evidence"]["f_test"], "lambda": f["evidence"]["lambda"],
                         "lambda_stderr": f["evidence"]["lambda_stderr"],
                         "interpretation": f["evidence"]["interpretation"]}})).collect::<Vec<_>>(),
        "extended": {"model": v["extended"]["model"], "n_params": v["extended"]["n_params"],
                     "test_mean_rel_error": v["extended"]["test_mean_rel_error"]},
        "unexplained": v["unexplained"], "gain": v["gain"]});
    println!("{}", serde_json::to_string_pretty(&short).unwrap());
    for key in ["model", "n_params", "test_mean_rel_error"] {
        assert!(
            v["baseline"][key].is_string() || v["baseline"][key].is_number(),
            "baseline.{key}"
        );
        assert!(
            v["extended"][key].is_string() || v["extended"][key].is_number(),
            "extended.{key}"
        );
    }
    assert_eq!(v["baseline"]["n_params"], 12);
    assert!(v["unexplained"].is_boolean());
    let findings = v["findings"].as_array().unwrap();
    assert!(!findings.is_empty());
    for f in findings {
        assert!(f["joint"].is_null() && f["axis"].is_null());
        assert!(f["aliases"].is_array() && f["evidence"].is_object());
        let effect = f["effect"].as_str().unwrap();
        assert!([
            "platform_gravity",
            "cable_hysteresis",
            "cable_nonlinearity",
            "connection_term"
        ]
        .contains(&effect));
    }
    assert_eq!(findings[0]["effect"], "cable_hysteresis");
    assert!(
        findings[0]["evidence"]["f_test"]["p_value"]
            .as_f64()
            .unwrap()
            < 1e-6
    );
    // The held-out error is the mean relative displacement error over held-out rows,
    // recomputed here from the reported rows would need the model; check its range instead.
    let base = v["baseline"]["test_mean_rel_error"].as_f64().unwrap();
    let ext = v["extended"]["test_mean_rel_error"].as_f64().unwrap();
    assert!(base > 0.0 && ext > 0.0 && ext < base, "{base} → {ext}");
    assert_eq!(v["rows"].as_array().unwrap().len(), 85);

    // Recompute the baseline's held-out error from the reported parameters and rows:
    // mean over `test` rows of ‖K_D⁻¹(Δτ − c) − Δζ‖/‖Δζ‖.
    let params = v["baseline"]["parameters"].as_array().unwrap();
    let value = |label: &str| {
        params.iter().find(|p| p["label"] == label).unwrap()["value"]
            .as_f64()
            .unwrap()
    };
    let k_d = nalgebra::Matrix3::from_fn(|i, j| value(&format!("K_D[{i}][{j}]")));
    let c = Vector3::new(value("offset.x"), value("offset.y"), value("offset.z"));
    let vec3 = |x: &serde_json::Value| {
        Vector3::from_iterator(x.as_array().unwrap().iter().map(|e| e.as_f64().unwrap()))
    };
    let errors: Vec<f64> = v["rows"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["set"] == "test")
        .map(|r| {
            let (dz, dt) = (vec3(&r["dzeta"]), vec3(&r["dtau"]));
            (k_d.try_inverse().unwrap() * (dt - c) - dz).norm() / dz.norm()
        })
        .collect();
    assert_eq!(errors.len(), v["n_test"].as_u64().unwrap() as usize);
    let recomputed = errors.iter().sum::<f64>() / errors.len() as f64;
    assert!(
        (recomputed - base).abs() < 1e-9 * base,
        "{recomputed} vs {base}"
    );
}

#[test]
fn bad_inputs_give_clear_errors() {
    let err = diagnose_file("/nonexistent/csjm.csv", &DiagnoseOptions::default()).unwrap_err();
    assert!(err.to_string().contains("/nonexistent/csjm.csv"), "{err}");

    let campaign = simulate_campaign(&spec(CsjmEffects::none(), 7000, 1.0)).unwrap();
    let mut options = DiagnoseOptions::default();
    options.selection.test_fraction = 1.5;
    let err = diagnose(&campaign.dataset, &options).unwrap_err();
    assert!(
        matches!(
            err,
            DiagnoseError::InvalidOption {
                option: "test_fraction",
                ..
            }
        ),
        "{err}"
    );
    let mut options = DiagnoseOptions::default();
    options.selection.fdr = f64::NAN;
    assert!(matches!(
        diagnose(&campaign.dataset, &options),
        Err(DiagnoseError::InvalidOption { option: "fdr", .. })
    ));

    // Too few rows to split.
    let rows = campaign.dataset.measurements()[..8].to_vec();
    let small = CsjmDataset::new(campaign.dataset.reference().clone(), rows).unwrap();
    let err = diagnose(&small, &DiagnoseOptions::default()).unwrap_err();
    assert!(
        matches!(err, DiagnoseError::TooFewRows { loaded: 8, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("8 loaded rows"), "{err}");

    // Loads about x only: the training rows do not excite y and z.
    let r0 = Rotation3::identity();
    let rows = (1..40)
        .map(|k| {
            let z = Vector3::new(0.001 * k as f64, 0.0, 0.0);
            CsjmMeasurement::new(r0 * so3::exp(&z), Vector3::new(30.0 * z.x, 0.0, 0.0))
        })
        .collect();
    let flat = CsjmDataset::new(CsjmMeasurement::new(r0, Vector3::zeros()), rows).unwrap();
    let err = diagnose(&flat, &DiagnoseOptions::default()).unwrap_err();
    assert!(matches!(err, DiagnoseError::Unexcited { .. }), "{err}");
}

#[test]
fn the_same_inputs_give_the_same_diagnosis() {
    let s = spec(CsjmEffects::friction(1.0), 8000, 1.0);
    assert_eq!(run(&s).to_json(), run(&s).to_json());
}

#[test]
fn a_measurement_file_diagnoses_like_the_dataset_it_holds() {
    let campaign = simulate_campaign(&spec(CsjmEffects::friction(1.0), 8100, 1.0)).unwrap();
    let dir = std::env::temp_dir().join(format!("csjm-diagnose-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("campaign.csv");
    campaign
        .dataset
        .write_csv(std::fs::File::create(&path).unwrap())
        .unwrap();
    let from_file = diagnose_file(&path, &DiagnoseOptions::default()).unwrap();
    let from_memory = diagnose(&campaign.dataset, &DiagnoseOptions::default()).unwrap();
    assert_eq!(from_file.defect_effects(), from_memory.defect_effects());
    let (a, b) = (
        from_file.extended.test_mean_rel_error,
        from_memory.extended.test_mean_rel_error,
    );
    assert!((a - b).abs() <= 1e-9 * b, "{a} vs {b}");
    // File rows are reported 1-based (the reference is data row 1).
    assert_eq!(from_file.rows[0].row, 2);

    // A file without the `tz` column: one clear error naming it.
    let text = std::fs::read_to_string(&path).unwrap();
    let broken: String = text
        .lines()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            f.remove(11);
            f.join(",") + "\n"
        })
        .collect();
    let bad = dir.join("missing_tz.csv");
    std::fs::write(&bad, broken).unwrap();
    let err = diagnose_file(&bad, &DiagnoseOptions::default()).unwrap_err();
    assert!(err.to_string().contains("`tz`"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
