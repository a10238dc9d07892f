//! A diagnosis' `joint_torsion_nonlinear` finding as a gear curve (`Finding::gear_curve`): a
//! model holding the extended fit's springs and that curve predicts what the extended fit
//! fitted, row by row.

use vjm::diagnose::report::GearFinding;
use vjm::diagnose::{diagnose, DiagnoseOptions};
use vjm::gravity::Gravity;
use vjm::testbed::{simulate, CampaignSpec, Effect, HarmonicDriveSpring, TrueModel};
use vjm::Measurements;
use vjm::{
    identify, predict_deflection, DataSource, IdentifyOptions, Load, SerialChain, StiffnessModel,
    VirtualJointModel,
};

/// The diagnosis of a Panda campaign whose shoulder gear stiffens (`gravity`: simulated and
/// diagnosed under it), with one finding at most, and a model with the extended fit's spring
/// compliances and the finding's curve. The model is made by identifying the traditional
/// springs on noise-free displacements `J C Jᵀ W` of those compliances (`predict_deflection`,
/// no curve), so its compliances are the fit's to rounding.
fn diagnosed(
    gravity: Option<Gravity>,
    gear: HarmonicDriveSpring,
) -> (
    SerialChain,
    vjm::testbed::Campaign,
    vjm::diagnose::report::Diagnosis,
    StiffnessModel,
) {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::TorsionNonlinear {
        joint: 1,
        spring: gear,
    });
    let spec = CampaignSpec {
        seed: 4,
        gravity,
        ..Default::default()
    };
    let campaign = simulate(&chain, &truth, &spec).unwrap();
    let opts = DiagnoseOptions {
        gravity,
        max_findings: 1,
        ..Default::default()
    };
    let d = diagnose(&chain, &campaign.dataset, &opts).unwrap();
    assert_eq!(d.findings.len(), 1, "{}", d.to_json());
    let f = &d.findings[0];
    assert_eq!((f.effect, f.joint), ("joint_torsion_nonlinear", Some(2)));
    let c: Vec<f64> = (1..=7)
        .map(|j| {
            let label = format!("J{j}z");
            let p = d.extended.parameters.iter().find(|p| p.label == label);
            // None: the torsion does not move the tip point (J7z on the Panda).
            p.and_then(|p| p.value).unwrap_or(0.0)
        })
        .collect();
    let data = &campaign.dataset;
    let model = VirtualJointModel::traditional(7);
    let (q, w) = (data.q_flat(), data.wrench_flat());
    let width = data.displacement_flat().len() / data.len();
    let mut synthetic = Vec::with_capacity(width * data.len());
    for i in 0..data.len() {
        let p = predict_deflection(&chain, &model, &c, data.q(i), &data.wrench(i), false).unwrap();
        synthetic.extend_from_slice(&p[..width]);
    }
    let opts = IdentifyOptions::default();
    let id = identify(&chain, &model, Measurements::new(q, w, &synthetic), &opts).unwrap();
    let sm = StiffnessModel::from_identification(
        &id,
        &chain,
        &model,
        &opts,
        DataSource::in_memory(data.len()),
    )
    .unwrap();
    let got = sm.determined_compliance().unwrap();
    let largest = c.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    for k in 0..7 {
        assert!((got[k] - c[k]).abs() <= 1e-10 * largest, "J{}z", k + 1);
    }
    let curves = d.gear_curves().unwrap();
    let sm = sm.with_gear_curves(&curves).unwrap();
    (chain, campaign, d, sm)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Weightless: the finding's curve has the candidate's knots (`TORSION_KNOTS` times the
/// joint's RMS training torque, read back from the curve's argument) and the extended fit's
/// coefficients, and the model with it predicts the extended fit's values on every row to
/// 1e-9 of the deflection (its columns do not depend on the fit's point). Without the curve
/// the prediction misses them by a visible fraction.
#[test]
fn a_diagnosed_gear_curve_reproduces_the_extended_fit() {
    // Weightless, a Panda campaign's loads give the shoulder ≈ 10 N·m RMS.
    let gear = HarmonicDriveSpring::stiffening(1e-4, 3.0, 3.0, 8.0);
    let (chain, campaign, d, sm) = diagnosed(None, gear);
    let f = &d.findings[0];
    let curve = f.gear_curve().unwrap().expect("a gear finding has a curve");
    assert_eq!(curve.joint(), 1);
    assert_eq!(curve.coefficients(), &f.evidence.estimate[..]);
    let knots = f.detail.knots.clone().unwrap();
    assert_eq!(curve.knots(), &knots[..]);
    // The knots are 0.33 and 1 times the RMS torsion torque of the training rows.
    let data = &campaign.dataset;
    let model = VirtualJointModel::traditional(7);
    let (mut sq, mut n) = (0.0, 0);
    for i in 0..data.len() {
        if data.set(i) == Some(vjm::dataset::SetLabel::Train) {
            let j = vjm::jacobian(&chain, &model, data.q(i)).unwrap();
            let w = data.wrench(i);
            sq += (0..6).map(|r| j[(r, 1)] * w[r]).sum::<f64>().powi(2);
            n += 1;
        }
    }
    assert!(n > 0, "the campaign holds out poses");
    let rms = (sq / n as f64).sqrt();
    assert!(
        (knots[1] - rms).abs() <= 1e-9 * rms,
        "{knots:?} vs RMS {rms}"
    );
    assert!((knots[0] - 0.33 * rms).abs() <= 1e-9 * rms);
    let flat = sm.clone().with_gear_curves(&[]).unwrap();
    let mut miss: f64 = 0.0;
    for (i, row) in d.rows.iter().enumerate() {
        let load = Load::Wrench(&data.wrench(i));
        let p = sm.predict(&chain, data.q(i), load).unwrap()[0];
        let diff: Vec<f64> = (0..3).map(|r| p.deflection[r] - row.extended[r]).collect();
        assert!(
            norm(&diff) <= 1e-9 * norm(&row.extended),
            "row {i}: {:?} vs {:?}",
            &p.deflection[..3],
            row.extended
        );
        let p0 = flat.predict(&chain, data.q(i), load).unwrap()[0];
        let d0: Vec<f64> = (0..3).map(|r| p0.deflection[r] - row.extended[r]).collect();
        miss = miss.max(norm(&d0) / norm(&row.extended));
    }
    assert!(
        miss > 1e-3,
        "without the curve the fit is missed by only {miss}"
    );
}

/// Under gravity the extended fit's columns are taken at the pass's linearisation C_lin (the
/// baseline's pre-fit: the sagged pose θ₀ = C_lin τ₀ and gravity's coupling), the model
/// evaluates them at its own compliances, the fit's C: the two are expected to differ by
/// second-order terms, (C − C_lin)·K_G of the deflection (C_lin is not reported, so the test
/// bounds the difference rather than isolating it). Measured ≤ 0.34 % of the deflection per row (bound 1 %),
/// where the model without the curve misses the fit by up to 68 %.
#[test]
fn under_gravity_a_diagnosed_gear_curve_reproduces_the_extended_fit_to_first_order() {
    let g = Gravity::default();
    let gear = HarmonicDriveSpring::stiffening(1e-4, 2.4, 30.0, 70.0);
    let (chain, campaign, d, sm) = diagnosed(Some(g), gear);
    let data = &campaign.dataset;
    let flat = sm.clone().with_gear_curves(&[]).unwrap();
    let (mut worst, mut miss): (f64, f64) = (0.0, 0.0);
    for (i, row) in d.rows.iter().enumerate() {
        let load = Load::Wrench(&data.wrench(i));
        let p = sm
            .predict_under_gravity(&chain, data.q(i), load, &g)
            .unwrap()[0];
        let diff: Vec<f64> = (0..3).map(|r| p.deflection[r] - row.extended[r]).collect();
        worst = worst.max(norm(&diff) / norm(&row.extended));
        let p0 = flat
            .predict_under_gravity(&chain, data.q(i), load, &g)
            .unwrap()[0];
        let d0: Vec<f64> = (0..3).map(|r| p0.deflection[r] - row.extended[r]).collect();
        miss = miss.max(norm(&d0) / norm(&row.extended));
    }
    assert!(
        worst <= 0.01,
        "the model misses the extended fit by {worst} of a deflection"
    );
    assert!(miss > 10.0 * worst, "without the curve: {miss}");
}

/// The model `diagnose --save` makes of a `joint_backlash` finding (as
/// `robot_stiffness._diagnosed_model` does: the traditional springs identified on the rows with
/// the curve's first-order share taken out, the curve put in the model): the finding's curve is
/// the shoulder's lost motion (no knots, b the extended fit's estimate, near the truth), and
/// the saved model predicts a second, held-out campaign's true displacements better than the
/// same model without the lost motion (measured 6.5 µm RMS against 210 µm, and 133 µm for the
/// springs fitted on the raw rows; bound 0.2×; b within 1.5 % of the truth, bound 10 %). A
/// torsion finding at the same joint merges into one
/// curve with both.
#[test]
fn a_diagnosed_backlash_is_the_saved_models_lost_motion() {
    let chain = SerialChain::bundled();
    let b_true = 1e-3;
    let truth = TrueModel::nominal(7).with_effect(Effect::Backlash {
        joint: 1,
        lost_motion: b_true,
    });
    let campaign = simulate(
        &chain,
        &truth,
        &CampaignSpec {
            seed: 4,
            ..Default::default()
        },
    )
    .unwrap();
    let opts = DiagnoseOptions {
        max_findings: 1,
        ..Default::default()
    };
    let d = diagnose(&chain, &campaign.dataset, &opts).unwrap();
    assert_eq!(d.findings.len(), 1, "{}", d.to_json());
    let f = &d.findings[0];
    assert_eq!((f.effect, f.joint), ("joint_backlash", Some(2)));
    let curves = d.gear_curves().unwrap();
    assert_eq!(curves.len(), 1);
    let curve = &curves[0];
    assert_eq!((curve.joint(), curve.knots().len()), (1, 0));
    assert_eq!(curve.lost_motion(), f.evidence.estimate[0]);
    assert!(
        (curve.lost_motion() - b_true).abs() <= 0.1 * b_true,
        "b = {} rad",
        curve.lost_motion()
    );
    // The saved model.
    let data = &campaign.dataset;
    let model = VirtualJointModel::traditional(7);
    let (q, w, disp) = (data.q_flat(), data.wrench_flat(), data.displacement_flat());
    let width = disp.len() / data.len();
    let iopts = IdentifyOptions::default();
    let fit = |d: &[f64]| {
        let id = identify(&chain, &model, Measurements::new(q, w, d), &iopts).unwrap();
        StiffnessModel::from_identification(
            &id,
            &chain,
            &model,
            &iopts,
            DataSource::in_memory(data.len()),
        )
        .unwrap()
    };
    let first = fit(disp);
    let bent = first.clone().with_gear_curves(&curves).unwrap();
    let (a, b) = (
        bent.predict(&chain, q, Load::Wrench(w)).unwrap(),
        first.predict(&chain, q, Load::Wrench(w)).unwrap(),
    );
    let mut corrected = disp.to_vec();
    for i in 0..data.len() {
        for r in 0..width {
            corrected[i * width + r] -= a[i].deflection[r] - b[i].deflection[r];
        }
    }
    let without = fit(&corrected);
    let saved = without.clone().with_gear_curves(&curves).unwrap();
    // Held out: another campaign of the same arm, its true (noise-free) displacements.
    let other = simulate(
        &chain,
        &truth,
        &CampaignSpec {
            seed: 11,
            ..Default::default()
        },
    )
    .unwrap();
    let rms = |m: &StiffnessModel| {
        let (q, w) = (other.dataset.q_flat(), other.applied_wrench.concat());
        let p = m.predict(&chain, q, Load::Wrench(&w)).unwrap();
        let sq: f64 = p
            .iter()
            .zip(&other.true_displacement)
            .map(|(p, t)| {
                (0..3)
                    .map(|r| (p.deflection[r] - t[r]).powi(2))
                    .sum::<f64>()
            })
            .sum();
        (sq / p.len() as f64).sqrt()
    };
    let (with_b, without_b, raw) = (rms(&saved), rms(&without), rms(&first));
    assert!(
        with_b < 0.2 * without_b && with_b < 0.2 * raw,
        "held-out RMS: {with_b} m with the lost motion, {without_b} m without, {raw} m raw fit"
    );
    // A torsion finding at the same joint: one curve, its knots and the backlash's b.
    let mut both = d.clone();
    let mut torsion = f.clone();
    torsion.effect = "joint_torsion_nonlinear";
    torsion.detail.knots = Some(vec![3.0, 9.0]);
    torsion.evidence.estimate = vec![2e-5, -1e-5];
    both.findings.insert(0, torsion);
    let merged = both.gear_curves().unwrap();
    assert_eq!(merged.len(), 1);
    assert_eq!(merged[0].knots(), &[3.0, 9.0]);
    assert_eq!(merged[0].coefficients(), &[2e-5, -1e-5]);
    assert_eq!(merged[0].lost_motion(), curve.lost_motion());
}
