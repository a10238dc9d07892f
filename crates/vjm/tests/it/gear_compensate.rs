//! `compensate` of a model with gear curves: the corrected targets put the curved model's tip
//! on the nominal pose, checked by an independent evaluation at those targets (the curved
//! static equilibrium under gravity; weightless, FK + J (c τ + e(τ)) with the curve written by
//! cases); a curve of zero coefficients compensates as no curve does, bit for bit.

use vjm::gear::GearCurve;
use vjm::gravity::{static_equilibrium_with_gears, Gravity, Loading};
use vjm::{CompensateOptions, CompensationStatus, Load, VirtualJointModel};

use super::gear_predict::{panda_model, shoulder_curve};

fn distance(a: &nalgebra::Isometry3<f64>, b: &nalgebra::Isometry3<f64>) -> f64 {
    (a.translation.vector - b.translation.vector).norm()
}

/// Under gravity: at the corrected targets the curved equilibrium (weight and load) puts the
/// tip on the nominal pose's rigid tip within the solver's tolerance (1e-9 m), where the
/// targets corrected without the curve miss it by micrometres.
#[test]
fn compensation_under_gravity_hits_the_target_with_the_curved_equilibrium() {
    let misses = curved_compensation_misses(&shoulder_curve(), 1e-6);
    assert!(misses >= 6, "the curve matters on only {misses} rows");
}

/// Compensates 12 rows of the Panda campaign under gravity with and without `curve`, checks
/// that the curved equilibrium at the curve's targets puts the tip on the nominal pose within
/// 2e-9 m (every row converged), and returns on how many rows the curve-free targets miss it by
/// more than `miss_at_least` m.
pub(crate) fn curved_compensation_misses(curve: &GearCurve, miss_at_least: f64) -> usize {
    let (chain, sm, data) = panda_model();
    let curved = sm
        .clone()
        .with_gear_curves(std::slice::from_ref(curve))
        .unwrap();
    let model = VirtualJointModel::traditional(7);
    let c = sm.determined_compliance().unwrap();
    let g = Gravity::default();
    let mut opts = CompensateOptions::default();
    (opts.gravity, opts.check_limits) = (Some(g), false);
    let rows = 12;
    let q = &data.q_flat()[..7 * rows];
    let w = &data.wrench_flat()[..6 * rows];
    let bent = curved
        .compensate(&chain, q, Load::Wrench(w), &opts)
        .unwrap();
    let flat = sm.compensate(&chain, q, Load::Wrench(w), &opts).unwrap();
    let mut misses = 0;
    for i in 0..rows {
        assert_eq!(
            bent.rows[i].status,
            CompensationStatus::Converged,
            "row {i}"
        );
        let target = chain.forward_kinematics(&q[7 * i..7 * i + 7]).unwrap();
        let loading = Loading {
            gravity: Some(g),
            payload: None,
            wrench: Some(data.wrench(i)),
        };
        let at = |qc: &[f64]| {
            static_equilibrium_with_gears(
                &chain,
                &model,
                &c,
                std::slice::from_ref(curve),
                qc,
                &loading,
            )
            .unwrap()
            .tip
        };
        let hit = distance(&at(&bent.q[7 * i..7 * i + 7]), &target);
        assert!(hit <= 2e-9, "row {i}: the curved tip misses by {hit} m");
        let miss = distance(&at(&flat.q[7 * i..7 * i + 7]), &target);
        misses += usize::from(miss > miss_at_least);
    }
    misses
}

/// Weightless without K_C: at the corrected targets q', FK(q') + J(q') θ with
/// θ_k = c_k τ_k (+ the shoulder's excess by cases), τ = J(q')ᵀ W, is the nominal tip.
#[test]
fn weightless_compensation_bends_the_curved_spring_by_its_curve() {
    let (chain, sm, data) = panda_model();
    let curved = sm.clone().with_gear_curves(&[shoulder_curve()]).unwrap();
    let model = VirtualJointModel::traditional(7);
    let c = sm.determined_compliance().unwrap();
    let mut opts = CompensateOptions::default();
    (opts.with_kc, opts.check_limits) = (false, false);
    let rows = data.len().min(40);
    let q = &data.q_flat()[..7 * rows];
    let w = &data.wrench_flat()[..6 * rows];
    let out = curved
        .compensate(&chain, q, Load::Wrench(w), &opts)
        .unwrap();
    let mut crossed = 0;
    for i in 0..rows {
        assert_eq!(out.rows[i].status, CompensationStatus::Converged, "row {i}");
        let qc = &out.q[7 * i..7 * i + 7];
        let wr = data.wrench(i);
        let j = vjm::jacobian(&chain, &model, qc).unwrap();
        let mut tip = chain.forward_kinematics(qc).unwrap().translation.vector;
        for k in 0..7 {
            let tau: f64 = (0..6).map(|r| j[(r, k)] * wr[r]).sum();
            let mut theta = c[k] * tau;
            if k == 1 {
                let t = tau.abs();
                theta += tau.signum() * (1e-4 * (t - 5.0).max(0.0) - 0.5e-4 * (t - 15.0).max(0.0));
                crossed += usize::from(t > 5.0);
            }
            for r in 0..3 {
                tip[r] += j[(r, k)] * theta;
            }
        }
        let target = chain.forward_kinematics(&q[7 * i..7 * i + 7]).unwrap();
        let miss = (tip - target.translation.vector).norm();
        assert!(miss <= 2e-9, "row {i}: misses by {miss} m");
    }
    assert!(
        crossed >= 3,
        "only {crossed} rows load the shoulder beyond its knot"
    );
}

/// A curve of zero coefficients compensates as no curve: the same targets and reports, bit
/// for bit, weightless with K_C and under gravity.
#[test]
fn a_zero_gear_curve_compensates_as_no_curve_bit_for_bit() {
    let (chain, sm, data) = panda_model();
    let zero = GearCurve::new(1, vec![5.0, 15.0], vec![0.0, 0.0]).unwrap();
    let curved = sm.clone().with_gear_curves(&[zero]).unwrap();
    let rows = 8;
    let q = &data.q_flat()[..7 * rows];
    let w = &data.wrench_flat()[..6 * rows];
    for gravity in [None, Some(Gravity::default())] {
        let mut opts = CompensateOptions::default();
        opts.gravity = gravity;
        let a = sm.compensate(&chain, q, Load::Wrench(w), &opts).unwrap();
        let b = curved
            .compensate(&chain, q, Load::Wrench(w), &opts)
            .unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.q), bits(&b.q), "gravity {gravity:?}");
        assert_eq!(a.rows, b.rows);
    }
}
