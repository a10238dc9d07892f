//! Jacobian and K_C against finite differences of independent code paths.

use nalgebra::{DMatrix, Isometry3, Vector3};
use proptest::prelude::*;
use vjm::{
    complementary_stiffness, forward_kinematics_deflected, jacobian, jacobian_batch_in_place,
    jacobian_deflected, jacobian_in_place, spring_axes, SerialChain, Spring, SpringAxis,
    VirtualJointModel, Workspace,
};

use crate::strategies::{arb_chain_and_q, arb_wrench, config, random_configurations};

/// Spatial velocity `[ṗ; ω]` of the tip (base frame) from two poses 2h apart.
fn twist_fd(plus: &Isometry3<f64>, minus: &Isometry3<f64>, h: f64) -> [f64; 6] {
    let v = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
    let w = (plus.rotation * minus.rotation.inverse()).scaled_axis() / (2.0 * h);
    [v.x, v.y, v.z, w.x, w.y, w.z]
}

/// Central differences of FK under each virtual rotation, around the deflected state `theta`.
fn jacobian_fd(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
) -> DMatrix<f64> {
    let h = 1e-6;
    let m = model.n_params();
    let mut out = DMatrix::zeros(6, m);
    for k in 0..m {
        let mut tp = theta.to_vec();
        let mut tm = theta.to_vec();
        tp[k] += h;
        tm[k] -= h;
        let plus = forward_kinematics_deflected(chain, model, q, &tp).unwrap();
        let minus = forward_kinematics_deflected(chain, model, q, &tm).unwrap();
        let col = twist_fd(&plus, &minus, h);
        for r in 0..6 {
            out[(r, k)] = col[r];
        }
    }
    out
}

fn random_offsets(n: usize) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|j| Vector3::new(0.01 * j as f64, -0.02, 0.03 * (j as f64).sin()))
        .collect()
}

proptest! {
    #![proptest_config(config(48))]

    /// Acceptance: Jacobian columns = central differences of FK under small virtual
    /// rotations, to 1e-8 (chains of ≤ 7 links of ≤ 0.7 m: |J| ≲ 5).
    #[test]
    fn jacobian_matches_fk_differences((chain, q) in arb_chain_and_q(1..=7), offsets in any::<bool>()) {
        let n = chain.n_joints();
        let mut model = VirtualJointModel::extended(n);
        if offsets {
            model = model.with_offsets(random_offsets(n)).unwrap();
        }
        let j = jacobian(&chain, &model, &q).unwrap();
        let fd = jacobian_fd(&chain, &model, &q, &vec![0.0; model.n_params()]);
        let err = (&j - &fd).amax();
        prop_assert!(err < 1e-8, "max |J − FD| = {err:e}");
    }

    /// The slow deflected Jacobian (used for K_C checks) is itself right at θ ≠ 0.
    #[test]
    fn deflected_jacobian_matches_fk_differences((chain, q) in arb_chain_and_q(1..=5), t in prop::collection::vec(-0.3f64..0.3, 15)) {
        let model = VirtualJointModel::extended(chain.n_joints());
        let theta = &t[..model.n_params()];
        let j = jacobian_deflected(&chain, &model, &q, theta).unwrap();
        let fd = jacobian_fd(&chain, &model, &q, theta);
        prop_assert!((&j - &fd).amax() < 1e-8);
    }

    /// Acceptance: K_C = ∂(JᵀF)/∂θ, by central differences of the deflected Jacobian,
    /// to 1e-6 relative to ‖K_C‖_max.
    #[test]
    fn kc_matches_differences_of_jt_f((chain, q) in arb_chain_and_q(1..=7), f in arb_wrench(), offsets in any::<bool>()) {
        let n = chain.n_joints();
        let mut model = VirtualJointModel::extended(n);
        if offsets {
            model = model.with_offsets(random_offsets(n)).unwrap();
        }
        let m = model.n_params();
        let kc = complementary_stiffness(&chain, &model, &q, &f).unwrap();
        let fv = nalgebra::DVector::from_column_slice(&f);
        let h = 1e-6;
        let mut fd = DMatrix::zeros(m, m);
        for i in 0..m {
            let mut tp = vec![0.0; m];
            let mut tm = vec![0.0; m];
            tp[i] = h;
            tm[i] = -h;
            let gp = jacobian_deflected(&chain, &model, &q, &tp).unwrap().transpose() * &fv;
            let gm = jacobian_deflected(&chain, &model, &q, &tm).unwrap().transpose() * &fv;
            fd.set_column(i, &((gp - gm) / (2.0 * h)));
        }
        let scale = kc.amax().max(1e-12);
        let err = (&kc - &fd).amax() / scale;
        prop_assert!(err < 1e-6, "relative K_C error {err:e}");
    }

    /// The fast, buffer-based paths equal the allocating one and the batched one.
    #[test]
    fn in_place_and_batched_agree((chain, q) in arb_chain_and_q(1..=7)) {
        let model = VirtualJointModel::extended(chain.n_joints());
        let m = model.n_params();
        let j = jacobian(&chain, &model, &q).unwrap();
        let slow = jacobian_deflected(&chain, &model, &q, &vec![0.0; m]).unwrap();
        prop_assert!((&j - &slow).amax() < 1e-12);
        let mut ws = Workspace::new(&chain, &model).unwrap();
        let mut q2 = q.clone();
        q2.extend(q.iter().map(|v| v * 0.5));
        let mut out = vec![0.0; 2 * 6 * m];
        jacobian_batch_in_place(&chain, &model, &q2, &mut ws, &mut out).unwrap();
        // The batch runs lane-wise with fused multiply-adds, so it agrees to rounding, not
        // bitwise (|J| ≲ 5 here; a misplaced lane or column would differ by O(1)).
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-14 * 8.0);
        prop_assert!(close(&out[..6 * m], j.as_slice()));
        let half: Vec<f64> = q.iter().map(|v| v * 0.5).collect();
        let mut one = vec![0.0; 6 * m];
        jacobian_in_place(&chain, &model, &half, &mut ws, &mut one).unwrap();
        prop_assert!(close(&out[6 * m..], &one[..]));
    }
}

/// The spring axes follow docs/conventions.md: z = a, x = u, y = a × u, orthonormal.
#[test]
fn spring_axes_convention() {
    let [z, x, y] = spring_axes(&Vector3::z());
    assert_eq!((z, x, y), (Vector3::z(), Vector3::x(), Vector3::y()));
    // x̂ ∥ a: ŷ replaces x̂.
    let [z, x, y] = spring_axes(&-Vector3::x());
    assert_eq!(z, -Vector3::x());
    assert!((x - Vector3::y()).norm() < 1e-15);
    assert!((y - (-Vector3::x()).cross(&Vector3::y())).norm() < 1e-15);
    // A generic axis: u is x̂ with its a-component removed.
    let a = Vector3::new(1.0, 2.0, 2.0) / 3.0;
    let [_, u, v] = spring_axes(&a);
    let expect = (Vector3::x() - a * a.x).normalize();
    assert!((u - expect).norm() < 1e-15);
    assert!(u.dot(&a).abs() < 1e-15 && v.dot(&a).abs() < 1e-15 && (v.norm() - 1.0).abs() < 1e-15);
}

/// On the Panda at q = 0 the torsion columns are the URDF joint axes through the joint
/// origins (hand-checked geometry): joint 1 is the base z axis, the flange is at
/// (0.088, 0, 0.926) and pointing down.
#[test]
fn panda_zero_pose_geometry() {
    let panda = SerialChain::bundled();
    let tip = panda.forward_kinematics(&[0.0; 7]).unwrap();
    let p = tip.translation.vector;
    assert!((p - Vector3::new(0.088, 0.0, 0.926)).norm() < 1e-12, "{p}");
    assert!((tip.rotation * Vector3::z() - (-Vector3::z())).norm() < 1e-12);
    let model = VirtualJointModel::traditional(7);
    let j = jacobian(&panda, &model, &[0.0; 7]).unwrap();
    // Joint 1: w = z, linear = z × (p − 0) = (0, 0.088, 0).
    let col: Vec<f64> = j.column(0).iter().copied().collect();
    let expect = [0.0, 0.088, 0.0, 0.0, 0.0, 1.0];
    for (a, b) in col.iter().zip(expect) {
        assert!((a - b).abs() < 1e-12, "{col:?}");
    }
    // Joint 7 axis passes through the flange: zero linear part.
    assert!(j.column(6).rows(0, 3).norm() < 1e-12);
}

/// A custom subset model gives exactly the matching columns of the extended model.
#[test]
fn subset_model_columns_match_extended() {
    let panda = SerialChain::bundled();
    let q = &random_configurations(&panda, 1, 11)[..];
    let ext = jacobian(&panda, &VirtualJointModel::extended(7), q).unwrap();
    let springs = vec![
        Spring::rotation(1, SpringAxis::Y),
        Spring::rotation(4, SpringAxis::Z),
        Spring::rotation(4, SpringAxis::X),
    ];
    let sub = jacobian(
        &panda,
        &VirtualJointModel::from_springs(7, springs).unwrap(),
        q,
    )
    .unwrap();
    for (c, e) in [(0, 5), (1, 12), (2, 13)] {
        assert_eq!(sub.column(c), ext.column(e));
    }
}
