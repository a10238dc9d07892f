//! The one model vocabulary ([`VirtualJointModel::parse`]).

use crate::error::VjmError;
use crate::model::{Spring, SpringAxis, SpringKind, VirtualJointModel};

/// Effects `diagnose` names that are not virtual springs of the joints, with what they are.
const NOT_SPRINGS: [(&str, &str); 7] = [
    ("wrench_bias", "an offset of the recorded wrench"),
    ("frame_misalignment", "a rotation of the tracker's frame"),
    (
        "geometric_nonlinearity",
        "the load's geometric stiffness (K_C)",
    ),
    ("mount_translation", "a compliance of the mount"),
    ("mount_rotation", "a compliance of the mount"),
    (
        "joint_torsion_nonlinear",
        "a torque-dependent gear curve (its linear part is the joint's torsion spring)",
    ),
    ("joint_backlash", "lost motion in a gear"),
];

impl VirtualJointModel {
    /// The model a spec names for a chain of `n_joints` joints, in the one model vocabulary of
    /// every command: `identify --model`, `design --model`,
    /// `diagnose --baseline` and the Python `model=` strings read a spring model the way `diagnose`
    /// prints its models.
    ///
    /// A spec is terms joined by `+` or `,` (spaces ignored): `traditional` (the torsion spring of
    /// every joint), `extended` (torsion and both tilts of every joint), `full` (the 6-D spring of
    /// every link: torsion, both tilts and three translations), a spring label `J3x` (1-based
    /// joint, axis z, x or y; `J3tx` the translation of the link after joint 3 along x), or a
    /// spring finding of `diagnose`, `joint_tilt(J3x)` or `link_translation(J3x)` (= `J3tx`). The
    /// model holds the union of the terms' springs, base → tip and `[z, x, y, tz, tx, ty]` within
    /// a joint, so `traditional + joint_tilt(J3x)` — what `diagnose` prints for a tilt found at
    /// joint 3 — is the seven torsion springs and J3x. Findings of `diagnose` that are not
    /// virtual springs (`wrench_bias`, `mount_translation`, …) are refused by name: `identify`
    /// fits springs.
    ///
    /// Named `traditional`, `extended` or `full` when its springs are those models',
    /// `custom` otherwise.
    ///
    /// ```
    /// use vjm::VirtualJointModel;
    /// let m = VirtualJointModel::parse(7, "traditional + joint_tilt(J3x)")?;
    /// assert_eq!(m.n_params(), 8);
    /// assert_eq!(m.labels()[3], "J3x");
    /// assert_eq!(VirtualJointModel::parse(7, "J1z, J2z")?.n_params(), 2);
    /// assert_eq!(VirtualJointModel::parse(7, "traditional + extended")?.name(), "extended");
    /// assert!(VirtualJointModel::parse(7, "traditional + wrench_bias").is_err());
    /// let t = VirtualJointModel::parse(7, "traditional + link_translation(J4z)")?;
    /// assert_eq!(t.labels()[4], "J4tz");
    /// assert_eq!(VirtualJointModel::parse(7, "full")?.n_params(), 42);
    /// # Ok::<(), vjm::VjmError>(())
    /// ```
    pub fn parse(n_joints: usize, spec: &str) -> Result<Self, VjmError> {
        let invalid = |message: String| VjmError::InvalidModel { message };
        let mut chosen = vec![false; 6 * n_joints];
        let mut terms = 0usize;
        for raw in spec.split(['+', ',']) {
            let term: String = raw.chars().filter(|c| !c.is_whitespace()).collect();
            if term.is_empty() {
                return Err(invalid(format!(
                    "model `{spec}` has an empty term: join terms with `+` or `,` (e.g. \
                     \"traditional + joint_tilt(J3x)\")"
                )));
            }
            terms += 1;
            for spring in term_springs(&term, n_joints)? {
                chosen[6 * spring.joint + spring.slot()] = true;
            }
        }
        if terms == 0 {
            return Err(invalid("the model spec is empty".into()));
        }
        let springs: Vec<Spring> = (0..6 * n_joints)
            .filter(|&k| chosen[k])
            .map(|k| Spring::from_slot(k / 6, k % 6))
            .collect();
        let presets = [
            VirtualJointModel::traditional(n_joints),
            VirtualJointModel::extended(n_joints),
            VirtualJointModel::full(n_joints),
        ];
        match presets.into_iter().find(|p| p.springs() == springs) {
            Some(preset) => Ok(preset),
            None => VirtualJointModel::from_springs(n_joints, springs),
        }
    }
}

/// The springs of one term (spaces removed).
fn term_springs(term: &str, n_joints: usize) -> Result<Vec<Spring>, VjmError> {
    match term {
        "traditional" => return Ok(VirtualJointModel::traditional(n_joints).springs().to_vec()),
        "extended" => return Ok(VirtualJointModel::extended(n_joints).springs().to_vec()),
        "full" => return Ok(VirtualJointModel::full(n_joints).springs().to_vec()),
        _ => {}
    }
    let (name, inner) = match term.split_once('(') {
        Some((name, rest)) => match rest.strip_suffix(')') {
            Some(inner) => (name, Some(inner)),
            None => {
                return Err(VjmError::InvalidModel {
                    message: format!("model term `{term}`: unclosed `(`"),
                })
            }
        },
        None => (term, None),
    };
    if let Some((_, what)) = NOT_SPRINGS.iter().find(|(effect, _)| *effect == name) {
        return Err(VjmError::InvalidModel {
            message: format!(
                "model term `{term}` is {what}, a finding of diagnose that is not a virtual \
                 spring: a spring model holds traditional, extended, full, spring labels (J3x, \
                 J3tx) and joint_tilt(J3x) or link_translation(J3x) findings (the model a diagnosis found is saved with its \
                 measurement errors taken out by diagnosed_model, CLI diagnose --save)"
            ),
        });
    }
    let (label, finding) = match (name, inner) {
        ("joint_tilt", Some(label)) => (label, Some(SpringKind::Rotation)),
        ("link_translation", Some(label)) => (label, Some(SpringKind::Translation)),
        (label, None) => (label, None),
        _ => {
            return Err(VjmError::InvalidModel {
                message: format!(
                    "unknown model `{term}`: expected traditional, extended, full, spring labels \
                     like J3x, or what diagnose prints, e.g. traditional + joint_tilt(J3x)"
                ),
            })
        }
    };
    let looks_like_a_label =
        label.starts_with(['J', 'j']) && label[1..].starts_with(|c: char| c.is_ascii_digit());
    if !looks_like_a_label {
        return Err(VjmError::InvalidModel {
            message: format!(
                "unknown model `{term}`: expected traditional, extended, full, spring labels like \
                 J3x, or what diagnose prints, e.g. traditional + joint_tilt(J3x)"
            ),
        });
    }
    let spring = spring_label(label, n_joints).ok_or_else(|| VjmError::InvalidModel {
        message: format!(
            "model term `{term}`: `{label}` is not a spring label: expected J<joint><axis> with \
             joint 1..{n_joints} and axis z, x or y (e.g. J3x; J3tx a translation), or \
             traditional / extended / full"
        ),
    })?;
    match finding {
        None => Ok(vec![spring]),
        Some(_) if spring.is_translation() => Err(VjmError::InvalidModel {
            message: format!(
                "model term `{term}`: name the axis inside a finding without `t` (e.g. \
                 link_translation(J3x), or the label J3tx alone)"
            ),
        }),
        Some(SpringKind::Rotation) if spring.axis == SpringAxis::Z => Err(VjmError::InvalidModel {
            message: format!("model term `{term}`: a tilt is about x or y, not z (the torsion)"),
        }),
        Some(SpringKind::Rotation) => Ok(vec![spring]),
        Some(SpringKind::Translation) => Ok(vec![Spring::translation(spring.joint, spring.axis)]),
    }
}

/// `J3x` (or `j3x`) → the rotational spring of joint 2 (0-based) about x; `J3tx` → the
/// translational spring of the link after joint 2 along x; None when not a label of a chain
/// of `n_joints` joints.
pub fn spring_label(label: &str, n_joints: usize) -> Option<Spring> {
    let rest = label.strip_prefix(['J', 'j'])?;
    let axis_char = rest.chars().last()?;
    let rest = &rest[..rest.len() - axis_char.len_utf8()];
    let (digits, kind) = match rest.strip_suffix(['t', 'T']) {
        Some(digits) => (digits, SpringKind::Translation),
        None => (rest, SpringKind::Rotation),
    };
    let joint: usize = digits.parse().ok()?;
    let axis: SpringAxis = axis_char.to_string().parse().ok()?;
    (1..=n_joints).contains(&joint).then_some(Spring {
        joint: joint - 1,
        axis,
        kind,
    })
}
