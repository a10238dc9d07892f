//! The full virtual-joint model (issue 23 item 2): translational link springs beside the
//! rotations, checked against independent code paths.

use nalgebra::{DVector, Vector3};
use vjm::Measurements;
use vjm::{
    complementary_stiffness, forward_kinematics_deflected, identify, jacobian,
    jacobian_batch_in_place, jacobian_deflected, IdentifyOptions, SerialChain, VirtualJointModel,
    Workspace,
};

use crate::identification::{assert_recovers, synthetic};
use crate::strategies::{random_compliances, random_configurations};

/// Every column of the full model's Jacobian (translations included) equals central finite
/// differences of the tip pose of the deflected chain (`forward_kinematics_deflected`, which
/// composes the springs' isometries: a code path that shares nothing with the columns).
#[test]
fn full_columns_equal_finite_differences_of_the_deflected_chain() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::full(7);
    let m = model.n_params();
    let h = 1e-6;
    for q in random_configurations(&panda, 5, 11).chunks_exact(7) {
        let j = jacobian(&panda, &model, q).unwrap();
        for k in 0..m {
            let mut plus = vec![0.0; m];
            let mut minus = vec![0.0; m];
            plus[k] = h;
            minus[k] = -h;
            let tp = forward_kinematics_deflected(&panda, &model, q, &plus).unwrap();
            let tm = forward_kinematics_deflected(&panda, &model, q, &minus).unwrap();
            let lin = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
            let ang = (tp.rotation * tm.rotation.inverse()).scaled_axis() / (2.0 * h);
            let col = j.column(k);
            let want_lin = Vector3::new(col[0], col[1], col[2]);
            let want_ang = Vector3::new(col[3], col[4], col[5]);
            assert!(
                (lin - want_lin).norm() < 1e-8,
                "{}: {lin} vs {want_lin}",
                model.labels()[k]
            );
            assert!(
                (ang - want_ang).norm() < 1e-8,
                "{}: {ang} vs {want_ang}",
                model.labels()[k]
            );
            if model.springs()[k].is_translation() {
                assert_eq!(want_ang, Vector3::zeros());
                assert!((want_lin.norm() - 1.0).abs() < 1e-12);
            }
        }
    }
}

/// K_C of the full model equals finite differences of Jᵀ(θ)F along the deflected chain.
#[test]
fn full_complementary_stiffness_equals_finite_differences() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::full(7);
    let m = model.n_params();
    let wrench = [30.0, -20.0, 45.0, 2.0, -3.0, 1.5];
    let w = DVector::from_column_slice(&wrench);
    let h = 1e-6;
    let q = [0.3, -0.4, 0.2, -2.0, 0.1, 1.7, 0.6];
    let kc = complementary_stiffness(&panda, &model, &q, &wrench).unwrap();
    let scale = kc.amax();
    for i in 0..m {
        let mut plus = vec![0.0; m];
        let mut minus = vec![0.0; m];
        plus[i] = h;
        minus[i] = -h;
        let gp = jacobian_deflected(&panda, &model, &q, &plus)
            .unwrap()
            .transpose()
            * &w;
        let gm = jacobian_deflected(&panda, &model, &q, &minus)
            .unwrap()
            .transpose()
            * &w;
        let fd = (gp - gm) / (2.0 * h);
        for k in 0..m {
            assert!(
                (fd[k] - kc[(k, i)]).abs() < 1e-6 * scale,
                "K_C[{k},{i}] ({} / {}): {} vs {}",
                model.labels()[k],
                model.labels()[i],
                kc[(k, i)],
                fd[k]
            );
        }
    }
}

/// The lane-wise batched Jacobian equals the scalar one for the full model.
#[test]
fn full_batched_jacobian_equals_the_scalar_one() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::full(7);
    let q = random_configurations(&panda, 13, 5);
    let mut ws = Workspace::new(&panda, &model).unwrap();
    let mut out = vec![0.0; 13 * 6 * 42];
    jacobian_batch_in_place(&panda, &model, &q, &mut ws, &mut out).unwrap();
    for (i, qi) in q.chunks_exact(7).enumerate() {
        let j = jacobian(&panda, &model, qi).unwrap();
        for (a, b) in j.as_slice().iter().zip(&out[i * 252..(i + 1) * 252]) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
}

/// Identify recovers hidden link translational compliances (and the rotations) of the full
/// model from noise-free data, through the lane-wise streaming path.
#[test]
fn identify_recovers_link_translations_of_the_full_model() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::full(7);
    let mut truth = random_compliances(42, 3);
    // Translational compliances of order 1e-7 m/N (a link of 10 N/µm).
    for (c, s) in truth.iter_mut().zip(model.springs()) {
        if s.is_translation() {
            *c *= 1e-1;
        }
    }
    let (q, f, d, r) = synthetic(&panda, &model, &truth, 400, 21);
    let mut opts = IdentifyOptions::default();
    opts.use_rotations = true;
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    assert_recovers(&id, &truth, 1e-6);
    assert!(
        id.rank > 21,
        "the translations add directions: rank {}",
        id.rank
    );
    // The result names each parameter as the model does (a translation is `J4tz`, not `J4z`),
    // and its JSON states the kind of a translation only.
    let labels: Vec<String> = id.parameters.iter().map(|p| p.label()).collect();
    assert_eq!(labels, model.labels());
    let json = serde_json::to_value(&id.parameters).unwrap();
    assert_eq!(json[3]["kind"], "translation");
    assert!(json[0].get("kind").is_none(), "{}", json[0]);
    for c in &id.combinations {
        for t in &c.terms {
            assert_eq!(t.label(), labels[t.param]);
        }
    }
}

/// The vocabulary: `full`, translation labels and `link_translation(...)` findings.
#[test]
fn the_vocabulary_reads_translations() {
    let full = VirtualJointModel::parse(7, "full").unwrap();
    assert_eq!(full.name(), "full");
    assert_eq!(full.n_params(), 42);
    assert_eq!(
        &full.labels()[..6],
        ["J1z", "J1x", "J1y", "J1tz", "J1tx", "J1ty"]
    );
    let m = VirtualJointModel::parse(7, "traditional + link_translation(J4z) + J2ty").unwrap();
    assert_eq!(m.name(), "custom");
    assert!(m.labels().contains(&"J4tz".to_string()));
    assert!(m.labels().contains(&"J2ty".to_string()));
    assert_eq!(
        VirtualJointModel::parse(7, "extended + J1tz, J1tx, J1ty, J2tz, J2tx, J2ty, J3tz, J3tx, J3ty, J4tz, J4tx, J4ty, J5tz, J5tx, J5ty, J6tz, J6tx, J6ty, J7tz, J7tx, J7ty")
            .unwrap()
            .name(),
        "full"
    );
    assert!(VirtualJointModel::parse(7, "link_translation(J4tz)").is_err());
    assert!(VirtualJointModel::parse(7, "joint_tilt(J4tz)").is_err());
    assert!(VirtualJointModel::parse(7, "J8tz").is_err());
    // Extended and traditional are unchanged.
    assert_eq!(
        VirtualJointModel::parse(7, "extended").unwrap(),
        VirtualJointModel::extended(7)
    );
}

/// A full model round-trips through the model file (labels `J3tx`, name `full`, bitwise
/// predictions) and its predictions equal the static equilibrium of the deflected chain
/// (`vjm::gravity::static_equilibrium`: composed isometries, no Jacobian) to second order in
/// the load.
#[test]
fn a_full_model_round_trips_through_the_file_and_predicts_the_equilibrium() {
    use vjm::gravity::{static_equilibrium, Loading};
    use vjm::{DataSource, Load, StiffnessModel};
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::full(7);
    let mut truth = random_compliances(42, 8);
    for (c, s) in truth.iter_mut().zip(model.springs()) {
        if s.is_translation() {
            *c *= 1e-1;
        }
    }
    let (q, f, d, r) = synthetic(&panda, &model, &truth, 400, 31);
    let mut opts = IdentifyOptions::default();
    opts.use_rotations = true;
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    let sm =
        StiffnessModel::from_identification(&id, &panda, &model, &opts, DataSource::in_memory(400))
            .unwrap();
    assert!(sm.springs().labels.iter().any(|l| l == "J4tz"));
    let back = StiffnessModel::from_json(&sm.to_json(), "<full>").unwrap();
    assert_eq!(back, sm);
    assert_eq!(back.spring_model().unwrap(), model);
    let q_new = random_configurations(&panda, 6, 77);
    let wrench = [20.0, -15.0, 30.0, 1.0, -2.0, 0.5];
    let w_all: Vec<f64> = (0..6).flat_map(|_| wrench).collect();
    let a = sm.predict(&panda, &q_new, Load::Wrench(&w_all)).unwrap();
    let b = back.predict(&panda, &q_new, Load::Wrench(&w_all)).unwrap();
    for ((pa, pb), qi) in a.iter().zip(&b).zip(q_new.chunks_exact(7)) {
        assert_eq!(
            pa.deflection.map(f64::to_bits),
            pb.deflection.map(f64::to_bits)
        );
        let loading = Loading {
            gravity: None,
            payload: None,
            wrench: Some(wrench),
        };
        let eq = static_equilibrium(&panda, &model, &truth, qi, &loading).unwrap();
        let rigid = forward_kinematics_deflected(&panda, &model, qi, &[0.0; 42]).unwrap();
        let dp = eq.tip.translation.vector - rigid.translation.vector;
        let scale = dp.norm();
        for k in 0..3 {
            // The prediction is linear in the load about the undeflected state; the
            // equilibrium's remainder is of order (C·load)² ≈ 1e-3 of the deflection.
            assert!(
                (pa.deflection[k] - dp[k]).abs() < 1e-2 * scale,
                "component {k}: {} vs {}",
                pa.deflection[k],
                dp[k]
            );
        }
    }
}
