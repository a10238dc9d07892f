//! The one model vocabulary ([`VirtualJointModel::parse`]).

use crate::error::VjmError;
use crate::model::{Spring, SpringAxis, VirtualJointModel};

/// Effects `diagnose` names that are not virtual springs of the joints, with what they are.
const NOT_SPRINGS: [(&str, &str); 8] = [
    ("wrench_bias", "an offset of the recorded wrench"),
    ("frame_misalignment", "a rotation of the tracker's frame"),
    (
        "geometric_nonlinearity",
        "the load's geometric stiffness (K_C)",
    ),
    ("mount_translation", "a compliance of the mount"),
    ("mount_rotation", "a compliance of the mount"),
    ("link_translation", "a translational spring of a link"),
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
    /// every joint), `extended` (torsion and both tilts of every joint), a spring label `J3x`
    /// (1-based joint, axis z, x or y), or a spring finding of `diagnose`, `joint_tilt(J3x)`. The
    /// model holds the union of the terms' springs, base → tip and `[z, x, y]` within a joint, so
    /// `traditional + joint_tilt(J3x)` — what `diagnose` prints for a tilt found at joint 3 — is the
    /// seven torsion springs and J3x. Findings of `diagnose` that are not virtual springs
    /// (`wrench_bias`, `link_translation(J4z)`, …) are refused by name: `identify` fits springs.
    ///
    /// Named `traditional` or `extended` when its springs are those models',
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
    /// # Ok::<(), vjm::VjmError>(())
    /// ```
    pub fn parse(n_joints: usize, spec: &str) -> Result<Self, VjmError> {
        let invalid = |message: String| VjmError::InvalidModel { message };
        let mut chosen = vec![false; 3 * n_joints];
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
                chosen[3 * spring.joint + spring.axis.index()] = true;
            }
        }
        if terms == 0 {
            return Err(invalid("the model spec is empty".into()));
        }
        let springs: Vec<Spring> = (0..3 * n_joints)
            .filter(|&k| chosen[k])
            .map(|k| Spring {
                joint: k / 3,
                axis: SpringAxis::ALL[k % 3],
            })
            .collect();
        let traditional = VirtualJointModel::traditional(n_joints);
        let extended = VirtualJointModel::extended(n_joints);
        if springs == traditional.springs() {
            Ok(traditional)
        } else if springs == extended.springs() {
            Ok(extended)
        } else {
            VirtualJointModel::from_springs(n_joints, springs)
        }
    }
}

/// The springs of one term (spaces removed).
fn term_springs(term: &str, n_joints: usize) -> Result<Vec<Spring>, VjmError> {
    match term {
        "traditional" => return Ok(VirtualJointModel::traditional(n_joints).springs().to_vec()),
        "extended" => return Ok(VirtualJointModel::extended(n_joints).springs().to_vec()),
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
                 spring: a spring model holds traditional, extended, spring labels (J3x) and \
                 joint_tilt(J3x) findings (the model a diagnosis found is saved with its \
                 measurement errors taken out by diagnosed_model, CLI diagnose --save)"
            ),
        });
    }
    let (label, tilt) = match (name, inner) {
        ("joint_tilt", Some(label)) => (label, true),
        (label, None) => (label, false),
        _ => {
            return Err(VjmError::InvalidModel {
                message: format!(
                    "unknown model `{term}`: expected traditional, extended, spring labels like \
                     J3x, or what diagnose prints, e.g. traditional + joint_tilt(J3x)"
                ),
            })
        }
    };
    let looks_like_a_label =
        label.starts_with(['J', 'j']) && label[1..].starts_with(|c: char| c.is_ascii_digit());
    if !looks_like_a_label {
        return Err(VjmError::InvalidModel {
            message: format!(
                "unknown model `{term}`: expected traditional, extended, spring labels like J3x, \
                 or what diagnose prints, e.g. traditional + joint_tilt(J3x)"
            ),
        });
    }
    let spring = spring_label(label, n_joints).ok_or_else(|| VjmError::InvalidModel {
        message: format!(
            "model term `{term}`: `{label}` is not a spring label: expected J<joint><axis> with \
             joint 1..{n_joints} and axis z, x or y (e.g. J3x), or traditional / extended"
        ),
    })?;
    if tilt && spring.axis == SpringAxis::Z {
        return Err(VjmError::InvalidModel {
            message: format!("model term `{term}`: a tilt is about x or y, not z (the torsion)"),
        });
    }
    Ok(vec![spring])
}

/// `J3x` (or `j3x`) → joint 2 (0-based), axis x; None when not a label of a chain of
/// `n_joints` joints.
pub fn spring_label(label: &str, n_joints: usize) -> Option<Spring> {
    let rest = label.strip_prefix(['J', 'j'])?;
    let axis_char = rest.chars().last()?;
    let joint: usize = rest[..rest.len() - axis_char.len_utf8()].parse().ok()?;
    let axis: SpringAxis = axis_char.to_string().parse().ok()?;
    (1..=n_joints).contains(&joint).then_some(Spring {
        joint: joint - 1,
        axis,
    })
}
