//! Every bad input of issue 3 gives an error naming the offending item; nothing panics.

use vjm::Measurements;
use vjm::{
    complementary_stiffness, identify, jacobian, jacobian_in_place, predict_deflection,
    IdentifyOptions, SerialChain, SolveMethod, Spring, SpringAxis, VirtualJointModel, VjmError,
    Workspace, BUNDLED_URDF,
};

fn two_link(extra: &str) -> String {
    format!(
        r#"<robot name="r">
      <link name="base"/><link name="l1"/><link name="l2"/>{extra}
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>"#
    )
}

#[test]
fn missing_link_names_the_link_and_role() {
    let err = SerialChain::from_urdf_str(BUNDLED_URDF, "panda_link0", "panda_link9").unwrap_err();
    assert!(
        matches!(&err, VjmError::MissingLink { role: "tip", name, .. } if name == "panda_link9")
    );
    let msg = err.to_string();
    assert!(
        msg.contains("tip link `panda_link9`") && msg.contains("panda_link8"),
        "{msg}"
    );
    let err = SerialChain::from_urdf_str(BUNDLED_URDF, "world", "panda_link8").unwrap_err();
    assert!(err.to_string().contains("base link `world`"));
}

#[test]
fn base_not_ancestor_of_tip() {
    let err = SerialChain::from_urdf_str(BUNDLED_URDF, "panda_link5", "panda_link2").unwrap_err();
    assert!(
        matches!(&err, VjmError::NotAncestor { base, tip, root } if base == "panda_link5" && tip == "panda_link2" && root == "panda_link0")
    );
    // Sibling branches: a finger is not an ancestor of the TCP.
    let err =
        SerialChain::from_urdf_str(BUNDLED_URDF, "panda_leftfinger", "panda_hand_tcp").unwrap_err();
    assert!(err
        .to_string()
        .contains("`panda_leftfinger` is not an ancestor of the tip link `panda_hand_tcp`"));
}

#[test]
fn closed_chain_names_the_link_and_joints() {
    let xml = two_link(
        r#"<joint name="loop" type="revolute"><parent link="base"/><child link="l2"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#,
    );
    let err = SerialChain::from_urdf_str(&xml, "base", "l2").unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, VjmError::ClosedChain { .. }), "{msg}");
    assert!(
        msg.contains("`l2`") && msg.contains("j2") && msg.contains("loop"),
        "{msg}"
    );
}

#[test]
fn mimic_joint_on_chain_is_rejected_by_name() {
    let xml = r#"<robot name="r">
      <link name="base"/><link name="l1"/><link name="l2"/>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="j1" multiplier="2"/></joint>
    </robot>"#;
    let err = SerialChain::from_urdf_str(xml, "base", "l2").unwrap_err();
    assert!(
        matches!(&err, VjmError::MimicJoint { joint, mimics } if joint == "j2" && mimics == "j1"),
        "{err}"
    );
    // A mimic joint off the chain (the Panda's right finger) is fine.
    assert!(SerialChain::bundled_with_tip("panda_hand_tcp").is_ok());
}

#[test]
fn malformed_urdf_and_zero_axis() {
    let err = SerialChain::from_urdf_str("<robot name=\"r\"><link", "a", "b").unwrap_err();
    assert!(matches!(err, VjmError::Urdf { .. }), "{err}");
    let xml = two_link("").replacen("<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 0 0\"/>", 1);
    let err = SerialChain::from_urdf_str(&xml, "base", "l2").unwrap_err();
    assert!(
        err.to_string().contains("joint `j1` has an invalid axis"),
        "{err}"
    );
}

#[test]
fn nan_in_q_or_wrench_names_row_and_column() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let mut q = vec![0.1; 7];
    q[4] = f64::NAN;
    let err = jacobian(&panda, &model, &q).unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::NonFinite {
                what: "q",
                column: 4,
                ..
            }
        ),
        "{err}"
    );
    let err = complementary_stiffness(
        &panda,
        &model,
        &[0.0; 7],
        &[0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0],
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::NonFinite {
                what: "wrench",
                column: 1,
                ..
            }
        ),
        "{err}"
    );
    // Batched identification: row and column of the bad entry.
    let n = 30;
    let mut qs = vec![0.2; n * 7];
    let mut f = vec![1.0; n * 6];
    let d = vec![0.0; n * 3];
    qs[7 * 12 + 3] = f64::NAN;
    let opts = IdentifyOptions::default();
    let err = identify(&panda, &model, Measurements::new(&qs, &f, &d), &opts).unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::NonFinite {
                what: "q",
                row: 12,
                column: 3,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("row 12, column 3"));
    qs[7 * 12 + 3] = 0.0;
    f[6 * 20 + 5] = f64::NAN;
    let err = identify(&panda, &model, Measurements::new(&qs, &f, &d), &opts).unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::NonFinite {
                what: "wrench",
                row: 20,
                column: 5,
                ..
            }
        ),
        "{err}"
    );
}

/// The normal-equations path checks values only when its Gram matrix comes out non-finite;
/// every reduction must still name the bad entry, and finite values whose squares overflow
/// get a numerical error, not NaN estimates.
#[test]
fn non_finite_measurements_are_named_by_every_reduction() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let n = 40;
    let q: Vec<f64> = (0..n * 7).map(|i| 0.05 * (i % 13) as f64).collect();
    let f: Vec<f64> = (0..n * 6).map(|i| 1.0 + (i % 5) as f64).collect();
    let mut d = vec![1e-4; n * 3];
    let mut r = vec![1e-5; n * 3];
    d[3 * 33 + 2] = f64::NAN;
    r[3 * 7 + 1] = f64::INFINITY;
    for method in [
        SolveMethod::Auto,
        SolveMethod::NormalEquations,
        SolveMethod::Qr,
    ] {
        let mut opts = IdentifyOptions::default();
        opts.method = method;
        let err = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap_err();
        assert!(
            matches!(
                err,
                VjmError::NonFinite {
                    what: "displacement",
                    row: 33,
                    column: 2,
                    ..
                }
            ),
            "{method:?}: {err}"
        );
        let mut d_ok = d.clone();
        d_ok[3 * 33 + 2] = 0.0;
        opts.use_rotations = true;
        let err = identify(
            &panda,
            &model,
            Measurements::new(&q, &f, &d_ok).with_rotation(Some(&r)),
            &opts,
        )
        .unwrap_err();
        assert!(
            matches!(
                err,
                VjmError::NonFinite {
                    what: "rotation",
                    row: 7,
                    column: 1,
                    ..
                }
            ),
            "{method:?}: {err}"
        );
        // Rotations are not used: their bad value does not matter.
        opts.use_rotations = false;
        assert!(identify(
            &panda,
            &model,
            Measurements::new(&q, &f, &d_ok).with_rotation(Some(&r)),
            &opts
        )
        .is_ok());
    }
    let mut huge = vec![1e-4; n * 3];
    huge[5] = 1e160;
    let err = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &huge),
        &IdentifyOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, VjmError::Numerical { .. }), "{err}");
    assert!(err.to_string().contains("overflow"), "{err}");
}

#[test]
fn shape_mismatches_state_expected_and_got() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let err = jacobian(&panda, &model, &[0.0; 6]).unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::ShapeMismatch {
                expected: 7,
                got: 6,
                ..
            }
        ),
        "{err}"
    );
    let mut ws = Workspace::new(&panda, &model).unwrap();
    let err = jacobian_in_place(&panda, &model, &[0.0; 7], &mut ws, &mut [0.0; 10]).unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::ShapeMismatch {
                expected: 126,
                got: 10,
                ..
            }
        ),
        "{err}"
    );
    let opts = IdentifyOptions::default();
    let err = identify(
        &panda,
        &model,
        Measurements::new(&[0.0; 70], &[0.0; 59], &[0.0; 30]),
        &opts,
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .contains("wrench (N×6): expected 60 values, got 59"),
        "{err}"
    );
    let err = identify(
        &panda,
        &model,
        Measurements::new(&[0.0; 69], &[0.0; 60], &[0.0; 30]),
        &opts,
    )
    .unwrap_err();
    assert!(err.to_string().contains("q (N×n"), "{err}");
    // A model for another chain, and a workspace for another model.
    let err = jacobian(&panda, &VirtualJointModel::extended(6), &[0.0; 7]).unwrap_err();
    assert!(
        err.to_string().contains("6 joints") && err.to_string().contains("has 7"),
        "{err}"
    );
    let mut ws6 = Workspace::new(&panda, &VirtualJointModel::traditional(7)).unwrap();
    assert!(jacobian_in_place(&panda, &model, &[0.0; 7], &mut ws6, &mut [0.0; 126]).is_err());
    // Prediction with the wrong number of compliances.
    let err =
        predict_deflection(&panda, &model, &[1e-6; 20], &[0.0; 7], &[0.0; 6], false).unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::ShapeMismatch {
                expected: 21,
                got: 20,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn too_few_measurements() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    // 6 measurements × 3 rows = 18 equations < 21 parameters.
    let err = identify(
        &panda,
        &model,
        Measurements::new(&[0.1; 42], &[1.0; 36], &[0.0; 18]),
        &IdentifyOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            VjmError::TooFewMeasurements {
                have: 18,
                need: 21,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("6 measurements"));
}

#[test]
fn invalid_models_and_options() {
    let dup = vec![
        Spring::rotation(0, SpringAxis::Z),
        Spring::rotation(0, SpringAxis::Z),
    ];
    let err = VirtualJointModel::from_springs(7, dup).unwrap_err();
    assert!(
        err.to_string().contains("J1z") && err.to_string().contains("twice"),
        "{err}"
    );
    let out = vec![Spring::rotation(9, SpringAxis::X)];
    assert!(VirtualJointModel::from_springs(7, out)
        .unwrap_err()
        .to_string()
        .contains("joint 10"));
    let order = vec![
        Spring::rotation(3, SpringAxis::X),
        Spring::rotation(1, SpringAxis::X),
    ];
    assert!(VirtualJointModel::from_springs(7, order)
        .unwrap_err()
        .to_string()
        .contains("base → tip"));
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let mut opts = IdentifyOptions::default();
    opts.noise_sigma[1] = 0.0;
    let err = identify(
        &panda,
        &model,
        Measurements::new(&[0.1; 70], &[1.0; 60], &[0.0; 30]),
        &opts,
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("noise_sigma") && err.to_string().contains("entry 1"),
        "{err}"
    );
    let mut opts = IdentifyOptions::default();
    opts.use_rotations = true;
    let err = identify(
        &panda,
        &model,
        Measurements::new(&[0.1; 70], &[1.0; 60], &[0.0; 30]),
        &opts,
    )
    .unwrap_err();
    assert!(err.to_string().contains("use_rotations"), "{err}");
}
