//! The immutable kinematic model of a serial chain extracted from a URDF.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use stiffness_core::num::Short;

use crate::error::VjmError;
use crate::gravity::mass::{links_declaring_inertial, mass_source, MassSource};
use crate::gravity::MassModel;

/// The bundled 7-DoF arm: a Franka Emika Panda with hand, written from Franka's
/// published kinematic parameters (see `data/panda_arm.urdf`).
pub const BUNDLED_URDF: &str = include_str!("../data/panda_arm.urdf");
/// Base link of [`BUNDLED_URDF`].
pub const BUNDLED_BASE: &str = "panda_link0";
/// Flange link of [`BUNDLED_URDF`] (0.107 m along joint 7's axis), the default tip.
pub const BUNDLED_FLANGE: &str = "panda_link8";
/// Tool centre point of [`BUNDLED_URDF`] (0.1034 m beyond the flange).
pub const BUNDLED_TCP: &str = "panda_hand_tcp";

/// `(name, origin, axis, limits)` of one joint for [`SerialChain::from_joints`]: origin in
/// the previous joint's child frame (m), axis in the joint frame, limits in rad.
pub type JointSpec = (String, Isometry3<f64>, Vector3<f64>, (f64, f64));

/// One actuated (revolute or continuous) joint of a [`SerialChain`].
#[derive(Debug, Clone)]
pub struct ActuatedJoint {
    pub(crate) name: String,
    /// Pose of the joint frame in the previous joint's child frame (or the base frame for
    /// the first joint), with all fixed joints in between folded in.
    pub(crate) origin: Isometry3<f64>,
    /// Unit rotation axis, joint-frame components.
    pub(crate) axis: Vector3<f64>,
    pub(crate) limits: (f64, f64),
    /// `R_origin`, `R_origin·hat(a)`, `R_origin·hat(a)²`: with these the rotation of the
    /// child frame relative to the parent is `b0 + sin q·b1 + (1 − cos q)·b2` (Rodrigues),
    /// which saves a 3×3 product per joint in the hot Jacobian loop.
    pub(crate) b0: Matrix3<f64>,
    pub(crate) b1: Matrix3<f64>,
    pub(crate) b2: Matrix3<f64>,
    pub(crate) t: Vector3<f64>,
}

impl ActuatedJoint {
    /// The joint's URDF name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Pose of the joint frame in the previous actuated joint's child frame (base frame for
    /// the first joint), fixed joints folded in. Metres.
    pub fn origin(&self) -> &Isometry3<f64> {
        &self.origin
    }
    /// Unit rotation axis, joint-frame components (the same in the child frame).
    pub fn axis(&self) -> &Vector3<f64> {
        &self.axis
    }
    /// Position limits `(lower, upper)` in rad; `(-inf, inf)` for continuous joints.
    pub fn limits(&self) -> (f64, f64) {
        self.limits
    }
}

/// An immutable serial chain from a base link to a tip link (Model in pinocchio's
/// Model/Data split): actuated revolute joints base → tip, fixed joints folded in.
///
/// All poses are of frames in the base link frame; lengths in m, angles in rad.
///
/// ```
/// use vjm::SerialChain;
/// let panda = SerialChain::bundled();
/// assert_eq!(panda.n_joints(), 7);
/// let tip = panda.forward_kinematics(&[0.0; 7]).unwrap();
/// // Zero pose: the flange is 0.333 + 0.316 + 0.384 − 0.107 m above the base.
/// assert!((tip.translation.vector.z - 0.926).abs() < 1e-12);
/// ```
#[derive(Debug, Clone)]
pub struct SerialChain {
    base: String,
    tip: String,
    joints: Vec<ActuatedJoint>,
    names: Vec<String>,
    limits: Vec<(f64, f64)>,
    /// Pose of the tip frame in the last actuated joint's child frame.
    tip_offset: Isometry3<f64>,
    /// Where the chain came from (URDF path and content hash), when it came from a URDF.
    source: Option<UrdfSource>,
    /// The bodies the actuated joints carry (from the URDF's inertials), for gravity.
    masses: MassSource,
}

/// The URDF a [`SerialChain`] was read from: the path as given and the SHA-256 of its text.
/// A saved stiffness model records it, and loading the model checks it against the chain.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UrdfSource {
    /// The path as the caller gave it; `bundled:panda_arm.urdf` for the bundled arm; `None`
    /// for URDF text given directly.
    pub path: Option<String>,
    /// SHA-256 of the URDF text, lowercase hex.
    pub sha256: String,
}

/// SHA-256 of the earlier revisions of [`BUNDLED_URDF`] with the same kinematics (before its
/// inertials were added), which a saved model may still name.
pub(crate) const BUNDLED_URDF_EARLIER_SHA256: &[&str] =
    &["97135d0b29577346c1becc93f40679498936456ef8a94bf24b109e208be8cd4c"];

/// Name under which the bundled URDF is recorded in a [`UrdfSource`].
pub const BUNDLED_URDF_PATH: &str = "bundled:panda_arm.urdf";

impl SerialChain {
    /// Loads the chain from `base` to `tip` from a URDF file.
    pub fn from_urdf_file(path: impl AsRef<Path>, base: &str, tip: &str) -> Result<Self, VjmError> {
        Self::from_urdf_file_with_text(path, base, tip).map(|(chain, _)| chain)
    }

    /// [`from_urdf_file`](Self::from_urdf_file), also returning the URDF text read, so that
    /// the same chain can be rebuilt where the file does not exist
    /// ([`from_urdf_str_read_from`](Self::from_urdf_str_read_from)).
    pub fn from_urdf_file_with_text(
        path: impl AsRef<Path>,
        base: &str,
        tip: &str,
    ) -> Result<(Self, String), VjmError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        // Capped: a huge file (or an endless stream) is refused without being read whole.
        let xml = crate::bounded::read_capped(path, crate::bounded::URDF_MAX_BYTES, "URDF")
            .map_err(|e| match e {
                crate::bounded::CappedReadError::Io(source) => VjmError::Io {
                    path: shown.clone(),
                    source,
                },
                crate::bounded::CappedReadError::TooLarge(limit) => VjmError::UrdfLimit {
                    path: Some(shown.clone()),
                    limit,
                },
            })?;
        let chain = Self::from_urdf_str_read_from(&xml, &shown, base, tip)?;
        Ok((chain, xml))
    }

    /// Loads the chain from URDF text that was read from `path` (recorded in its
    /// [`UrdfSource`] as [`from_urdf_file`](Self::from_urdf_file) records it; the file is not
    /// opened). A chain sent to another process is rebuilt with it, and a model saved there
    /// names the same URDF as one saved here.
    pub fn from_urdf_str_read_from(
        xml: &str,
        path: &str,
        base: &str,
        tip: &str,
    ) -> Result<Self, VjmError> {
        let mut chain = Self::from_urdf_str(xml, base, tip).map_err(|e| match e {
            VjmError::UrdfLimit { path: None, limit } => VjmError::UrdfLimit {
                path: Some(path.to_string()),
                limit,
            },
            other => other,
        })?;
        if let Some(source) = chain.source.as_mut() {
            source.path = Some(path.to_string());
        }
        Ok(chain)
    }

    /// Loads the chain from `base` to `tip` from URDF text.
    ///
    /// Text larger than [`URDF_MAX_BYTES`](crate::bounded::URDF_MAX_BYTES) or nesting deeper
    /// than [`URDF_MAX_DEPTH`](crate::bounded::URDF_MAX_DEPTH) is refused with
    /// [`VjmError::UrdfLimit`] before it is parsed.
    pub fn from_urdf_str(xml: &str, base: &str, tip: &str) -> Result<Self, VjmError> {
        // Every URDF path of the crate (files, text, the Python package, the CLI) comes here:
        // the parser recurses per nested element, so the depth is bounded before it runs.
        crate::bounded::check_urdf_text(xml)
            .map_err(|limit| VjmError::UrdfLimit { path: None, limit })?;
        let robot = urdf_rs::read_from_string(xml).map_err(|e| VjmError::Urdf {
            message: e.to_string(),
        })?;
        let declared = links_declaring_inertial(xml);
        let mut chain = Self::from_urdf_robot_declaring(&robot, base, tip, Some(&declared))?;
        chain.source = Some(UrdfSource {
            path: None,
            sha256: crate::hashing::sha256_hex(xml.as_bytes()),
        });
        Ok(chain)
    }

    /// Extracts the chain from `base` to `tip` from an already parsed URDF.
    ///
    /// Without the URDF text, a link with a shape whose inertial is all zeros counts as
    /// having none (see [`mass_model`](Self::mass_model)).
    pub fn from_urdf_robot(
        robot: &urdf_rs::Robot,
        base: &str,
        tip: &str,
    ) -> Result<Self, VjmError> {
        Self::from_urdf_robot_declaring(robot, base, tip, None)
    }

    /// [`from_urdf_robot`](Self::from_urdf_robot); `declared` are the links whose URDF text
    /// has an `<inertial>` element, where the text is known.
    fn from_urdf_robot_declaring(
        robot: &urdf_rs::Robot,
        base: &str,
        tip: &str,
        declared: Option<&HashSet<String>>,
    ) -> Result<Self, VjmError> {
        let available = || {
            let mut names: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
            if names.len() > 20 {
                names.truncate(20);
                names.push("...");
            }
            names.join(", ")
        };
        for (role, name) in [("base", base), ("tip", tip)] {
            if !robot.links.iter().any(|l| l.name == name) {
                return Err(VjmError::MissingLink {
                    role,
                    name: name.to_string(),
                    available: available(),
                });
            }
        }
        // child link -> index of its (unique) parent joint
        let mut parent_joint: HashMap<&str, usize> = HashMap::new();
        for (i, joint) in robot.joints.iter().enumerate() {
            if let Some(&other) = parent_joint.get(joint.child.link.as_str()) {
                return Err(VjmError::ClosedChain {
                    link: joint.child.link.clone(),
                    joints: format!("{}, {}", robot.joints[other].name, joint.name),
                });
            }
            parent_joint.insert(joint.child.link.as_str(), i);
        }
        // Walk up from the tip; a cycle among parents is also a closed chain.
        let mut path = Vec::new();
        let mut link = tip;
        while link != base {
            let Some(&ji) = parent_joint.get(link) else {
                return Err(VjmError::NotAncestor {
                    base: base.to_string(),
                    tip: tip.to_string(),
                    root: link.to_string(),
                });
            };
            if path.contains(&ji) {
                return Err(VjmError::ClosedChain {
                    link: link.to_string(),
                    joints: robot.joints[ji].name.clone(),
                });
            }
            path.push(ji);
            link = robot.joints[ji].parent.link.as_str();
        }
        path.reverse();

        let mut joints = Vec::new();
        let mut actuated = Vec::new();
        let mut pending = Isometry3::identity();
        for &ji in &path {
            let j = &robot.joints[ji];
            check_joint_numbers(j)?;
            let origin = pose_to_isometry(&j.origin);
            match j.joint_type {
                urdf_rs::JointType::Fixed => {
                    pending *= origin;
                    continue;
                }
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {}
                ref other => {
                    return Err(VjmError::UnsupportedJoint {
                        joint: j.name.clone(),
                        kind: format!("{other:?}").to_lowercase(),
                    })
                }
            }
            if let Some(m) = &j.mimic {
                return Err(VjmError::MimicJoint {
                    joint: j.name.clone(),
                    mimics: m.joint.clone(),
                });
            }
            let raw = j.axis.xyz.0;
            let a = Vector3::from(raw);
            let norm = a.norm();
            if !norm.is_finite() || norm < 1e-12 {
                return Err(VjmError::InvalidAxis {
                    joint: j.name.clone(),
                    axis: raw,
                });
            }
            let limits = if j.joint_type == urdf_rs::JointType::Continuous {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                (j.limit.lower, j.limit.upper)
            };
            joints.push(ActuatedJoint::new(
                j.name.clone(),
                pending * origin,
                a / norm,
                limits,
            ));
            actuated.push(ji);
            pending = Isometry3::identity();
        }
        if joints.is_empty() {
            return Err(VjmError::NoActuatedJoints {
                base: base.to_string(),
                tip: tip.to_string(),
            });
        }
        let mut chain = Self::from_parts(base, tip, joints, pending);
        chain.masses = mass_source(robot, &actuated, declared);
        Ok(chain)
    }

    /// Builds a chain directly from joint data (used by tests and random-chain generators).
    ///
    /// `joints[j] = (name, origin, axis, limits)`: `origin` is the pose of joint j's frame in
    /// joint j−1's child frame (base frame for j = 0), `axis` its rotation axis in the joint
    /// frame (normalised here). `tip_offset` is the pose of the tip frame in the last child
    /// frame.
    pub fn from_joints(
        base: &str,
        tip: &str,
        joints: Vec<JointSpec>,
        tip_offset: Isometry3<f64>,
    ) -> Result<Self, VjmError> {
        if joints.is_empty() {
            return Err(VjmError::NoActuatedJoints {
                base: base.to_string(),
                tip: tip.to_string(),
            });
        }
        let mut out = Vec::with_capacity(joints.len());
        for (name, origin, axis, limits) in joints {
            let t = origin.translation.vector;
            check_finite_attribute(&name, "origin translation", &[t.x, t.y, t.z])?;
            let r = origin.rotation.coords;
            check_finite_attribute(&name, "origin rotation", &[r.x, r.y, r.z, r.w])?;
            check_limits(&name, limits.0, limits.1, true)?;
            let norm = axis.norm();
            if !norm.is_finite() || norm < 1e-12 {
                return Err(VjmError::InvalidAxis {
                    joint: name,
                    axis: [axis.x, axis.y, axis.z],
                });
            }
            out.push(ActuatedJoint::new(name, origin, axis / norm, limits));
        }
        Ok(Self::from_parts(base, tip, out, tip_offset))
    }

    fn from_parts(
        base: &str,
        tip: &str,
        joints: Vec<ActuatedJoint>,
        tip_offset: Isometry3<f64>,
    ) -> Self {
        let names = joints.iter().map(|j| j.name.clone()).collect();
        let limits = joints.iter().map(|j| j.limits).collect();
        Self {
            base: base.to_string(),
            tip: tip.to_string(),
            joints,
            names,
            limits,
            tip_offset,
            source: None,
            masses: MassSource::None,
        }
    }

    /// The bodies the actuated joints carry, from the URDF's `<inertial>` elements (see
    /// [`MassModel`]); an error naming the link when a link with a shape has no inertial, or
    /// when the chain was not built from a URDF and [`with_masses`](Self::with_masses) was
    /// not called.
    pub fn mass_model(&self) -> Result<&MassModel, VjmError> {
        self.masses.get()
    }

    /// This chain with the given bodies (one per actuated joint), e.g. for a chain built with
    /// [`from_joints`](Self::from_joints) or to replace a URDF's inertials.
    pub fn with_masses(mut self, masses: MassModel) -> Result<Self, VjmError> {
        if masses.bodies().len() != self.joints.len() {
            return Err(VjmError::ShapeMismatch {
                what: "mass model (one body per actuated joint)",
                expected: self.joints.len(),
                got: masses.bodies().len(),
            });
        }
        self.masses = MassSource::Known(masses);
        Ok(self)
    }

    /// The bundled Franka Emika Panda arm from `panda_link0` to the flange `panda_link8`.
    pub fn bundled() -> Self {
        Self::bundled_with_tip(BUNDLED_FLANGE).expect("the bundled URDF is valid")
    }

    /// The bundled Panda from `panda_link0` to any of its links (e.g. [`BUNDLED_TCP`]).
    pub fn bundled_with_tip(tip: &str) -> Result<Self, VjmError> {
        Self::from_urdf_str_read_from(BUNDLED_URDF, BUNDLED_URDF_PATH, BUNDLED_BASE, tip)
    }

    /// The URDF this chain was read from (path as given, SHA-256 of the text); `None` for a
    /// chain built with [`from_joints`](Self::from_joints) or from an already parsed URDF.
    pub fn urdf_source(&self) -> Option<&UrdfSource> {
        self.source.as_ref()
    }

    /// Number of actuated joints n.
    pub fn n_joints(&self) -> usize {
        self.joints.len()
    }
    /// Names of the actuated joints, base → tip.
    pub fn joint_names(&self) -> &[String] {
        &self.names
    }
    /// Position limits `(lower, upper)` in rad, base → tip; `(-inf, inf)` for continuous joints.
    pub fn limits(&self) -> &[(f64, f64)] {
        &self.limits
    }
    /// The actuated joints, base → tip.
    pub fn joints(&self) -> &[ActuatedJoint] {
        &self.joints
    }
    /// Name of the base link.
    pub fn base_link(&self) -> &str {
        &self.base
    }
    /// Name of the tip link.
    pub fn tip_link(&self) -> &str {
        &self.tip
    }
    /// Pose of the tip frame in the last actuated joint's child frame.
    pub fn tip_offset(&self) -> &Isometry3<f64> {
        &self.tip_offset
    }

    /// Checks that `q` has n finite entries; `row` is reported in errors.
    pub(crate) fn check_q(&self, q: &[f64], row: usize) -> Result<(), VjmError> {
        if q.len() != self.joints.len() {
            return Err(VjmError::ShapeMismatch {
                what: "q (joint positions)",
                expected: self.joints.len(),
                got: q.len(),
            });
        }
        check_finite("q", q, row, 0)
    }

    /// Poses of the child frames of every actuated joint in the base frame at `q`.
    pub fn joint_frames(&self, q: &[f64]) -> Result<Vec<Isometry3<f64>>, VjmError> {
        self.check_q(q, 0)?;
        let mut t = Isometry3::identity();
        Ok(self
            .joints
            .iter()
            .zip(q)
            .map(|(j, &qj)| {
                t = t * j.origin * rotation_about(&j.axis, qj);
                t
            })
            .collect())
    }

    /// Pose of the tip frame in the base frame at joint positions `q` (rad).
    pub fn forward_kinematics(&self, q: &[f64]) -> Result<Isometry3<f64>, VjmError> {
        let frames = self.joint_frames(q)?;
        Ok(frames[frames.len() - 1] * self.tip_offset)
    }
}

impl ActuatedJoint {
    fn new(name: String, origin: Isometry3<f64>, axis: Vector3<f64>, limits: (f64, f64)) -> Self {
        let b0 = *origin.rotation.to_rotation_matrix().matrix();
        let ahat = axis.cross_matrix();
        Self {
            name,
            origin,
            axis,
            limits,
            b0,
            b1: b0 * ahat,
            b2: b0 * ahat * ahat,
            t: origin.translation.vector,
        }
    }
}

/// Rotation by `angle` (rad) about the unit `axis`, as an isometry.
pub(crate) fn rotation_about(axis: &Vector3<f64>, angle: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_scaled_axis(axis * angle),
    )
}

/// Refuses a joint of the URDF whose numbers cannot describe a robot: a non-finite origin
/// (`xyz`, `rpy`), axis, or (revolute joints) limit, or an empty limit range. Checked for every
/// joint on the chain, fixed ones included, before anything is computed from them: a single NaN
/// would otherwise turn every Jacobian into NaN (and hang the SVD of the pose sampler).
fn check_joint_numbers(j: &urdf_rs::Joint) -> Result<(), VjmError> {
    check_finite_attribute(&j.name, "origin xyz", &j.origin.xyz.0)?;
    check_finite_attribute(&j.name, "origin rpy", &j.origin.rpy.0)?;
    if j.joint_type == urdf_rs::JointType::Fixed {
        return Ok(());
    }
    check_finite_attribute(&j.name, "axis xyz", &j.axis.xyz.0)?;
    if j.joint_type == urdf_rs::JointType::Revolute {
        check_limits(&j.name, j.limit.lower, j.limit.upper, false)?;
    }
    Ok(())
}

fn check_finite_attribute(joint: &str, attribute: &'static str, v: &[f64]) -> Result<(), VjmError> {
    if v.iter().all(|x| x.is_finite()) {
        return Ok(());
    }
    let shown: Vec<String> = v.iter().map(|x| Short(*x).to_string()).collect();
    Err(VjmError::InvalidJointValue {
        joint: joint.to_string(),
        attribute,
        message: format!("= \"{}\" is not finite", shown.join(" ")),
    })
}

/// Limits must be numbers with `lower <= upper`; `±inf` only where `infinite_ok` (the
/// programmatic constructor, where `(-inf, inf)` means a continuous joint).
fn check_limits(joint: &str, lower: f64, upper: f64, infinite_ok: bool) -> Result<(), VjmError> {
    for (attribute, v) in [("limit lower", lower), ("limit upper", upper)] {
        if v.is_nan() || (!infinite_ok && v.is_infinite()) {
            return Err(VjmError::InvalidJointValue {
                joint: joint.to_string(),
                attribute,
                message: format!("= {} is not finite", Short(v)),
            });
        }
    }
    if lower > upper {
        return Err(VjmError::InvalidJointValue {
            joint: joint.to_string(),
            attribute: "limit",
            message: format!(
                "range is empty: lower {} > upper {} rad",
                Short(lower),
                Short(upper)
            ),
        });
    }
    Ok(())
}

pub(crate) fn pose_to_isometry(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [x, y, z] = p.xyz.0;
    let [r, pi, yaw] = p.rpy.0;
    // URDF: R = Rz(yaw)·Ry(pitch)·Rx(roll), which is nalgebra's from_euler_angles.
    let rot = Rotation3::from_euler_angles(r, pi, yaw);
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_rotation_matrix(&rot),
    )
}

/// Errors with the first non-finite entry of `values`, reported at `row` and `col0 + index`.
pub(crate) fn check_finite(
    what: &'static str,
    values: &[f64],
    row: usize,
    col0: usize,
) -> Result<(), VjmError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(c) => Err(VjmError::NonFinite {
            what,
            row,
            column: col0 + c,
            value: values[c],
        }),
    }
}
