//! The error type of CSJM identification: reading measurements, fitting, verifying.

use thiserror::Error;

/// Everything that can go wrong between a measurement file and an identified stiffness.
///
/// Row numbers are 1-based **data** rows (the header is not counted); line numbers are the
/// 1-based line in the file (the header is line 1), so both can be looked up directly in an
/// editor or a spreadsheet.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum IdentificationError {
    /// The measurement file could not be opened or read.
    #[error("cannot read measurement file {path}: {source}")]
    Io {
        /// The path that was given.
        path: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The CSV layer rejected the file (e.g. a row with the wrong number of fields).
    #[error("malformed CSV at line {line}: {message}")]
    Csv {
        /// 1-based line of the problem (0 if unknown).
        line: u64,
        /// The CSV parser's message.
        message: String,
    },
    /// A required column is absent from the header.
    #[error("missing column `{column}` (required: r11..r33, tx, ty, tz, ref)")]
    MissingColumn {
        /// The column name that was expected.
        column: &'static str,
    },
    /// A column name appears more than once in the header.
    #[error("column `{column}` appears more than once in the header")]
    DuplicateColumn {
        /// The repeated column name.
        column: String,
    },
    /// A field is not a number.
    #[error("data row {row} (line {line}), column `{column}`: cannot parse {value:?} as a number")]
    Parse {
        /// 1-based data row.
        row: usize,
        /// 1-based file line.
        line: u64,
        /// Column name.
        column: &'static str,
        /// The offending text.
        value: String,
    },
    /// A field is NaN or ±∞.
    #[error("data row {row} (line {line}), column `{column}`: value {} is not finite", stiffness_core::num::Short(*.value))]
    NonFinite {
        /// 1-based data row.
        row: usize,
        /// 1-based file line.
        line: u64,
        /// Column name.
        column: &'static str,
        /// The non-finite value.
        value: f64,
    },
    /// The `ref` field is not 0 or 1.
    #[error("data row {row} (line {line}): `ref` must be 0 or 1, found {value:?}")]
    BadReferenceFlag {
        /// 1-based data row.
        row: usize,
        /// 1-based file line.
        line: u64,
        /// The offending text.
        value: String,
    },
    /// The orientation of a row is not a rotation within the tolerance.
    #[error(
        "data row {row} (line {line}): r11..r33 is not a rotation matrix: orthogonality error \
         ‖RᵀR − I‖_F = {orthogonality_error:.3e} exceeds the tolerance {tol:.3e} \
         (to project measured matrices onto SO(3) instead, pass project=True)"
    )]
    NotARotation {
        /// 1-based data row.
        row: usize,
        /// 1-based file line.
        line: u64,
        /// ‖RᵀR − I‖_F of the row's matrix.
        orthogonality_error: f64,
        /// The tolerance it was checked against.
        tol: f64,
    },
    /// The orientation of a row has det ≤ 0 (a reflection or singular), so it cannot even be
    /// projected onto SO(3).
    #[error(
        "data row {row} (line {line}): r11..r33 has determinant {det:.4} ≤ 0 \
         (a reflection or singular matrix, not a rotation; check the sign of each entry)"
    )]
    Reflection {
        /// 1-based data row.
        row: usize,
        /// 1-based file line.
        line: u64,
        /// det of the row's matrix.
        det: f64,
    },
    /// No row has `ref` = 1.
    #[error(
        "no reference row: exactly one row must have ref = 1 (the pose R₀ with its pre-load τ₀)"
    )]
    MissingReference,
    /// More than one row has `ref` = 1.
    #[error("{} rows have ref = 1 (data rows {rows:?}); exactly one reference row is allowed", rows.len())]
    MultipleReferences {
        /// 1-based data rows flagged as reference.
        rows: Vec<usize>,
    },
    /// Too few measurements for the requested fit.
    #[error("{usable} usable load increments, but the {what} needs at least {required}")]
    TooFewMeasurements {
        /// What needed them (e.g. "first-order fit").
        what: &'static str,
        /// Increments available (rows other than the reference).
        usable: usize,
        /// Increments required.
        required: usize,
    },
    /// Two slices that must have one entry per measurement differ in length.
    #[error("{what}: {left} displacements but {right} load increments")]
    LengthMismatch {
        /// Which call.
        what: &'static str,
        /// Number of displacement increments.
        left: usize,
        /// Number of load increments.
        right: usize,
    },
    /// The displacements do not excite all three rotation directions well enough to fit K.
    #[error(
        "the fit is ill-conditioned: condition number {condition:.3e} of {matrix} exceeds the \
         limit {max_condition:.3e}; singular values of Ω (rad): {omega_singular_values:?}. \
         Load the joint about all three axes."
    )]
    IllConditioned {
        /// Which matrix: Ω (the displacements) or the column-scaled regressor.
        matrix: &'static str,
        /// σ_max/σ_min of that matrix.
        condition: f64,
        /// The limit from the fit options.
        max_condition: f64,
        /// Singular values of Ω = [Δζ₁ … Δζ_N] (3×N), descending, in rad.
        omega_singular_values: [f64; 3],
    },
    /// An input vector or matrix passed to the API is not finite.
    #[error("{what} is not finite")]
    NonFiniteInput {
        /// Which argument.
        what: &'static str,
    },
    /// The stiffness matrix cannot be inverted to predict a displacement.
    #[error("stiffness matrix is singular or ill-conditioned (condition number {condition:.3e}); cannot predict a displacement")]
    SingularStiffness {
        /// σ_max/σ_min of K.
        condition: f64,
    },
    /// A geometric input is degenerate (e.g. collinear tracker points).
    #[error("degenerate geometry: {message}")]
    Degenerate {
        /// What is degenerate and why.
        message: String,
    },
    /// The SVD inside the fit did not converge.
    #[error("the SVD of the regression matrix did not converge")]
    SvdFailed,
    /// A campaign or simulation input is invalid.
    #[error("invalid campaign setting `{field}`: {message}")]
    InvalidSetting {
        /// The setting.
        field: &'static str,
        /// Why it is invalid.
        message: String,
    },
    /// The simulator failed to find an equilibrium.
    #[error("simulation failed at load increment {index}: {message}")]
    Simulation {
        /// 0-based increment index.
        index: usize,
        /// The simulator's message.
        message: String,
    },
}
