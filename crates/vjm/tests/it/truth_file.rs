//! The testbed's truth as written to `truth.json`: joints 1-based like every file and output
//! (the Rust values stay 0-based, as in `vjm::model::Spring`).

use vjm::testbed::{Effect, HarmonicDriveSpring, TrueModel};
use vjm::SpringAxis;

#[test]
fn truth_json_counts_joints_from_one() {
    let spring = HarmonicDriveSpring {
        k1: 1000.0,
        k2: 2000.0,
        k3: 4000.0,
        t1: 5.0,
        t2: 15.0,
    };
    let truth = TrueModel::nominal(7)
        .with_effect(Effect::JointTilt {
            joint: 2,
            axis: SpringAxis::X,
            compliance: 5e-5,
        })
        .with_effect(Effect::TorsionNonlinear { joint: 0, spring })
        .with_effect(Effect::Backlash {
            joint: 6,
            lost_motion: 2e-4,
        });
    let v = serde_json::to_value(&truth).unwrap();
    let joints: Vec<u64> = v["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["joint"].as_u64().unwrap())
        .collect();
    assert_eq!(joints, vec![3, 1, 7]);
    assert_eq!(v["effects"][0]["effect"], "joint_tilt");
}
