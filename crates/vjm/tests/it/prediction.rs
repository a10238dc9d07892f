//! Deflection prediction with and without K_C against the exact nonlinear equilibrium.

use nalgebra::{DMatrix, DVector};
use vjm::{
    jacobian, jacobian_deflected, predict_deflection, spring_deflection, SerialChain,
    VirtualJointModel,
};

use crate::strategies::{random_compliances, random_configurations};

/// Without K_C the prediction is J C Jᵀ F (seed eqs. 7–8), computed here independently.
#[test]
fn linear_prediction_is_j_c_jt_f() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let c = random_compliances(21, 1);
    let q = random_configurations(&panda, 1, 2);
    let f = [10.0, -20.0, 30.0, 1.0, -2.0, 0.5];
    let j = jacobian(&panda, &model, &q).unwrap();
    let cx = &j * DMatrix::from_diagonal(&DVector::from_column_slice(&c)) * j.transpose();
    let expect = cx * DVector::from_column_slice(&f);
    let got = predict_deflection(&panda, &model, &c, &q, &f, false).unwrap();
    for r in 0..6 {
        assert!(
            (got[r] - expect[r]).abs() < 1e-15 + 1e-12 * expect.amax(),
            "{got:?} vs {expect}"
        );
    }
}

/// The exact spring equilibrium K_Θ Δθ = J(Δθ)ᵀF (θ-dependent Jacobian), by fixed-point
/// iteration on the slow, independent deflected-kinematics path.
fn exact_equilibrium(
    chain: &SerialChain,
    model: &VirtualJointModel,
    c: &[f64],
    q: &[f64],
    f: &[f64; 6],
) -> DVector<f64> {
    let fv = DVector::from_column_slice(f);
    let mut theta = DVector::zeros(c.len());
    for _ in 0..200 {
        let tau = jacobian_deflected(chain, model, q, theta.as_slice())
            .unwrap()
            .transpose()
            * &fv;
        let next = DVector::from_iterator(c.len(), tau.iter().zip(c).map(|(t, ci)| t * ci));
        if (&next - &theta).amax() < 1e-18 {
            return next;
        }
        theta = next;
    }
    theta
}

/// With K_C, Δθ is the linearisation of the exact equilibrium: its error is O(λ³) in the
/// load scale λ (halving λ divides it by ≈ 8), while without K_C it is O(λ²) (÷ 4).
#[test]
fn kc_captures_the_second_order_equilibrium() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let c: Vec<f64> = random_compliances(21, 3)
        .iter()
        .map(|v| v * 100.0)
        .collect();
    let q = random_configurations(&panda, 1, 4);
    let base = [40.0, -30.0, 50.0, 3.0, -4.0, 2.0];
    let errs = |lambda: f64| {
        let f = base.map(|v| v * lambda);
        let exact = exact_equilibrium(&panda, &model, &c, &q, &f);
        let lin = spring_deflection(&panda, &model, &c, &q, &f, false).unwrap();
        let kc = spring_deflection(&panda, &model, &c, &q, &f, true).unwrap();
        ((&lin - &exact).amax(), (&kc - &exact).amax(), exact.amax())
    };
    let (lin1, kc1, size) = errs(1.0);
    let (lin2, kc2, _) = errs(0.5);
    assert!(size > 1e-4 && size < 1e-1, "deflection scale {size}");
    assert!(kc1 < 0.05 * lin1, "K_C error {kc1:e} vs linear {lin1:e}");
    let (r_lin, r_kc) = (lin1 / lin2, kc1 / kc2);
    assert!((r_lin - 4.0).abs() < 0.4, "linear error ratio {r_lin}");
    assert!((r_kc - 8.0).abs() < 1.0, "K_C error ratio {r_kc}");
}

/// Zero compliance everywhere: no deflection, with or without K_C.
#[test]
fn zero_compliance_no_deflection() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let d = predict_deflection(
        &panda,
        &model,
        &[0.0; 7],
        &[0.0, -0.5, 0.0, -2.0, 0.0, 1.5, 0.0],
        &[1.0; 6],
        true,
    )
    .unwrap();
    assert_eq!(d, [0.0; 6]);
}
