//! Optional cross-check against pinocchio on example-robot-data URDFs.
//!
//! Runs when `python3 -c "import pinocchio"` works and the example-robot-data URDFs are
//! found (through the `example_robot_data` module, or the cmeel prefix that the `pin` and
//! `example-robot-data` wheels install into); otherwise prints that it skipped.

use std::process::Command;

use vjm::{jacobian, SerialChain, VirtualJointModel};

const SCRIPT: &str = r#"
import json, os, sys
import numpy as np
import pinocchio as pin
name, tip, qs = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
path = None
try:
    import example_robot_data as erd
    path = erd.getModelPath(name) 
    path = os.path.join(path, name) if os.path.isdir(path) else path
except Exception:
    pass
if path is None or not os.path.isfile(path):
    prefix = os.path.dirname(pin.__file__)
    while prefix != os.path.dirname(prefix) and os.path.basename(prefix) != "cmeel.prefix":
        prefix = os.path.dirname(prefix)
    robots = os.path.join(prefix, "share", "example-robot-data", "robots")
    path = None
    for root, _, files in os.walk(robots):
        if name in files:
            path = os.path.join(root, name)
            break
if path is None:
    print(json.dumps({"skip": "no " + name}))
    sys.exit(0)
model = pin.buildModelFromUrdf(path)
data = model.createData()
fid = model.getFrameId(tip)
names = [n for n in qs["joints"]]
out = []
for qv in qs["q"]:
    q = pin.neutral(model)
    for n, v in zip(names, qv):
        j = model.joints[model.getJointId(n)]
        if j.nq == 2:
            q[j.idx_q], q[j.idx_q + 1] = np.cos(v), np.sin(v)
        else:
            q[j.idx_q] = v
    J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
    cols = [model.joints[model.getJointId(n)].idx_v for n in names]
    out.append(J[:, cols].T.tolist())
print(json.dumps({"path": path, "jacobians": out}))
"#;

fn pinocchio_available() -> bool {
    Command::new("python3")
        .args(["-c", "import pinocchio"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Returns the URDF path and, per configuration, pinocchio's columns (one per joint).
fn pinocchio_columns(
    urdf: &str,
    tip: &str,
    joints: &[String],
    qs: &[Vec<f64>],
) -> Option<(String, Vec<Vec<Vec<f64>>>)> {
    let arg = serde_json::json!({ "joints": joints, "q": qs }).to_string();
    let out = Command::new("python3")
        .args(["-c", SCRIPT, urdf, tip, &arg])
        .output()
        .ok()?;
    assert!(
        out.status.success(),
        "pinocchio script failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("script prints JSON");
    if let Some(s) = v.get("skip") {
        println!("pinocchio cross-check skipped: {s}");
        return None;
    }
    let path = v["path"].as_str()?.to_string();
    let jac = serde_json::from_value(v["jacobians"].clone()).ok()?;
    Some((path, jac))
}

fn cross_check(urdf: &str, joints_hint: &[&str], base: &str, tip: &str) {
    if !pinocchio_available() {
        println!("pinocchio cross-check skipped: python3 cannot import pinocchio (pip install pin example-robot-data)");
        return;
    }
    let joints: Vec<String> = joints_hint.iter().map(|s| s.to_string()).collect();
    // Configurations inside typical limits, deterministic.
    let qs: Vec<Vec<f64>> = (0..5)
        .map(|i| {
            (0..joints.len())
                .map(|j| 0.9 * ((1 + i * 7 + j * 3) as f64).sin() - if j == 3 { 1.2 } else { 0.0 })
                .collect()
        })
        .collect();
    let Some((path, reference)) = pinocchio_columns(urdf, tip, &joints, &qs) else {
        return;
    };
    let chain = SerialChain::from_urdf_file(&path, base, tip).unwrap();
    assert_eq!(chain.joint_names(), joints.as_slice());
    let model = VirtualJointModel::traditional(chain.n_joints());
    let mut worst = 0.0f64;
    for (q, cols) in qs.iter().zip(&reference) {
        let j = jacobian(&chain, &model, q).unwrap();
        for (k, col) in cols.iter().enumerate() {
            for r in 0..6 {
                worst = worst.max((j[(r, k)] - col[r]).abs());
            }
        }
    }
    println!("pinocchio cross-check {urdf} ({base} → {tip}): max |J_vjm − J_pin| = {worst:e}");
    assert!(worst < 1e-10, "{urdf}: {worst:e}");
}

/// example-robot-data's panda.urdf, tip panda_hand_tcp: z-columns = pinocchio's frame
/// Jacobian (LOCAL_WORLD_ALIGNED) to 1e-10.
#[test]
fn panda_matches_pinocchio() {
    let joints: Vec<String> = (1..=7).map(|i| format!("panda_joint{i}")).collect();
    let refs: Vec<&str> = joints.iter().map(String::as_str).collect();
    cross_check("panda.urdf", &refs, "panda_link0", "panda_hand_tcp");
}

/// example-robot-data's xarm7.urdf, tip link_eef.
#[test]
fn xarm7_matches_pinocchio() {
    let joints: Vec<String> = (1..=7).map(|i| format!("joint{i}")).collect();
    let refs: Vec<&str> = joints.iter().map(String::as_str).collect();
    cross_check("xarm7.urdf", &refs, "world", "link_eef");
}
