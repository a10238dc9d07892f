//! Loading chains from URDF.

use vjm::{SerialChain, BUNDLED_TCP, BUNDLED_URDF};

/// The bundled Panda branches at the hand (two fingers, one a mimic, both prismatic):
/// naming the TCP or the flange gives the 7-joint arm; the finger branch is ignored.
#[test]
fn branching_robot_with_named_tip() {
    let flange = SerialChain::bundled();
    let tcp = SerialChain::bundled_with_tip(BUNDLED_TCP).unwrap();
    assert_eq!(tcp.n_joints(), 7);
    assert_eq!(
        tcp.joint_names(),
        (1..=7)
            .map(|i| format!("panda_joint{i}"))
            .collect::<Vec<_>>()
            .as_slice()
    );
    assert_eq!(tcp.limits()[3], (-3.0718, -0.0698));
    // The TCP is 0.1034 m beyond the flange along the flange z axis, at any q.
    let q = [0.3, -0.5, 0.2, -2.0, 0.4, 1.6, -0.7];
    let a = flange.forward_kinematics(&q).unwrap();
    let b = tcp.forward_kinematics(&q).unwrap();
    let expect = a.translation.vector + a.rotation * nalgebra::Vector3::new(0.0, 0.0, 0.1034);
    assert!((b.translation.vector - expect).norm() < 1e-12);
    // The hand frame is turned −45° about z.
    let rel = a.inverse() * b;
    assert!((rel.rotation.angle() - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
}

/// A sub-chain between two inner links, and a finger (prismatic) tip is rejected by name.
#[test]
fn inner_subchain_and_prismatic_rejection() {
    let sub = SerialChain::from_urdf_str(BUNDLED_URDF, "panda_link2", "panda_link5").unwrap();
    assert_eq!(
        sub.joint_names(),
        ["panda_joint3", "panda_joint4", "panda_joint5"]
    );
    let err =
        SerialChain::from_urdf_str(BUNDLED_URDF, "panda_link0", "panda_leftfinger").unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("panda_finger_joint1") && msg.contains("prismatic"),
        "{msg}"
    );
}

/// Continuous joints get infinite limits; fixed joints before the first and after the
/// last actuated joint are folded into the origin and the tip offset.
#[test]
fn continuous_and_fixed_joints() {
    let xml = r#"<robot name="r">
      <link name="world"/><link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>
      <joint name="mount" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 1" rpy="0 0 1.5707963267948966"/></joint>
      <joint name="a" type="continuous"><parent link="base"/><child link="l1"/><axis xyz="0 0 2"/></joint>
      <joint name="b" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="t" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.5 0 0"/></joint>
    </robot>"#;
    let c = SerialChain::from_urdf_str(xml, "world", "tool").unwrap();
    assert_eq!(c.n_joints(), 2);
    assert_eq!(c.limits()[0], (f64::NEG_INFINITY, f64::INFINITY));
    // Axis normalised; mount turns x into y: at q = 0 the tool is at (0, 1.5, 1).
    assert!((c.joints()[0].axis().z - 1.0).abs() < 1e-15);
    let p = c
        .forward_kinematics(&[0.0, 0.0])
        .unwrap()
        .translation
        .vector;
    assert!(
        (p - nalgebra::Vector3::new(0.0, 1.5, 1.0)).norm() < 1e-12,
        "{p}"
    );
    // Joint b about the (rotated) y axis by +90°: the tool drops by 0.5 m.
    let p = c
        .forward_kinematics(&[0.0, std::f64::consts::FRAC_PI_2])
        .unwrap()
        .translation
        .vector;
    assert!(
        (p - nalgebra::Vector3::new(0.0, 1.0, 0.5)).norm() < 1e-12,
        "{p}"
    );
}

/// `from_urdf_file` reads files and names a missing path.
#[test]
fn from_file() {
    let dir = std::env::temp_dir().join(format!("vjm-urdf-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("panda.urdf");
    std::fs::write(&path, BUNDLED_URDF).unwrap();
    let c = SerialChain::from_urdf_file(&path, "panda_link0", "panda_link8").unwrap();
    assert_eq!(c.n_joints(), 7);
    let missing = dir.join("nope.urdf");
    let msg = SerialChain::from_urdf_file(&missing, "a", "b")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("nope.urdf"), "{msg}");
    std::fs::remove_dir_all(&dir).unwrap();
}
