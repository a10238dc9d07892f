//! `predict` of a model with gear curves: the load's deflection of a curved torsion spring is
//! its curve's change from the weight's working point, checked against an independent Jacobian
//! (weightless, exact to rounding) and against the exact equilibrium with the curve (under
//! gravity, to first order); a curve of zero coefficients predicts what no curve does, bit for
//! bit.

use vjm::gear::GearCurve;
use vjm::gravity::{deflection_under_gravity, deflection_under_gravity_with_gears, Gravity};
use vjm::testbed::{simulate, CampaignSpec, TrueModel};
use vjm::Measurements;
use vjm::{
    identify, DataSource, IdentifyOptions, Load, PointMass, SerialChain, StiffnessModel,
    VirtualJointModel,
};

/// A traditional model identified on a clean weightless Panda campaign (compliances
/// `NOMINAL_TORSION`, J2 1e-4 rad/(N·m)), and its data.
pub(crate) fn panda_model() -> (SerialChain, StiffnessModel, vjm::dataset::Dataset<'static>) {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 10,
        noise: false,
        ..Default::default()
    };
    let data = simulate(&chain, &TrueModel::nominal(7), &spec)
        .unwrap()
        .dataset;
    let (model, opts) = (
        VirtualJointModel::traditional(7),
        IdentifyOptions::default(),
    );
    let (q, w, d) = (data.q_flat(), data.wrench_flat(), data.displacement_flat());
    let id = identify(&chain, &model, Measurements::new(q, w, d), &opts).unwrap();
    let sm = StiffnessModel::from_identification(
        &id,
        &chain,
        &model,
        &opts,
        DataSource::in_memory(data.len()),
    )
    .unwrap();
    (chain, sm, data)
}

/// The shoulder (J2) softens by 1e-4 rad/(N·m) beyond 5 N·m and re-stiffens by half of that
/// beyond 15 N·m: the curve's excess is as large as the linear spring's deflection.
pub(crate) fn shoulder_curve() -> GearCurve {
    GearCurve::new(1, vec![5.0, 15.0], vec![1e-4, -0.5e-4]).unwrap()
}

fn bits(d: [f64; 6]) -> [u64; 6] {
    d.map(f64::to_bits)
}

/// Weightless: the curved prediction is the linear one plus `J_2 · Σ a_k h_k(τ_2)` with J the
/// Jacobian of `vjm::jacobian` and τ_2 = J_2ᵀ W, the curve written out by cases.
#[test]
fn a_gear_curve_adds_its_excess_at_the_load_torque() {
    let (chain, sm, data) = panda_model();
    let curved = sm.clone().with_gear_curves(&[shoulder_curve()]).unwrap();
    let model = VirtualJointModel::traditional(7);
    let mut crossed = 0;
    for i in 0..data.len().min(40) {
        let (q, w) = (data.q(i), data.wrench(i));
        let plain = sm.predict(&chain, q, Load::Wrench(&w)).unwrap()[0];
        let bent = curved.predict(&chain, q, Load::Wrench(&w)).unwrap()[0];
        let j = vjm::jacobian(&chain, &model, q).unwrap();
        let tau: f64 = (0..6).map(|r| j[(r, 1)] * w[r]).sum();
        // Σ a_k sign(τ)(|τ| − t_k)⁺ for the knots 5 and 15 N·m.
        let excess = tau.signum()
            * (1e-4 * (tau.abs() - 5.0).max(0.0) - 0.5e-4 * (tau.abs() - 15.0).max(0.0));
        crossed += usize::from(tau.abs() > 5.0);
        for r in 0..3 {
            let want = plain.deflection[r] + j[(r, 1)] * excess;
            let scale = plain.deflection[r].abs().max(1e-6);
            assert!(
                (bent.deflection[r] - want).abs() <= 1e-12 * scale,
                "row {i} axis {r}: {} vs {want}",
                bent.deflection[r]
            );
        }
        assert_eq!(
            plain.stddev.map(f64::to_bits),
            bent.stddev.map(f64::to_bits)
        );
    }
    assert!(
        crossed >= 5,
        "only {crossed} rows load the shoulder beyond its first knot"
    );
}

/// Under gravity the curve works about the weight's preload: the curve's share of the
/// prediction, (curved − linear) of `predict_under_gravity`, equals that share of the exact
/// equilibrium, (curved − linear) of `deflection_under_gravity_with_gears`, to first order
/// (they differ by the load's K_C and by ‖C K‖ of the curve's share: measured 0.7–9 %, 2.6 %
/// on average, on these rows). Without the preload (τ₀ = 0) the share would be the weightless
/// one, which is off by 20–100 % on most rows (the load alone seldom reaches the first knot).
#[test]
fn under_gravity_a_gear_curve_works_about_the_weights_preload() {
    let (chain, sm, data) = panda_model();
    let curve = shoulder_curve();
    let curved = sm
        .clone()
        .with_gear_curves(std::slice::from_ref(&curve))
        .unwrap();
    let model = VirtualJointModel::traditional(7);
    let c = sm.determined_compliance().unwrap();
    let g = Gravity::default();
    let (mut worst, mut sum, mut counted): (f64, f64, usize) = (0.0, 0.0, 0);
    let mut preload_matters = 0;
    for i in 0..data.len().min(20) {
        let (q, w) = (data.q(i), data.wrench(i));
        let plain = sm
            .predict_under_gravity(&chain, q, Load::Wrench(&w), &g)
            .unwrap()[0];
        let bent = curved
            .predict_under_gravity(&chain, q, Load::Wrench(&w), &g)
            .unwrap()[0];
        let exact_plain = deflection_under_gravity(&chain, &model, &c, q, &w, &g, None).unwrap();
        let loading = vjm::gravity::Loading {
            gravity: Some(g),
            payload: None,
            wrench: Some(w),
        };
        let exact_bent = deflection_under_gravity_with_gears(
            &chain,
            &model,
            &c,
            std::slice::from_ref(&curve),
            q,
            &loading,
        )
        .unwrap();
        let share: Vec<f64> = (0..3)
            .map(|r| bent.deflection[r] - plain.deflection[r])
            .collect();
        let exact: Vec<f64> = (0..3).map(|r| exact_bent[r] - exact_plain[r]).collect();
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let diff: Vec<f64> = share.iter().zip(&exact).map(|(a, b)| a - b).collect();
        if norm(&exact) < 1e-6 {
            continue; // the load does not move the shoulder's torque across a knot
        }
        let rel = norm(&diff) / norm(&exact);
        (worst, sum, counted) = (worst.max(rel), sum + rel, counted + 1);
        // The weightless share (no preload) is far from the exact one.
        let weightless = curved.predict(&chain, q, Load::Wrench(&w)).unwrap()[0];
        let flat = sm.predict(&chain, q, Load::Wrench(&w)).unwrap()[0];
        let wl: Vec<f64> = (0..3)
            .map(|r| weightless.deflection[r] - flat.deflection[r] - exact[r])
            .collect();
        preload_matters += usize::from(norm(&wl) > 0.2 * norm(&exact));
    }
    assert!(counted >= 10, "{counted} rows move the curve");
    let mean = sum / counted as f64;
    assert!(
        worst <= 0.1 && mean <= 0.04,
        "the curve's share is off by up to {worst} of it, {mean} on average"
    );
    assert!(
        preload_matters >= 3,
        "{preload_matters} rows tell the preload apart"
    );
}

/// A curve of zero coefficients predicts what the model without curves predicts, bit for bit:
/// weightless and under gravity, with wrenches and with a payload.
#[test]
fn a_zero_gear_curve_predicts_as_no_curve_bit_for_bit() {
    let (chain, sm, data) = panda_model();
    let zero = GearCurve::new(1, vec![5.0, 15.0], vec![0.0, 0.0]).unwrap();
    let curved = sm.clone().with_gear_curves(&[zero]).unwrap();
    let rows = data.len().min(30);
    let q = &data.q_flat()[..7 * rows];
    let w = &data.wrench_flat()[..6 * rows];
    let g = Gravity::default();
    let payload = PointMass::new(3.0, [0.0, 0.05, 0.1]).unwrap();
    for load in [Load::Wrench(w), Load::Payload(payload)] {
        let a = sm.predict(&chain, q, load).unwrap();
        let b = curved.predict(&chain, q, load).unwrap();
        let ag = sm.predict_under_gravity(&chain, q, load, &g).unwrap();
        let bg = curved.predict_under_gravity(&chain, q, load, &g).unwrap();
        for i in 0..rows {
            assert_eq!(bits(a[i].deflection), bits(b[i].deflection), "row {i}");
            assert_eq!(bits(ag[i].deflection), bits(bg[i].deflection), "row {i}");
        }
    }
}
