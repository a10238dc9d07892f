//! The error type of the crate.

/// Everything that can go wrong in `vjm`.
///
/// Every variant names the offending item (link, joint, spring, row, column, option)
/// so that a user can fix the input without a debugger.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VjmError {
    /// The URDF file could not be read.
    #[error("cannot read URDF file `{path}`: {source}")]
    Io {
        /// The path as given.
        path: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The URDF text could not be parsed.
    #[error("invalid URDF: {message}")]
    Urdf {
        /// The parser's message.
        message: String,
    },
    /// The URDF text is larger or nests deeper than accepted: refused before parsing, so that
    /// a pathological file cannot overflow the parser's stack (see [`crate::bounded`]).
    #[error("{}{limit}", path.as_ref().map(|p| format!("`{p}`: ")).unwrap_or_default())]
    UrdfLimit {
        /// The file as given, when the text was read from one.
        path: Option<String>,
        /// What is too large or too deep, with the limit.
        limit: crate::bounded::TextLimitError,
    },
    /// A link named by the caller does not exist in the URDF.
    #[error("the {role} link `{name}` does not exist in the URDF (links: {available})")]
    MissingLink {
        /// `"base"` or `"tip"`.
        role: &'static str,
        /// The name asked for.
        name: String,
        /// Comma-separated names of the links that exist (truncated).
        available: String,
    },
    /// The base link is not an ancestor of the tip link.
    #[error("the base link `{base}` is not an ancestor of the tip link `{tip}` (the tip's root is `{root}`)")]
    NotAncestor {
        /// Base link name.
        base: String,
        /// Tip link name.
        tip: String,
        /// The root reached walking up from the tip.
        root: String,
    },
    /// A link has more than one parent joint, i.e. the URDF is not a tree.
    #[error("closed kinematic chain: link `{link}` is the child of several joints ({joints})")]
    ClosedChain {
        /// The link with several parents.
        link: String,
        /// The joints that all claim it as child.
        joints: String,
    },
    /// A joint on the chain mimics another one; mimic joints are not independent coordinates.
    #[error("joint `{joint}` on the chain mimics `{mimics}`; mimic joints are not supported on the base-tip chain")]
    MimicJoint {
        /// The mimic joint.
        joint: String,
        /// The joint it mimics.
        mimics: String,
    },
    /// A joint on the chain has a type this crate does not model.
    #[error("joint `{joint}` on the chain is {kind}; only revolute, continuous and fixed joints are supported")]
    UnsupportedJoint {
        /// The joint name.
        joint: String,
        /// Its URDF type (prismatic, floating, planar, spherical).
        kind: String,
    },
    /// A joint axis is zero or not finite.
    #[error("joint `{joint}` has an invalid axis {} (must be finite and non-zero)", stiffness_core::num::short_list(.axis))]
    InvalidAxis {
        /// The joint name.
        joint: String,
        /// The axis as written in the URDF.
        axis: [f64; 3],
    },
    /// A number of a joint in the robot description is not finite (origin `xyz`/`rpy`,
    /// limits), or a joint's limit range is empty.
    #[error("joint `{joint}`: {attribute} {message}")]
    InvalidJointValue {
        /// The joint name.
        joint: String,
        /// The attribute as written in the URDF (`origin xyz`, `origin rpy`, `limit lower`...).
        attribute: &'static str,
        /// What is wrong, with the value.
        message: String,
    },
    /// A link's `<inertial>` cannot give its weight (missing where the link has a shape, or
    /// not finite), or the chain has no masses at all; only needed where gravity is on.
    #[error("link `{link}`: {message}")]
    InvalidInertial {
        /// The link name (or what stands for it).
        link: String,
        /// What is wrong.
        message: String,
    },
    /// The chain between base and tip has no actuated joint.
    #[error("the chain from `{base}` to `{tip}` has no revolute or continuous joint")]
    NoActuatedJoints {
        /// Base link name.
        base: String,
        /// Tip link name.
        tip: String,
    },
    /// A value is NaN or infinite.
    #[error("non-finite value {} in {what} at row {row}, column {column}", stiffness_core::num::Short(*.value))]
    NonFinite {
        /// Which input (`"q"`, `"wrench"`, `"displacement"`, `"rotation"`, `"compliance"`, ...).
        what: &'static str,
        /// 0-based row (measurement / configuration index).
        row: usize,
        /// 0-based column.
        column: usize,
        /// The offending value.
        value: f64,
    },
    /// A slice has the wrong length.
    #[error("shape mismatch in {what}: expected {expected} values, got {got}")]
    ShapeMismatch {
        /// Which input or output buffer.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// Not enough measurement equations to identify the model.
    #[error(
        "too few measurements: {have} measurement equations, at least {need} are needed ({why})"
    )]
    TooFewMeasurements {
        /// Number of scalar measurement equations supplied.
        have: usize,
        /// Number needed.
        need: usize,
        /// Why that many are needed.
        why: String,
    },
    /// A virtual-joint model does not fit the chain or is malformed.
    #[error("invalid virtual-joint model: {message}")]
    InvalidModel {
        /// What is wrong, naming the spring or joint.
        message: String,
    },
    /// An option has an invalid value.
    #[error("invalid option `{name}`: {message}")]
    InvalidOption {
        /// The option's field name.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// An iterative decomposition hit its iteration cap (non-finite or extreme input).
    #[error(transparent)]
    NotConverged(#[from] stiffness_core::NotConverged),
    /// Two partial identifications that cannot be merged or finished together (different
    /// robot, model or options).
    #[error("cannot combine partial identifications: different {what} ({left} vs {right})")]
    IncompatiblePartials {
        /// What differs: `robot kinematics`, `model`, `options`.
        what: &'static str,
        /// The first partial's value.
        left: String,
        /// The other partial's (or the robot's) value.
        right: String,
    },
    /// A numerical routine failed (e.g. SVD did not converge, or a load beyond buckling).
    #[error("numerical failure: {message}")]
    Numerical {
        /// What failed.
        message: String,
    },
    /// A monitored computation ([`crate::design::plan::design_monitored`]) was cancelled
    /// through its token.
    #[error(transparent)]
    Cancelled(#[from] stiffness_core::Cancelled),
}

impl From<stiffness_core::lsq::ShapeMismatch> for VjmError {
    fn from(e: stiffness_core::lsq::ShapeMismatch) -> Self {
        VjmError::ShapeMismatch {
            what: e.what,
            expected: e.expected,
            got: e.got,
        }
    }
}
