//! Issue 14, Rust side: non-finite robot descriptions are refused at load, naming the joint and
//! the attribute (before the fix a NaN origin made `simulate` spin forever and Python return
//! NaN Jacobians).

use nalgebra::{Isometry3, Vector3};
use vjm::{SerialChain, VjmError};

/// Two revolute joints and a fixed tool joint; `{..}` placeholders are replaced per test.
const TEMPLATE: &str = r#"<robot name="two">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="{J1_XYZ}" rpy="{J1_RPY}"/><axis xyz="{J1_AXIS}"/>
    <limit lower="{J1_LOWER}" upper="{J1_UPPER}" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="l2"/><child link="tool"/>
    <origin xyz="{TOOL_XYZ}" rpy="0 0 0"/>
  </joint>
</robot>"#;

fn urdf(replace: &[(&str, &str)]) -> String {
    let mut s = TEMPLATE.to_string();
    for (k, v) in replace {
        s = s.replace(&format!("{{{k}}}"), v);
    }
    for (k, v) in [
        ("J1_XYZ", "0 0 0.1"),
        ("J1_RPY", "0 0 0"),
        ("J1_AXIS", "0 0 1"),
        ("J1_LOWER", "-2"),
        ("J1_UPPER", "2"),
        ("TOOL_XYZ", "0.2 0 0"),
    ] {
        s = s.replace(&format!("{{{k}}}"), v);
    }
    s
}

fn load(replace: &[(&str, &str)]) -> Result<SerialChain, VjmError> {
    SerialChain::from_urdf_str(&urdf(replace), "base", "tool")
}

#[test]
fn the_template_itself_loads() {
    let chain = load(&[]).unwrap();
    assert_eq!(chain.n_joints(), 2);
}

#[test]
fn non_finite_urdf_numbers_are_refused_naming_joint_and_attribute() {
    let cases: [(&str, &str, &str, &str); 8] = [
        ("J1_XYZ", "nan 0 0", "j1", "origin xyz"),
        ("J1_XYZ", "0 inf 0", "j1", "origin xyz"),
        ("J1_RPY", "0 NaN 0", "j1", "origin rpy"),
        ("J1_AXIS", "nan 0 1", "j1", "axis"),
        ("J1_LOWER", "nan", "j1", "limit lower"),
        ("J1_UPPER", "inf", "j1", "limit upper"),
        ("J1_UPPER", "-3", "j1", "limit"),
        ("TOOL_XYZ", "0 0 -inf", "tool_joint", "origin xyz"),
    ];
    for (key, value, joint, attribute) in cases {
        let err = load(&[(key, value)]).expect_err(&format!("{key}={value} must be refused"));
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("`{joint}`")) && msg.contains(attribute),
            "{key}={value}: {msg}"
        );
        assert!(!msg.contains("::"), "{msg}");
    }
}

#[test]
fn a_zero_length_axis_is_refused() {
    let err = load(&[("J1_AXIS", "0 0 0")]).unwrap_err();
    assert!(
        matches!(err, VjmError::InvalidAxis { ref joint, .. } if joint == "j1"),
        "{err}"
    );
}

#[test]
fn from_joints_refuses_non_finite_origins_and_nan_limits() {
    let good = || {
        (
            "a".to_string(),
            Isometry3::translation(0.0, 0.0, 0.1),
            Vector3::z(),
            (-1.0, 1.0),
        )
    };
    let mut bad_origin = good();
    bad_origin.1 = Isometry3::translation(f64::NAN, 0.0, 0.0);
    let mut bad_limit = good();
    bad_limit.3 = (f64::NAN, 1.0);
    for spec in [bad_origin, bad_limit] {
        let err =
            SerialChain::from_joints("b", "t", vec![spec], Isometry3::identity()).unwrap_err();
        assert!(err.to_string().contains("joint `a`"), "{err}");
    }
    // (-inf, inf) still means a continuous joint.
    let mut continuous = good();
    continuous.3 = (f64::NEG_INFINITY, f64::INFINITY);
    SerialChain::from_joints("b", "t", vec![continuous], Isometry3::identity()).unwrap();
}
