//! Virtual-joint (spring) models: which virtual springs sit at which actuated joint.

use std::fmt;

use nalgebra::Vector3;
use serde::Serialize;

use crate::chain::SerialChain;
use crate::error::VjmError;

/// Nominal torsional compliances of a Panda-class cobot, rad/(N·m), base → tip: stiffness
/// 10 kN·m/rad at the shoulder down to 2 kN·m/rad at the wrist. The prior of planning
/// ([`NoiseModel::typical`](crate::NoiseModel::typical)) and the virtual testbed's truth.
pub const NOMINAL_TORSION: [f64; 7] = [1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4];

/// The axis of a virtual spring, in the child frame of its actuated joint.
///
/// For a joint axis a: `Z` is torsion about a; `X` and `Y` are the tilting springs about
/// u = normalize(x̂ − (x̂·a)a) (ŷ instead of x̂ when x̂ ∥ a) and v = a × u. When a = ẑ these
/// are the joint frame's x and y axes. Displayed and serialised as `"z"`, `"x"`, `"y"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SpringAxis {
    /// Torsion about the joint axis.
    Z,
    /// Tilt about u (the joint frame's x axis when the joint axis is z).
    X,
    /// Tilt about v = a × u.
    Y,
}

impl SpringAxis {
    /// The three axes in a joint's spring order, `[z, x, y]` ([`SpringAxis::index`]).
    pub const ALL: [SpringAxis; 3] = [SpringAxis::Z, SpringAxis::X, SpringAxis::Y];

    /// Position of the axis within a joint's springs, joint-major `[z, x, y]`: spring
    /// `3·joint + axis.index()` of the 3n (the order of the extended model and of the testbed's
    /// compliances).
    pub fn index(self) -> usize {
        match self {
            SpringAxis::Z => 0,
            SpringAxis::X => 1,
            SpringAxis::Y => 2,
        }
    }
}

impl fmt::Display for SpringAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SpringAxis::Z => "z",
            SpringAxis::X => "x",
            SpringAxis::Y => "y",
        })
    }
}

impl std::str::FromStr for SpringAxis {
    type Err = VjmError;
    fn from_str(s: &str) -> Result<Self, VjmError> {
        match s {
            "z" | "Z" => Ok(SpringAxis::Z),
            "x" | "X" => Ok(SpringAxis::X),
            "y" | "Y" => Ok(SpringAxis::Y),
            other => Err(VjmError::InvalidModel {
                message: format!("unknown spring axis `{other}` (expected z, x or y)"),
            }),
        }
    }
}

/// Whether a virtual spring rotates or translates the link after its joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SpringKind {
    /// A virtual revolute joint about the spring axis (compliance in rad/(N·m)): torsion and
    /// tilts, labels `J3z`, `J3x`, `J3y`.
    #[default]
    Rotation,
    /// A virtual prismatic joint along the spring axis (compliance in m/N): the link's
    /// translational spring of the full 6-D virtual spring, labels `J3tz`, `J3tx`, `J3ty`
    /// (`link_translation(J3z)` in the words of `diagnose`).
    Translation,
}

impl SpringKind {
    /// True for [`SpringKind::Rotation`] (the serialiser leaves the kind of a rotation out, so
    /// the springs of the rotational models serialise as before).
    pub fn is_rotation(&self) -> bool {
        *self == SpringKind::Rotation
    }
}

/// One virtual spring at actuated joint `joint` (0-based, base → tip): a virtual revolute
/// joint about `axis` or, for [`SpringKind::Translation`], a virtual prismatic joint along it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct Spring {
    /// 0-based index of the actuated joint, base → tip.
    pub joint: usize,
    /// Axis of the spring in that joint's child frame.
    pub axis: SpringAxis,
    /// Rotation (torsion, tilt) or translation of the link after the joint.
    #[serde(skip_serializing_if = "SpringKind::is_rotation")]
    pub kind: SpringKind,
}

impl Spring {
    /// The rotational spring of `joint` (0-based) about `axis`: torsion (`Z`) or a tilt.
    pub fn rotation(joint: usize, axis: SpringAxis) -> Self {
        Self {
            joint,
            axis,
            kind: SpringKind::Rotation,
        }
    }

    /// The translational spring of the link after `joint` (0-based) along `axis`.
    pub fn translation(joint: usize, axis: SpringAxis) -> Self {
        Self {
            joint,
            axis,
            kind: SpringKind::Translation,
        }
    }

    /// True for a translational spring.
    pub fn is_translation(&self) -> bool {
        self.kind == SpringKind::Translation
    }

    /// Position of the spring within its joint's six, joint-major `[z, x, y, tz, tx, ty]`:
    /// spring `6·joint + slot()` of the full model (the rotations first, in the order of the
    /// extended model).
    pub fn slot(&self) -> usize {
        match self.kind {
            SpringKind::Rotation => self.axis.index(),
            SpringKind::Translation => 3 + self.axis.index(),
        }
    }

    /// The spring in `slot` (see [`Spring::slot`]) of `joint`.
    pub(crate) fn from_slot(joint: usize, slot: usize) -> Self {
        let axis = SpringAxis::ALL[slot % 3];
        if slot < 3 {
            Self::rotation(joint, axis)
        } else {
            Self::translation(joint, axis)
        }
    }
}

impl fmt::Display for Spring {
    /// 1-based user-facing label, e.g. `J3x` (a tilt) or `J3tx` (a translation).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = if self.is_translation() { "t" } else { "" };
        write!(f, "J{}{}{}", self.joint + 1, t, self.axis)
    }
}

/// The unit spring axes `[z, x, y] = [a, u, v]` of a joint with unit axis `a` (joint-frame
/// components), following docs/conventions.md.
pub fn spring_axes(a: &Vector3<f64>) -> [Vector3<f64>; 3] {
    let a = a.normalize();
    let x = Vector3::x();
    let mut u = x - a * a.dot(&x);
    // x̂ ∥ a leaves a residual of rounding size only; switch to ŷ then.
    if u.norm() < 1e-9 {
        let y = Vector3::y();
        u = y - a * a.dot(&y);
    }
    let u = u.normalize();
    let v = a.cross(&u);
    [a, u, v]
}

/// Spring `s`'s unit axis in its joint's child frame (one of [`spring_axes`]).
pub(crate) fn local_spring_axis(chain: &crate::SerialChain, s: &Spring) -> Vector3<f64> {
    let [z, x, y] = spring_axes(chain.joints()[s.joint].axis());
    match s.axis {
        SpringAxis::Z => z,
        SpringAxis::X => x,
        SpringAxis::Y => y,
    }
}

/// `Some(i)` when `a` is exactly the basis vector e_i: its base-frame image is then column i
/// of the joint rotation, with no product (the common case: URDF axes along x, y or z).
pub(crate) fn basis_index(a: &Vector3<f64>) -> Option<usize> {
    (0..3).find(|&i| a[i] == 1.0 && a[(i + 1) % 3] == 0.0 && a[(i + 2) % 3] == 0.0)
}

/// A virtual-joint stiffness model: an ordered list of springs (the parameters) and
/// optional per-joint offsets of where the springs sit.
///
/// Parameter order is the order of [`springs`](Self::springs); presets use the
/// conventions' order (joint-major, `[z, x, y]` within a joint). Springs must be listed
/// base → tip (non-decreasing joint index); within one joint the listed order is the
/// order in which the virtual rotations are composed (it matters only for the second
/// derivatives in [`complementary_stiffness`](crate::complementary_stiffness)).
///
/// ```
/// use vjm::{SpringAxis, VirtualJointModel};
/// let m = VirtualJointModel::extended(7);
/// assert_eq!(m.n_params(), 21);
/// assert_eq!(m.springs()[4].axis, SpringAxis::X); // joint 2, tilt x
/// assert_eq!(m.labels()[4], "J2x");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualJointModel {
    n_joints: usize,
    springs: Vec<Spring>,
    /// Per joint: position of the springs' common centre in the joint's child frame (m),
    /// relative to the joint origin (the seed's extra frames O_d).
    offsets: Vec<Vector3<f64>>,
    name: String,
}

impl VirtualJointModel {
    /// One torsional spring per joint (n parameters), the classic VJM.
    pub fn traditional(n_joints: usize) -> Self {
        let springs = (0..n_joints)
            .map(|joint| Spring::rotation(joint, SpringAxis::Z))
            .collect();
        Self {
            n_joints,
            springs,
            offsets: vec![Vector3::zeros(); n_joints],
            name: "traditional".into(),
        }
    }

    /// Three springs per joint `[z, x, y]` (3n parameters), the seed's extended model.
    pub fn extended(n_joints: usize) -> Self {
        let springs = (0..n_joints)
            .flat_map(|joint| {
                SpringAxis::ALL
                    .into_iter()
                    .map(move |axis| Spring::rotation(joint, axis))
            })
            .collect();
        Self {
            n_joints,
            springs,
            offsets: vec![Vector3::zeros(); n_joints],
            name: "extended".into(),
        }
    }

    /// The full virtual-joint model: every link's 6-D spring, torsion, both tilts and three
    /// translations per joint (6n parameters, joint-major `[z, x, y, tz, tx, ty]`; the
    /// translations in m/N along the spring axes of [`spring_axes`]).
    ///
    /// ```
    /// use vjm::VirtualJointModel;
    /// let m = VirtualJointModel::full(6);
    /// assert_eq!(m.n_params(), 36);
    /// assert_eq!(m.labels()[3], "J1tz");
    /// ```
    pub fn full(n_joints: usize) -> Self {
        let springs = (0..n_joints)
            .flat_map(|joint| (0..6).map(move |slot| Spring::from_slot(joint, slot)))
            .collect();
        Self {
            n_joints,
            springs,
            offsets: vec![Vector3::zeros(); n_joints],
            name: "full".into(),
        }
    }

    /// True when any spring is a translation (the full model's link springs).
    pub fn has_translations(&self) -> bool {
        self.springs.iter().any(Spring::is_translation)
    }

    /// Any subset of springs for a chain of `n_joints` joints, listed base → tip.
    pub fn from_springs(n_joints: usize, springs: Vec<Spring>) -> Result<Self, VjmError> {
        if springs.is_empty() {
            return Err(VjmError::InvalidModel {
                message: "the model has no spring".into(),
            });
        }
        for (i, s) in springs.iter().enumerate() {
            if s.joint >= n_joints {
                return Err(VjmError::InvalidModel {
                    message: format!(
                        "spring {i} ({s}) is on joint {} but the chain has {n_joints} joints",
                        s.joint + 1
                    ),
                });
            }
            if springs[..i].contains(s) {
                return Err(VjmError::InvalidModel {
                    message: format!("spring {i} ({s}) is listed twice"),
                });
            }
            if i > 0 && springs[i - 1].joint > s.joint {
                return Err(VjmError::InvalidModel {
                    message: format!(
                        "spring {i} ({s}) comes after {}; list springs base → tip",
                        springs[i - 1]
                    ),
                });
            }
        }
        Ok(Self {
            n_joints,
            springs,
            offsets: vec![Vector3::zeros(); n_joints],
            name: "custom".into(),
        })
    }

    /// The same model with the springs of each joint centred at `offsets[j]` (child frame
    /// of joint j, m) instead of at the joint origin.
    pub fn with_offsets(mut self, offsets: Vec<Vector3<f64>>) -> Result<Self, VjmError> {
        if offsets.len() != self.n_joints {
            return Err(VjmError::ShapeMismatch {
                what: "spring offsets (one per joint)",
                expected: self.n_joints,
                got: offsets.len(),
            });
        }
        for (j, o) in offsets.iter().enumerate() {
            if let Some(c) = o.iter().position(|v| !v.is_finite()) {
                return Err(VjmError::NonFinite {
                    what: "spring offsets",
                    row: j,
                    column: c,
                    value: o[c],
                });
            }
        }
        self.offsets = offsets;
        Ok(self)
    }

    /// Number of parameters (springs) m.
    pub fn n_params(&self) -> usize {
        self.springs.len()
    }
    /// Number of actuated joints the model is written for.
    pub fn n_joints(&self) -> usize {
        self.n_joints
    }
    /// The springs in parameter order.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }
    /// Per-joint spring centres in the joint's child frame (m).
    pub fn offsets(&self) -> &[Vector3<f64>] {
        &self.offsets
    }
    /// `"traditional"`, `"extended"`, `"full"` or `"custom"`.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// 1-based labels of the parameters, e.g. `["J1z", "J1x", ...]`.
    pub fn labels(&self) -> Vec<String> {
        self.springs.iter().map(|s| s.to_string()).collect()
    }

    /// Checks that the model was written for `chain`.
    pub(crate) fn check_chain(&self, chain: &SerialChain) -> Result<(), VjmError> {
        if chain.n_joints() != self.n_joints {
            return Err(VjmError::InvalidModel {
                message: format!(
                    "the model is for {} joints but the chain `{}`→`{}` has {}",
                    self.n_joints,
                    chain.base_link(),
                    chain.tip_link(),
                    chain.n_joints()
                ),
            });
        }
        Ok(())
    }
}
