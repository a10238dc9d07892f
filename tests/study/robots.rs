//! The robots of the diagnose study: the bundled Panda and three arms from the
//! `example-robot-data` package (xArm7, UR5, Kinova j2s6s200), each with the torsional
//! compliances the study assumes for it.

use std::path::{Path, PathBuf};
use std::process::Command;

use vjm::testbed::NOMINAL_TORSION;
use vjm::SerialChain;

/// Finds example-robot-data's URDFs the way the pinocchio cross-check does
/// (`crates/vjm/tests/it/pinocchio.rs`): the `example_robot_data` module if it imports, else
/// the `robots/` folder of the cmeel prefix that the `example-robot-data` and `pin` wheels
/// install into (found on `sys.path`). `EXAMPLE_ROBOT_DATA_ROBOTS` overrides both.
const LOCATE: &str = r#"
import os, sys
name = sys.argv[1]
roots = []
try:
    import example_robot_data as erd
    roots.append(os.path.join(os.path.dirname(erd.__file__), "robots"))
    p = erd.getModelPath(name)
    roots.append(p)
except Exception:
    pass
for entry in sys.path:
    prefix = entry
    while prefix and prefix != os.path.dirname(prefix) and os.path.basename(prefix) != "cmeel.prefix":
        prefix = os.path.dirname(prefix)
    if os.path.basename(prefix) == "cmeel.prefix":
        roots.append(os.path.join(prefix, "share", "example-robot-data", "robots"))
    roots.append(os.path.join(entry, "cmeel.prefix", "share", "example-robot-data", "robots"))
for root in roots:
    for dirpath, _, files in os.walk(root):
        if name in files:
            print(os.path.join(dirpath, name))
            sys.exit(0)
sys.exit(3)
"#;

/// Why a robot could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RobotError {
    /// The URDF file was not found.
    #[error("{file} not found: install the example-robot-data package (pip install example-robot-data) or set EXAMPLE_ROBOT_DATA_ROBOTS to its robots/ folder")]
    NotFound {
        /// The URDF file name.
        file: String,
    },
    /// The URDF did not give a chain between the stated links.
    #[error("{file} ({base} → {tip}): {message}")]
    Chain {
        /// The URDF file name.
        file: String,
        /// Base link.
        base: String,
        /// Tip link.
        tip: String,
        /// The loader's message.
        message: String,
    },
    /// A robot name the study does not know.
    #[error("unknown robot `{0}` (known: panda, xarm7, ur5, kinova)")]
    Unknown(String),
}

/// Path of an example-robot-data URDF, e.g. `ur5_robot.urdf`.
pub fn example_robot_urdf(file: &str) -> Result<PathBuf, RobotError> {
    let not_found = || RobotError::NotFound { file: file.into() };
    if let Ok(root) = std::env::var("EXAMPLE_ROBOT_DATA_ROBOTS") {
        return find_under(Path::new(&root), file).ok_or_else(not_found);
    }
    let out = Command::new("python3")
        .args(["-c", LOCATE, file])
        .output()
        .map_err(|_| not_found())?;
    if !out.status.success() {
        return Err(not_found());
    }
    let path = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    if path.is_file() {
        Ok(path)
    } else {
        Err(not_found())
    }
}

fn find_under(root: &Path, file: &str) -> Option<PathBuf> {
    let mut stack = vec![root.to_path_buf()];
    // Bounded walk: example-robot-data has a few hundred folders.
    let mut visited = 0usize;
    while let Some(dir) = stack.pop() {
        visited += 1;
        if visited > 100_000 {
            return None;
        }
        for entry in std::fs::read_dir(&dir).ok()?.flatten() {
            let p = entry.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().is_some_and(|n| n == file) {
                return Some(p);
            }
        }
    }
    None
}

/// A robot of the study: its chain and the torsional compliances (rad/(N·m), base → tip) of
/// its clean truth.
#[derive(Debug, Clone)]
pub struct StudyRobot {
    /// Short name (`panda`, `xarm7`, `ur5`, `kinova`, `ur10`).
    pub name: &'static str,
    /// Where the chain comes from, e.g. `xarm7.urdf link_base → link_eef`.
    pub source: String,
    /// The serial chain.
    pub chain: SerialChain,
    /// Torsional compliance per joint, rad/(N·m).
    pub torsion: Vec<f64>,
}

/// The robots the study knows, in table order.
pub const ROBOTS: [&str; 5] = ["panda", "xarm7", "ur5", "kinova", "ur10"];

/// Torsional compliances (rad/(N·m)) assumed for each robot. The Panda's are the testbed's
/// nominal ones (docs/diagnose.md): 10 kN·m/rad on the 87 N·m joints down to 2 kN·m/rad at the
/// wrist. The others are scaled by the rated torque of each joint's drive (URDF `effort`) in
/// the same way: harmonic drives of a given size have a stiffness roughly proportional to
/// their rated torque, and these arms publish no joint stiffness.
pub fn torsion_of(name: &str) -> Option<Vec<f64>> {
    let t: Vec<f64> = match name {
        "panda" => NOMINAL_TORSION.to_vec(),
        // xArm7: efforts 50, 50, 30, 30, 30, 20, 20 N·m.
        "xarm7" => vec![1.5e-4, 1.5e-4, 2.0e-4, 2.0e-4, 2.0e-4, 3.0e-4, 3.0e-4],
        // UR5: 150 N·m (size-3) joints 1–3, 28 N·m (size-1) wrist joints 4–6.
        "ur5" => vec![1.0e-4, 1.0e-4, 1.0e-4, 3.0e-4, 3.0e-4, 3.0e-4],
        // Kinova j2s6s200: efforts 40, 80, 40, 20, 20, 20 N·m.
        "kinova" => vec![2.0e-4, 1.5e-4, 2.0e-4, 4.0e-4, 4.0e-4, 4.0e-4],
        // UR10: 330 N·m (size-4) joints 1–2, 150 N·m (size-3) joint 3, 56 N·m (size-2) wrist,
        // scaled from the UR5's 1e-4 at 150 N·m and 3e-4 at 28 N·m by the rated torque.
        "ur10" => vec![4.5e-5, 4.5e-5, 1.0e-4, 1.5e-4, 1.5e-4, 1.5e-4],
        _ => return None,
    };
    Some(t)
}

/// Loads a robot by name. Base and tip links: Panda `panda_link0 → panda_link8` (bundled,
/// the flange); xArm7 `link_base → link_eef`; UR5 `base_link → tool0`; Kinova j2s6s200
/// `j2s6s200_link_base → j2s6s200_end_effector`: the arm's own base (not a world or mounting
/// block link) to the tool flange frame the vendor defines.
pub fn load_robot(name: &str) -> Result<StudyRobot, RobotError> {
    let torsion = torsion_of(name).ok_or_else(|| RobotError::Unknown(name.into()))?;
    let (name, file, base, tip): (&'static str, &str, &str, &str) = match name {
        "panda" => {
            return Ok(StudyRobot {
                name: "panda",
                source: "bundled panda_arm.urdf panda_link0 → panda_link8".into(),
                chain: SerialChain::bundled(),
                torsion,
            })
        }
        "xarm7" => ("xarm7", "xarm7.urdf", "link_base", "link_eef"),
        "ur5" => ("ur5", "ur5_robot.urdf", "base_link", "tool0"),
        "ur10" => ("ur10", "ur10_robot.urdf", "base_link", "tool0"),
        "kinova" => (
            "kinova",
            "kinova.urdf",
            "j2s6s200_link_base",
            "j2s6s200_end_effector",
        ),
        other => return Err(RobotError::Unknown(other.into())),
    };
    let path = example_robot_urdf(file)?;
    let chain = SerialChain::from_urdf_file(&path, base, tip).map_err(|e| RobotError::Chain {
        file: file.into(),
        base: base.into(),
        tip: tip.into(),
        message: e.to_string(),
    })?;
    Ok(StudyRobot {
        name,
        source: format!("{file} {base} → {tip}"),
        chain,
        torsion,
    })
}
