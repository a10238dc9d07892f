//! The VJM measurement file (issue 5): one loaded measurement per row, SI units.
//!
//! Columns (header row required, any order):
//! - `q1..qn` — actuated joint angles from base to tip, rad;
//! - `fx,fy,fz` (N) and `mx,my,mz` (N·m) — the external wrench at the tip point, base-frame
//!   components;
//! - `dx,dy,dz` (m) — the measured tip displacement, loaded minus unloaded, base frame;
//! - optional `rx,ry,rz` (rad) — the tip rotation vector, base frame;
//! - optional `pose` — an integer configuration id;
//! - optional `set` — `train` or `test`.
//!
//! Reading validates everything before returning: a file either loads completely or gives one
//! [`DatasetError`] naming the line and column at fault. Writing goes to a temporary file that is
//! renamed into place, so a failed write never leaves a half-written file behind.
//!
//! ```
//! use vjm::dataset::Dataset;
//! let csv = "q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz,pose,set\n\
//!            0.1,0.2,10,0,0,0,0,0,0.0001,0.0002,0,0,train\n\
//!            0.3,0.4,0,10,0,0,0,0,0.0002,0.0001,0,1,test\n";
//! let data = Dataset::from_reader(csv.as_bytes(), 2)?;
//! assert_eq!(data.len(), 2);
//! assert_eq!(data.q(1), &[0.3, 0.4]);
//! # Ok::<(), vjm::dataset::DatasetError>(())
//! ```

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::measurements::Measurements;
use stiffness_core::num::Short;
use stiffness_core::table::{write_csv, CellKind, Column, CsvReader, Layout, Table, TableError};
use stiffness_core::Cancel;

/// Largest plausible displacement component, m. A cobot tip moving more than 5 cm under a
/// static test load is far outside any stiffness experiment; such values are almost always
/// millimetres written into a metre column.
pub const MAX_PLAUSIBLE_DISPLACEMENT: f64 = 0.05;
/// Largest plausible joint angle magnitude, rad (two turns). Larger values are most likely degrees.
pub const MAX_PLAUSIBLE_JOINT_ANGLE: f64 = 4.0 * std::f64::consts::PI;
/// Largest plausible tip rotation component under load, rad (about 5.7°).
pub const MAX_PLAUSIBLE_ROTATION: f64 = 0.1;
/// How far (rad) a recorded joint angle may lie outside the URDF limits before it is refused:
/// encoders report a hair beyond a soft limit, degrees or a swapped joint lie far beyond.
pub const JOINT_LIMIT_TOLERANCE: f64 = 1e-3;
/// Largest plausible force component, N (100 kN: ten times what a heavy industrial arm
/// carries). Larger values are a unit error or a corrupt cell; a single such cell would
/// otherwise dominate every fit (one 1e308 cell gave "100 %" errors and a spurious finding).
pub const MAX_PLAUSIBLE_FORCE: f64 = 1e5;
/// Largest plausible moment component, N·m (10 kN·m), for the same reason.
pub const MAX_PLAUSIBLE_MOMENT: f64 = 1e4;
/// A campaign whose every force component is below this (N) and every moment component below
/// [`MIN_INFORMATIVE_MOMENT`] carries no information about a stiffness: 1 mN on a cobot
/// (1e-4 rad/(N·m), 1 m reach) deflects the tip by 0.1 µm, a hundred times below a laser
/// tracker's resolution. Such loads are a unit or scaling error (a table multiplied by
/// 1e-300 gave "rank 0" and an exit status of 0).
pub const MIN_INFORMATIVE_FORCE: f64 = 1e-3;
/// The moment counterpart of [`MIN_INFORMATIVE_FORCE`], N·m (1 mN at 0.1 m).
pub const MIN_INFORMATIVE_MOMENT: f64 = 1e-4;

/// Which part of a campaign a row belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SetLabel {
    /// Used to fit models.
    Train,
    /// Held out: only used to measure prediction error and confirm findings.
    Test,
}

impl SetLabel {
    /// The label as written in the `set` column.
    pub fn as_str(self) -> &'static str {
        match self {
            SetLabel::Train => "train",
            SetLabel::Test => "test",
        }
    }
}

impl fmt::Display for SetLabel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Errors of reading, writing or building a measurement file. Line numbers count the header as
/// line 1, as a text editor shows them.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The CSV structure itself is broken (bad quoting, wrong number of fields, ...).
    #[error("line {line}: malformed CSV: {message}")]
    Csv {
        /// File line (header = 1), 0 when unknown.
        line: u64,
        /// What the CSV parser reported.
        message: String,
    },
    /// A required column is absent from the header.
    #[error("missing column '{column}' (required columns: q1..q{n_joints}, fx,fy,fz,mx,my,mz, dx,dy,dz)")]
    MissingColumn {
        /// The column name.
        column: String,
        /// Joint count of the chain.
        n_joints: usize,
    },
    /// A header name is not one of the file's columns.
    #[error("unknown column '{column}' (allowed: q1..qN, fx,fy,fz,mx,my,mz, dx,dy,dz, rx,ry,rz, pose, set)")]
    UnknownColumn {
        /// The column name.
        column: String,
    },
    /// A header name appears twice.
    #[error("column '{column}' appears more than once")]
    DuplicateColumn {
        /// The column name.
        column: String,
    },
    /// The file's `q` columns do not match the chain's actuated joint count.
    #[error(
        "the data have {} but the chain has {expected} actuated joints (expected columns q1..q{expected})",
        joint_columns(*found)
    )]
    JointCount {
        /// Joint columns found (or joint values per row given).
        found: usize,
        /// Actuated joints of the chain.
        expected: usize,
    },
    /// Only some of `rx,ry,rz` are present.
    #[error("rotation columns must be given together: found {found:?}, need rx, ry and rz")]
    PartialRotation {
        /// The rotation columns that are present.
        found: Vec<String>,
    },
    /// A cell is not a number (or not an integer for `pose`).
    #[error("line {line}, column '{column}': cannot parse '{text}' as {expected}")]
    Parse {
        /// File line (header = 1).
        line: u64,
        /// The column name.
        column: String,
        /// The offending text.
        text: String,
        /// What was expected.
        expected: &'static str,
    },
    /// A cell is NaN or infinite.
    #[error("line {line}, column '{column}': value {} is not finite", Short(*.value))]
    NonFinite {
        /// File line (header = 1).
        line: u64,
        /// The column name.
        column: String,
        /// The value.
        value: f64,
    },
    /// The `set` label is neither `train` nor `test`.
    #[error("line {line}, column 'set': unknown label '{label}' (expected 'train' or 'test')")]
    UnknownSet {
        /// File line (header = 1).
        line: u64,
        /// The label found.
        label: String,
    },
    /// A displacement, rotation or joint angle is physically implausible for its unit.
    #[error("line {line}, column '{column}': {} is larger than physically plausible ({} {unit}); {hint}", Short(*.value), Short(*.limit))]
    Implausible {
        /// File line (header = 1).
        line: u64,
        /// The column name.
        column: String,
        /// The value.
        value: f64,
        /// The plausibility limit.
        limit: f64,
        /// The expected unit.
        unit: &'static str,
        /// The likely cause, e.g. "looks like mm, expected m".
        hint: &'static str,
    },
    /// The file is empty: not even a header line.
    #[error(
        "the file is empty: no header line (expected columns q1..qN, fx,fy,fz,mx,my,mz, dx,dy,dz)"
    )]
    NoHeader,
    /// The file has a header but no data rows.
    #[error("no data rows")]
    Empty,
    /// A joint angle lies outside the joint's limits in the robot description.
    #[error(
        "line {line}, column '{column}' (joint `{joint}`): {} rad is outside the joint's \
         limits [{}, {}] rad (degrees, or a wrong joint order? If the robot really went \
         there, pass allow_outside_limits=True in Python or --allow-outside-limits on the command \
         line)",
        Short(*.value),
        Short(*.lower),
        Short(*.upper)
    )]
    OutsideLimits {
        /// File line (header = 1; row i of arrays is line i + 2).
        line: u64,
        /// The column, `q1`..`qn`.
        column: String,
        /// The joint's name in the robot description.
        joint: String,
        /// The angle, rad.
        value: f64,
        /// Lower limit, rad.
        lower: f64,
        /// Upper limit, rad.
        upper: f64,
    },
    /// Every wrench is zero: no load, so nothing about the stiffness can be learnt.
    #[error(
        "no load in any of the {rows} rows (fx, fy, fz, mx, my, mz are all 0): a stiffness cannot \
         be identified without loading the robot"
    )]
    NoLoad {
        /// Rows in the data.
        rows: usize,
    },
    /// Every load is so small that no arm deflects measurably under it (see
    /// [`MIN_INFORMATIVE_FORCE`]).
    #[error(
        "the loads carry no information: the largest force component of the {rows} rows is \
         {force:.3e} N and the largest moment component {moment:.3e} N·m, below what deflects \
         any arm measurably ({MIN_INFORMATIVE_FORCE} N, {MIN_INFORMATIVE_MOMENT} N·m); check \
         the unit (N, N·m) and the scale of fx..mz"
    )]
    NegligibleLoad {
        /// Rows in the data.
        rows: usize,
        /// The largest |fx|, |fy|, |fz|, N.
        force: f64,
        /// The largest |mx|, |my|, |mz|, N·m.
        moment: f64,
    },
    /// Every displacement is zero: relative errors would be 0/0.
    #[error(
        "no displacement in any of the {rows} rows (dx, dy, dz are all 0): either the robot is \
         rigid to the instrument's resolution or the displacement columns are empty"
    )]
    NoDisplacement {
        /// Rows in the data.
        rows: usize,
    },
    /// In-memory construction: a flat array does not have the expected length.
    #[error("'{name}' has {found} values, expected {expected} ({rows} rows × {per_row})")]
    Shape {
        /// Which array.
        name: &'static str,
        /// Values given.
        found: usize,
        /// Values expected.
        expected: usize,
        /// Rows of the dataset.
        rows: usize,
        /// Values per row.
        per_row: usize,
    },
    /// Reading was cancelled through its token.
    #[error("cancelled")]
    Cancelled,
    /// The train/test split leaves one side empty.
    #[error("the train/test split leaves no {which} rows")]
    EmptySplit {
        /// `train` or `test`.
        which: SetLabel,
    },
}

/// Whether a lower-cased column name is a joint position `q1`, `q2`, … (no leading zero), as a
/// measurement file and a pose table name them.
pub(crate) fn is_joint_column(name: &str) -> bool {
    name.len() > 1
        && name.starts_with('q')
        && name[1..].bytes().all(|b| b.is_ascii_digit())
        && !name[1..].starts_with('0')
}

impl From<TableError> for DatasetError {
    fn from(e: TableError) -> Self {
        match e {
            TableError::Io { path, source } => DatasetError::Io { path, source },
            TableError::NoHeader => DatasetError::NoHeader,
            TableError::Parse {
                line,
                column,
                text,
                expected,
                ..
            } => DatasetError::Parse {
                line,
                column,
                text,
                expected,
            },
            // The only label column of a measurement file is `set`.
            TableError::Label { line, text, .. } => DatasetError::UnknownSet { line, label: text },
            TableError::Malformed { line, message } => DatasetError::Csv { line, message },
            TableError::Cancelled => DatasetError::Cancelled,
            other => DatasetError::Csv {
                line: 0,
                message: other.to_string(),
            },
        }
    }
}

impl DatasetError {
    /// The error of a cell check (which counts row i as line i + 2) with the line the row has
    /// in the file.
    pub(crate) fn at_file_lines(mut self, table: &Table) -> Self {
        match &mut self {
            DatasetError::NonFinite { line, .. }
            | DatasetError::Implausible { line, .. }
            | DatasetError::OutsideLimits { line, .. } => {
                *line = table.line_of((*line as usize).saturating_sub(2));
            }
            _ => {}
        }
        self
    }
}

/// A validated VJM measurement campaign. All vectors have base-frame components (see
/// `docs/conventions.md`); arrays are row-major flat slices.
///
/// The numeric columns are owned (a file read, [`Dataset::new`]: `Dataset<'static>`) or borrowed
/// from the caller's arrays ([`Dataset::from_columns`]), so that a large campaign held elsewhere (a
/// numpy array in the Python package) is validated and diagnosed without a copy.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset<'a> {
    n_joints: usize,
    q: Cow<'a, [f64]>,
    wrench: Cow<'a, [f64]>,
    displacement: Cow<'a, [f64]>,
    rotation: Option<Cow<'a, [f64]>>,
    pose: Option<Cow<'a, [i64]>>,
    set: Option<Vec<SetLabel>>,
}

/// A [`Dataset`]'s columns, owned and row-major ([`Dataset::into_columns`]): the same units and
/// frames as the dataset's accessors.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct DatasetColumns {
    /// Actuated joints per configuration.
    pub n_joints: usize,
    /// Joint angles, N×n, rad.
    pub q: Vec<f64>,
    /// Wrenches `[fx, fy, fz, mx, my, mz]`, N×6, base frame, N and N·m.
    pub wrench: Vec<f64>,
    /// Tip displacements, N×3, base frame, m.
    pub displacement: Vec<f64>,
    /// Tip rotation vectors, N×3, base frame, rad, when the table has them.
    pub rotation: Option<Vec<f64>>,
    /// Pose ids, when the table has them.
    pub pose: Option<Vec<i64>>,
    /// Set labels, when the table has them.
    pub set: Option<Vec<SetLabel>>,
}

const WRENCH_COLUMNS: [&str; 6] = ["fx", "fy", "fz", "mx", "my", "mz"];
const DISPLACEMENT_COLUMNS: [&str; 3] = ["dx", "dy", "dz"];
const ROTATION_COLUMNS: [&str; 3] = ["rx", "ry", "rz"];
/// The `set` labels, in the order of the reader's label codes.
const SET_LABELS: &[&str] = &["train", "test"];

fn check_len(
    name: &'static str,
    v: &[f64],
    rows: usize,
    per_row: usize,
) -> Result<(), DatasetError> {
    if v.len() != rows * per_row {
        return Err(DatasetError::Shape {
            name,
            found: v.len(),
            expected: rows * per_row,
            rows,
            per_row,
        });
    }
    Ok(())
}

/// Checks one value for finiteness and plausibility; `line` is the file line (or row index + 2
/// for in-memory data, so that messages match the CSV the data would be written to). The
/// column's first letter picks the unit (`q`, `f`, `m`, `d`, `r`); also the pose table's.
pub(crate) fn check_value(line: u64, column: &str, value: f64) -> Result<(), DatasetError> {
    if !value.is_finite() {
        return Err(DatasetError::NonFinite {
            line,
            column: column.to_string(),
            value,
        });
    }
    let implausible = |limit: f64, unit: &'static str, hint: &'static str| {
        Err(DatasetError::Implausible {
            line,
            column: column.to_string(),
            value,
            limit,
            unit,
            hint,
        })
    };
    if column.starts_with('d') && value.abs() > MAX_PLAUSIBLE_DISPLACEMENT {
        return implausible(MAX_PLAUSIBLE_DISPLACEMENT, "m", "looks like mm, expected m");
    }
    if column.starts_with('r') && value.abs() > MAX_PLAUSIBLE_ROTATION {
        return implausible(
            MAX_PLAUSIBLE_ROTATION,
            "rad",
            "looks like degrees or mrad, expected rad",
        );
    }
    if column.starts_with('f') && value.abs() > MAX_PLAUSIBLE_FORCE {
        return implausible(MAX_PLAUSIBLE_FORCE, "N", "check the unit (N) and the cell");
    }
    if column.starts_with('m') && value.abs() > MAX_PLAUSIBLE_MOMENT {
        return implausible(
            MAX_PLAUSIBLE_MOMENT,
            "N·m",
            "check the unit (N·m) and the cell",
        );
    }
    if column.starts_with('q') && value.abs() > MAX_PLAUSIBLE_JOINT_ANGLE {
        return implausible(
            MAX_PLAUSIBLE_JOINT_ANGLE,
            "rad",
            "looks like degrees, expected rad",
        );
    }
    Ok(())
}

/// The value checks of a measurement table held as row-major arrays ([`Measurements`]),
/// without copying them: finiteness and plausibility of
/// every cell (row `i` is reported as line `i + 2`, its line in the written CSV), then that the
/// data carry information (some load, some displacement). Shapes must already match. This is
/// the one validation of in-memory data: [`Dataset::new`] and the Python `identify` call it.
pub fn check_values(n_joints: usize, data: Measurements<'_>) -> Result<(), DatasetError> {
    let (wrench, displacement) = (data.wrench(), data.displacement());
    check_cells(
        n_joints,
        data.q(),
        Some(wrench),
        Some(displacement),
        data.rotation(),
    )?;
    check_information(wrench, displacement)
}

/// The per-cell part of [`check_values`] for the columns that are given; rows are counted
/// from `q`. Shared with [`check_poses`], so that a prediction refuses exactly the joint
/// angles and loads an identification refuses.
pub(crate) fn check_cells(
    n_joints: usize,
    q: &[f64],
    wrench: Option<&[f64]>,
    displacement: Option<&[f64]>,
    rotation: Option<&[f64]>,
) -> Result<(), DatasetError> {
    // The fast path compares without building column names; a name is formatted only for the
    // cell that fails (check_value), so 10⁶ rows cost a few ms.
    // NaN fails too: `is_finite` first, then the cap.
    let fails = |v: f64, limit: f64| !v.is_finite() || v.abs() > limit;
    let check = |i: usize, column: &str, v: f64, limit: f64| {
        if fails(v, limit) {
            check_value(i as u64 + 2, column, v)
        } else {
            Ok(())
        }
    };
    let rows = q.len().checked_div(n_joints).unwrap_or(0);
    // The first failing row is found on every core; its message is built by the loop below.
    let row_fails = |i: usize| {
        q[i * n_joints..(i + 1) * n_joints]
            .iter()
            .any(|&v| fails(v, MAX_PLAUSIBLE_JOINT_ANGLE))
            || wrench.is_some_and(|w| (0..6).any(|k| fails(w[i * 6 + k], WRENCH_CAPS[k])))
            || displacement
                .is_some_and(|d| (0..3).any(|k| fails(d[i * 3 + k], MAX_PLAUSIBLE_DISPLACEMENT)))
            || rotation.is_some_and(|r| (0..3).any(|k| fails(r[i * 3 + k], MAX_PLAUSIBLE_ROTATION)))
    };
    let Some(first) = (0..rows)
        .into_par_iter()
        .with_min_len(1 << 14)
        .find_first(|&i| row_fails(i))
    else {
        return Ok(());
    };
    for i in first..rows {
        for j in 0..n_joints {
            let v = q[i * n_joints + j];
            if fails(v, MAX_PLAUSIBLE_JOINT_ANGLE) {
                check_value(i as u64 + 2, &format!("q{}", j + 1), v)?;
            }
        }
        if let Some(w) = wrench {
            for (k, c) in WRENCH_COLUMNS.iter().enumerate() {
                check(i, c, w[i * 6 + k], WRENCH_CAPS[k])?;
            }
        }
        if let Some(d) = displacement {
            for (k, c) in DISPLACEMENT_COLUMNS.iter().enumerate() {
                check(i, c, d[i * 3 + k], MAX_PLAUSIBLE_DISPLACEMENT)?;
            }
        }
        if let Some(r) = rotation {
            for (k, c) in ROTATION_COLUMNS.iter().enumerate() {
                check(i, c, r[i * 3 + k], MAX_PLAUSIBLE_ROTATION)?;
            }
        }
    }
    Ok(())
}

/// The checks of [`check_arrays`] that apply to the input of a prediction or a compensation
/// (`q` N×n row-major, rad; `wrench` N×6 when the load is given per row): the same
/// plausibility caps on every joint angle and wrench component and, given a chain, the same
/// joint limits (callers skip them when the user opts out with `allow_outside_limits`), with
/// the same messages (row `i` is line `i + 2`). There is no displacement and a zero load is a
/// valid question, so nothing is required to carry information. Shapes must already match.
/// [`ArraysCheck::NonFinite`] when a value is NaN or infinite: nothing else was checked, the
/// caller reports it by array, row and column.
pub fn check_poses(
    n_joints: usize,
    q: &[f64],
    wrench: Option<&[f64]>,
    limits_of: Option<&crate::SerialChain>,
) -> Result<ArraysCheck, DatasetError> {
    let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
    if !(finite(q) && wrench.is_none_or(finite)) {
        return Ok(ArraysCheck::NonFinite);
    }
    check_cells(n_joints, q, wrench, None, None)?;
    if let Some(chain) = limits_of {
        check_joint_limits(chain, q)?;
    }
    Ok(ArraysCheck::Passed)
}

/// What [`check_arrays`] found when it returned no error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ArraysCheck {
    /// Every check passed.
    Passed,
    /// Some value is NaN or infinite; nothing else was checked (the caller reports it by
    /// array, row and column, as `identify` does).
    NonFinite,
}

/// Rows per task of [`check_arrays`]: 16 384 rows of a 7-joint table are 0.5 MiB.
const CHECK_CHUNK: usize = 1 << 14;

/// [`check_values`] and, given a chain, [`check_joint_limits`] of row-major arrays (shapes
/// must already match), split so that a caller can run them on ranges of rows while it reads
/// those rows anyway ([`rows_ok`](Self::rows_ok), e.g. fused into
/// [`crate::identify_checking_rows`]), and report the first error only when a range failed
/// ([`report`](Self::report): the error those functions give, with its line and column).
#[derive(Debug)]
pub struct ArrayChecks<'a> {
    n_joints: usize,
    q: &'a [f64],
    wrench: &'a [f64],
    displacement: &'a [f64],
    rotation: Option<&'a [f64]>,
    limits_of: Option<&'a crate::SerialChain>,
    /// Per joint, the interval q must lie in: plausible and, given a chain, inside its
    /// limits widened by [`JOINT_LIMIT_TOLERANCE`].
    bounds: Vec<(f64, f64)>,
}

const WRENCH_CAPS: [f64; 6] = [
    MAX_PLAUSIBLE_FORCE,
    MAX_PLAUSIBLE_FORCE,
    MAX_PLAUSIBLE_FORCE,
    MAX_PLAUSIBLE_MOMENT,
    MAX_PLAUSIBLE_MOMENT,
    MAX_PLAUSIBLE_MOMENT,
];

// The negated comparisons below are deliberate: they are true for NaN.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
impl<'a> ArrayChecks<'a> {
    /// The checks of these arrays; the joint limits only when `limits_of` is given.
    pub fn new(
        n_joints: usize,
        data: Measurements<'a>,
        limits_of: Option<&'a crate::SerialChain>,
    ) -> Self {
        let Measurements {
            q,
            wrench,
            displacement,
            rotation,
        } = data;
        // One interval per joint covers both checks: plausible, and (given a chain) inside
        // the limits widened by the tolerance.
        let cap = MAX_PLAUSIBLE_JOINT_ANGLE;
        let bounds = match limits_of {
            Some(c) => c
                .limits()
                .iter()
                .map(|&(lo, hi)| {
                    (
                        (lo - JOINT_LIMIT_TOLERANCE).max(-cap),
                        (hi + JOINT_LIMIT_TOLERANCE).min(cap),
                    )
                })
                .collect(),
            None => vec![(-cap, cap); n_joints],
        };
        Self {
            n_joints,
            q,
            wrench,
            displacement,
            rotation,
            limits_of,
            bounds,
        }
    }

    /// Whether rows `[start, end)` pass every check (finite, plausible, inside the limits).
    /// No early exit, so the loops vectorise.
    pub fn rows_ok(&self, start: usize, end: usize) -> bool {
        fn over(values: &[f64], cap: f64) -> bool {
            values.iter().fold(false, |bad, v| bad | !(v.abs() <= cap))
        }
        // Rows as fixed-size arrays, so that the per-column loops unroll and vectorise.
        fn q_outside<const N: usize>(q: &[f64], bounds: &[(f64, f64)]) -> bool {
            let mut lo = [0.0; N];
            let mut hi = [0.0; N];
            for (j, &(l, h)) in bounds.iter().take(N).enumerate() {
                (lo[j], hi[j]) = (l, h);
            }
            let (rows, _) = q.as_chunks::<N>();
            let mut bad = false;
            for row in rows {
                for j in 0..N {
                    bad |= !(row[j] >= lo[j] && row[j] <= hi[j]);
                }
            }
            bad
        }
        let n = self.n_joints;
        let q = &self.q[start * n..end * n];
        let mut bad = match n {
            6 => q_outside::<6>(q, &self.bounds),
            7 => q_outside::<7>(q, &self.bounds),
            _ => q.chunks_exact(n).any(|row| {
                row.iter()
                    .zip(&self.bounds)
                    .any(|(&v, &(lo, hi))| !(v >= lo && v <= hi))
            }),
        };
        bad |= over(
            &self.displacement[start * 3..end * 3],
            MAX_PLAUSIBLE_DISPLACEMENT,
        ) | self
            .rotation
            .is_some_and(|r| over(&r[start * 3..end * 3], MAX_PLAUSIBLE_ROTATION));
        let (wrench, _) = self.wrench[start * 6..end * 6].as_chunks::<6>();
        for row in wrench {
            for j in 0..6 {
                bad |= !(row[j].abs() <= WRENCH_CAPS[j]);
            }
        }
        !bad
    }

    /// After [`rows_ok`](Self::rows_ok) refused some rows, or to check everything: the first
    /// error of [`check_values`] then [`check_joint_limits`], or [`ArraysCheck::NonFinite`]
    /// when some value is NaN or infinite (the caller reports it by array, row and column).
    pub fn report(&self) -> Result<ArraysCheck, DatasetError> {
        let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
        if !(finite(self.q)
            && finite(self.wrench)
            && finite(self.displacement)
            && self.rotation.is_none_or(finite))
        {
            return Ok(ArraysCheck::NonFinite);
        }
        check_values(
            self.n_joints,
            Measurements::new(self.q, self.wrench, self.displacement).with_rotation(self.rotation),
        )?;
        if let Some(chain) = self.limits_of {
            check_joint_limits(chain, self.q)?;
        }
        Ok(ArraysCheck::Passed)
    }

    /// That the data carry information (some load, some displacement): cheap, not per row.
    pub fn information(&self) -> Result<(), DatasetError> {
        check_information(self.wrench, self.displacement)
    }
}

/// Every check of [`ArrayChecks`] on all rows, split across rayon tasks: one pass when
/// everything is in order, the checks' own first error otherwise.
pub fn check_arrays(
    n_joints: usize,
    data: Measurements<'_>,
    limits_of: Option<&crate::SerialChain>,
) -> Result<ArraysCheck, DatasetError> {
    use rayon::prelude::*;
    let checks = ArrayChecks::new(n_joints, data, limits_of);
    let rows = data.displacement().len() / 3;
    let ok = (0..rows.div_ceil(CHECK_CHUNK))
        .into_par_iter()
        .all(|c| checks.rows_ok(c * CHECK_CHUNK, ((c + 1) * CHECK_CHUNK).min(rows)));
    if !ok {
        let found = checks.report()?;
        if found == ArraysCheck::NonFinite {
            return Ok(found);
        }
    }
    checks.information()?;
    Ok(ArraysCheck::Passed)
}

/// Refuses the first joint angle of `q` (N×n row-major, rad) outside `chain`'s limits by more
/// than [`JOINT_LIMIT_TOLERANCE`] (continuous joints have none), naming line (row + 2), column
/// and joint. Callers skip it when the user opts out (`allow_outside_limits`).
pub fn check_joint_limits(chain: &crate::SerialChain, q: &[f64]) -> Result<(), DatasetError> {
    let n = chain.n_joints();
    if n == 0 || !q.len().is_multiple_of(n) {
        return Err(DatasetError::JointCount {
            found: q.len(),
            expected: n,
        });
    }
    let limits = chain.limits();
    for (i, row) in q.chunks_exact(n).enumerate() {
        for (j, &value) in row.iter().enumerate() {
            let (lower, upper) = limits[j];
            if value < lower - JOINT_LIMIT_TOLERANCE || value > upper + JOINT_LIMIT_TOLERANCE {
                return Err(DatasetError::OutsideLimits {
                    line: i as u64 + 2,
                    column: format!("q{}", j + 1),
                    joint: chain.joint_names()[j].clone(),
                    value,
                    lower,
                    upper,
                });
            }
        }
    }
    Ok(())
}

impl Dataset<'static> {
    /// Builds a dataset from row-major arrays: `q` N×n (rad), `wrench` N×6 (N, N·m),
    /// `displacement` N×3 (m), optional `rotation` N×3 (rad), `pose` and `set` of length N.
    /// Validates shapes, finiteness and plausibility exactly as [`Dataset::from_reader`] does
    /// (row `i` is reported as line `i + 2`, its line in the written CSV).
    pub fn new(
        n_joints: usize,
        q: Vec<f64>,
        wrench: Vec<f64>,
        displacement: Vec<f64>,
        rotation: Option<Vec<f64>>,
        pose: Option<Vec<i64>>,
        set: Option<Vec<SetLabel>>,
    ) -> Result<Self, DatasetError> {
        Dataset::from_columns(
            n_joints,
            Cow::Owned(q),
            Cow::Owned(wrench),
            Cow::Owned(displacement),
            rotation.map(Cow::Owned),
            pose.map(Cow::Owned),
            set,
        )
    }
}

impl<'a> Dataset<'a> {
    /// The same data, owned (copies what was borrowed).
    pub fn into_owned(self) -> Dataset<'static> {
        Dataset {
            n_joints: self.n_joints,
            q: Cow::Owned(self.q.into_owned()),
            wrench: Cow::Owned(self.wrench.into_owned()),
            displacement: Cow::Owned(self.displacement.into_owned()),
            rotation: self.rotation.map(|r| Cow::Owned(r.into_owned())),
            pose: self.pose.map(|p| Cow::Owned(p.into_owned())),
            set: self.set,
        }
    }

    /// A dataset over columns that are borrowed (`Cow::Borrowed`: the caller's arrays, not
    /// copied) or owned; the shapes and the validation of [`Dataset::new`], which calls it.
    ///
    /// ```
    /// use std::borrow::Cow;
    /// use vjm::dataset::Dataset;
    /// let q = [0.1, 0.2, 0.3, 0.4];
    /// let wrench = [10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.0];
    /// let displacement = [1e-4, 2e-4, 0.0, 2e-4, 1e-4, 0.0];
    /// let columns = |q: &[f64]| {
    ///     let (w, d) = (Cow::Borrowed(&wrench[..]), Cow::Borrowed(&displacement[..]));
    ///     Dataset::from_columns(2, Cow::Borrowed(q), w, d, None, None, None).map(|d| d.q(1).to_vec())
    /// };
    /// assert_eq!(columns(&q)?, [0.3, 0.4]);
    /// assert!(columns(&q[..3]).is_err()); // 3 angles for 2 rows of 2 joints
    /// # Ok::<(), vjm::dataset::DatasetError>(())
    /// ```
    pub fn from_columns(
        n_joints: usize,
        q: Cow<'a, [f64]>,
        wrench: Cow<'a, [f64]>,
        displacement: Cow<'a, [f64]>,
        rotation: Option<Cow<'a, [f64]>>,
        pose: Option<Cow<'a, [i64]>>,
        set: Option<Vec<SetLabel>>,
    ) -> Result<Self, DatasetError> {
        let rows = displacement.len() / 3;
        if rows == 0 {
            return Err(DatasetError::Empty);
        }
        check_len("displacement", &displacement, rows, 3)?;
        if n_joints == 0 || q.len() != rows * n_joints {
            if q.len().is_multiple_of(rows) {
                return Err(DatasetError::JointCount {
                    found: q.len() / rows,
                    expected: n_joints,
                });
            }
            check_len("q", &q, rows, n_joints)?;
        }
        check_len("wrench", &wrench, rows, 6)?;
        if let Some(r) = &rotation {
            check_len("rotation", r, rows, 3)?;
        }
        if let Some(p) = &pose {
            if p.len() != rows {
                return Err(DatasetError::Shape {
                    name: "pose",
                    found: p.len(),
                    expected: rows,
                    rows,
                    per_row: 1,
                });
            }
        }
        if let Some(s) = &set {
            if s.len() != rows {
                return Err(DatasetError::Shape {
                    name: "set",
                    found: s.len(),
                    expected: rows,
                    rows,
                    per_row: 1,
                });
            }
        }
        check_values(
            n_joints,
            Measurements::new(&q, &wrench, &displacement).with_rotation(rotation.as_deref()),
        )?;
        Ok(Dataset {
            n_joints,
            q,
            wrench,
            displacement,
            rotation,
            pose,
            set,
        })
    }

    /// Refuses the first joint angle outside `chain`'s limits by more than
    /// [`JOINT_LIMIT_TOLERANCE`] (continuous joints have none), naming line, column and joint.
    /// Callers skip it when the user opts out (`allow_outside_limits`).
    pub fn check_joint_limits(&self, chain: &crate::SerialChain) -> Result<(), DatasetError> {
        if chain.n_joints() != self.n_joints {
            return Err(DatasetError::JointCount {
                found: self.n_joints,
                expected: chain.n_joints(),
            });
        }
        check_joint_limits(chain, &self.q)
    }

    /// Reads and validates a measurement file for a chain with `n_joints` actuated joints.
    pub fn read_csv(
        path: impl AsRef<Path>,
        n_joints: usize,
    ) -> Result<Dataset<'static>, DatasetError> {
        Ok(Dataset::read_table(CsvReader::open(path)?, n_joints)?.0)
    }

    /// [`Dataset::read_csv`] and the SHA-256 (lowercase hex) of exactly the bytes read, taken
    /// in the same pass (what a saved model records as its data's fingerprint:
    /// [`DataSource::file_with_sha256`](crate::stiffness_model::DataSource::file_with_sha256)).
    pub fn read_csv_with_sha256(
        path: impl AsRef<Path>,
        n_joints: usize,
    ) -> Result<(Dataset<'static>, String), DatasetError> {
        let (data, sha256) = Dataset::read_table(CsvReader::open_hashing(path)?, n_joints)?;
        let sha256 = sha256.expect("a hashing reader returns its hash");
        Ok((data, crate::hashing::hex(&sha256)))
    }

    /// Reads and validates a measurement file from any reader (see the module docs for columns).
    pub fn from_reader(
        reader: impl Read,
        n_joints: usize,
    ) -> Result<Dataset<'static>, DatasetError> {
        Ok(Dataset::read_table(CsvReader::from_reader(reader)?, n_joints)?.0)
    }

    /// The rows of an opened table (the one reader of `stiffness_core::table`: chunked, on
    /// every core), then the cell checks of in-memory data, with the file's lines in messages.
    fn read_table<R: Read>(
        reader: CsvReader<R>,
        n_joints: usize,
    ) -> Result<(Dataset<'static>, Option<[u8; 32]>), DatasetError> {
        let headers = reader.header();
        if headers.iter().all(|h| h.is_empty()) {
            return Err(DatasetError::NoHeader);
        }
        // Map column name -> field index, rejecting unknown and duplicate names.
        let mut index: BTreeMap<String, usize> = BTreeMap::new();
        let mut q_found = 0usize;
        for (k, h) in headers.iter().enumerate() {
            let name = h.to_ascii_lowercase();
            let known = WRENCH_COLUMNS.contains(&name.as_str())
                || DISPLACEMENT_COLUMNS.contains(&name.as_str())
                || ROTATION_COLUMNS.contains(&name.as_str())
                || name == "pose"
                || name == "set";
            let is_q = is_joint_column(&name);
            if !known && !is_q {
                return Err(DatasetError::UnknownColumn {
                    column: h.to_string(),
                });
            }
            if is_q {
                q_found += 1;
            }
            if index.insert(name, k).is_some() {
                return Err(DatasetError::DuplicateColumn {
                    column: h.to_string(),
                });
            }
        }
        // q columns must be exactly q1..qn.
        if q_found != n_joints {
            return Err(DatasetError::JointCount {
                found: q_found,
                expected: n_joints,
            });
        }
        let need = |c: &str| -> Result<(usize, String), DatasetError> {
            index
                .get(c)
                .map(|&k| (k, c.to_string()))
                .ok_or_else(|| DatasetError::MissingColumn {
                    column: c.to_string(),
                    n_joints,
                })
        };
        let q_cols: Vec<(usize, String)> = (1..=n_joints)
            .map(|j| need(&format!("q{j}")))
            .collect::<Result<_, _>>()?;
        let w_cols: Vec<(usize, String)> = WRENCH_COLUMNS
            .iter()
            .map(|c| need(c))
            .collect::<Result<_, _>>()?;
        let d_cols: Vec<(usize, String)> = DISPLACEMENT_COLUMNS
            .iter()
            .map(|c| need(c))
            .collect::<Result<_, _>>()?;
        let r_present: Vec<String> = ROTATION_COLUMNS
            .iter()
            .filter(|c| index.contains_key(**c))
            .map(|c| c.to_string())
            .collect();
        let r_cols: Option<Vec<(usize, String)>> = match r_present.len() {
            0 => None,
            3 => Some(
                ROTATION_COLUMNS
                    .iter()
                    .map(|c| (index[*c], c.to_string()))
                    .collect(),
            ),
            _ => return Err(DatasetError::PartialRotation { found: r_present }),
        };
        let mut layout = Layout::new();
        let q_g = layout.group(CellKind::Float, q_cols);
        let w_g = layout.group(CellKind::Float, w_cols);
        let d_g = layout.group(CellKind::Float, d_cols);
        let r_g = r_cols.map(|c| layout.group(CellKind::Float, c));
        let pose_g = index
            .get("pose")
            .map(|&k| layout.group(CellKind::Integer, vec![(k, "pose".to_string())]));
        let set_g = index
            .get("set")
            .map(|&k| layout.group(CellKind::Label(SET_LABELS), vec![(k, "set".to_string())]));
        let mut table = reader.read(&layout, &Cancel::new())?;
        let q = table.take_floats(q_g);
        let wrench = table.take_floats(w_g);
        let displacement = table.take_floats(d_g);
        let rotation = r_g.map(|g| table.take_floats(g));
        let pose = pose_g.map(|g| table.take_integers(g));
        let set = set_g.map(|g| {
            table
                .take_labels(g)
                .into_iter()
                .map(|c| {
                    if c == 0 {
                        SetLabel::Train
                    } else {
                        SetLabel::Test
                    }
                })
                .collect()
        });
        if displacement.is_empty() {
            return Err(DatasetError::Empty);
        }
        // The one check of in-memory data; it counts row i as line i + 2, the file may differ
        // (blank lines).
        check_cells(
            n_joints,
            &q,
            Some(&wrench),
            Some(&displacement),
            rotation.as_deref(),
        )
        .map_err(|e| e.at_file_lines(&table))?;
        check_information(&wrench, &displacement)?;
        let data = Dataset {
            n_joints,
            q: Cow::Owned(q),
            wrench: Cow::Owned(wrench),
            displacement: Cow::Owned(displacement),
            rotation: rotation.map(Cow::Owned),
            pose: pose.map(Cow::Owned),
            set,
        };
        Ok((data, table.sha256()))
    }

    /// Writes the dataset as CSV to `path`, atomically: the data go to a temporary file in the
    /// same directory which is renamed over `path` only once it is complete.
    pub fn write_csv(&self, path: impl AsRef<Path>) -> Result<(), DatasetError> {
        let path = path.as_ref();
        let io = |source: std::io::Error| DatasetError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file_name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "dataset.csv".to_string());
        let tmp = path.with_file_name(format!(".{file_name}.{}.tmp", std::process::id()));
        let result = (|| {
            let file = std::fs::File::create(&tmp).map_err(io)?;
            let mut w = std::io::BufWriter::new(file);
            self.to_writer(&mut w)?;
            w.flush().map_err(io)?;
            w.get_ref().sync_all().map_err(io)?;
            Ok::<(), DatasetError>(())
        })();
        match result {
            Ok(()) => std::fs::rename(&tmp, path).map_err(io),
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                Err(e)
            }
        }
    }

    /// Writes the dataset as CSV to any writer, numbers in their shortest round-trip form (the
    /// one writer of `stiffness_core::table`).
    pub fn to_writer(&self, writer: impl Write) -> Result<(), DatasetError> {
        let mut header: Vec<String> = (1..=self.n_joints).map(|j| format!("q{j}")).collect();
        header.extend(WRENCH_COLUMNS.iter().map(|s| s.to_string()));
        header.extend(DISPLACEMENT_COLUMNS.iter().map(|s| s.to_string()));
        let mut columns = vec![
            Column::Floats {
                data: &self.q,
                width: self.n_joints,
            },
            Column::Floats {
                data: &self.wrench,
                width: 6,
            },
            Column::Floats {
                data: &self.displacement,
                width: 3,
            },
        ];
        if let Some(r) = &self.rotation {
            header.extend(ROTATION_COLUMNS.iter().map(|s| s.to_string()));
            columns.push(Column::Floats { data: r, width: 3 });
        }
        if let Some(p) = &self.pose {
            header.push("pose".into());
            columns.push(Column::Integers {
                data: p,
                width: 1,
                empty: None,
            });
        }
        let codes: Option<Vec<u8>> = self
            .set
            .as_ref()
            .map(|s| s.iter().map(|l| (*l == SetLabel::Test) as u8).collect());
        if let Some(codes) = &codes {
            header.push("set".into());
            columns.push(Column::Labels {
                codes,
                names: SET_LABELS,
            });
        }
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        Ok(write_csv(writer, &header, &columns, &Cancel::new())?)
    }

    /// Number of measurements (rows).
    pub fn len(&self) -> usize {
        self.displacement.len() / 3
    }

    /// Always false: a dataset has at least one row.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Actuated joints per configuration.
    pub fn n_joints(&self) -> usize {
        self.n_joints
    }

    /// The columns, owned: moved out when the dataset owns them (a file read), copied when it
    /// borrows the caller's arrays. What a binding hands over without a copy of 10⁶ rows.
    pub fn into_columns(self) -> DatasetColumns {
        DatasetColumns {
            n_joints: self.n_joints,
            q: self.q.into_owned(),
            wrench: self.wrench.into_owned(),
            displacement: self.displacement.into_owned(),
            rotation: self.rotation.map(Cow::into_owned),
            pose: self.pose.map(Cow::into_owned),
            set: self.set,
        }
    }

    /// Joint angles of row `i`, rad.
    pub fn q(&self, i: usize) -> &[f64] {
        &self.q[i * self.n_joints..(i + 1) * self.n_joints]
    }

    /// Recorded wrench of row `i`, `[fx, fy, fz, mx, my, mz]`, base frame, N and N·m.
    pub fn wrench(&self, i: usize) -> [f64; 6] {
        let w = &self.wrench[i * 6..i * 6 + 6];
        [w[0], w[1], w[2], w[3], w[4], w[5]]
    }

    /// Measured tip displacement of row `i`, base frame, m.
    pub fn displacement(&self, i: usize) -> [f64; 3] {
        let d = &self.displacement[i * 3..i * 3 + 3];
        [d[0], d[1], d[2]]
    }

    /// Measured tip rotation vector of row `i` (base frame, rad), when the file has one.
    pub fn rotation(&self, i: usize) -> Option<[f64; 3]> {
        self.rotation
            .as_ref()
            .map(|r| [r[i * 3], r[i * 3 + 1], r[i * 3 + 2]])
    }

    /// Pose id of row `i`, when the file has a `pose` column.
    pub fn pose(&self, i: usize) -> Option<i64> {
        self.pose.as_ref().map(|p| p[i])
    }

    /// Set label of row `i`, when the file has a `set` column.
    pub fn set(&self, i: usize) -> Option<SetLabel> {
        self.set.as_ref().map(|s| s[i])
    }

    /// All joint angles, row-major N×n.
    pub fn q_flat(&self) -> &[f64] {
        &self.q
    }

    /// All wrenches, row-major N×6.
    pub fn wrench_flat(&self) -> &[f64] {
        &self.wrench
    }

    /// All displacements, row-major N×3.
    pub fn displacement_flat(&self) -> &[f64] {
        &self.displacement
    }

    /// All rows as the view an identification reads (with the rotations when the table has
    /// them): `vjm::identify(&chain, &model, data.measurements(), &opts)`.
    pub fn measurements(&self) -> Measurements<'_> {
        Measurements::new(&self.q, &self.wrench, &self.displacement)
            .with_rotation(self.rotation.as_deref())
    }

    /// Pose group of every row: the `pose` column when present, otherwise rows with bitwise
    /// identical joint angles share a group. Groups are numbered 0.. in order of first appearance.
    pub fn pose_groups(&self) -> Vec<usize> {
        let mut ids: Vec<usize> = Vec::with_capacity(self.len());
        // A row of the same pose as the row before (a pose's loads are usually recorded one
        // after another) takes its group without a look-up.
        match &self.pose {
            Some(p) => {
                let mut map: BTreeMap<i64, usize> = BTreeMap::new();
                for (i, &id) in p.iter().enumerate() {
                    if i > 0 && p[i - 1] == id {
                        ids.push(ids[i - 1]);
                        continue;
                    }
                    let next = map.len();
                    ids.push(*map.entry(id).or_insert(next));
                }
            }
            None => {
                let mut map: BTreeMap<Vec<u64>, usize> = BTreeMap::new();
                let same =
                    |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                for i in 0..self.len() {
                    if i > 0 && same(self.q(i), self.q(i - 1)) {
                        ids.push(ids[i - 1]);
                        continue;
                    }
                    let key: Vec<u64> = self.q(i).iter().map(|v| v.to_bits()).collect();
                    let next = map.len();
                    ids.push(*map.entry(key).or_insert(next));
                }
            }
        }
        ids
    }

    /// The train/test label of every row. With a `set` column, that column. Without one, whole
    /// poses (see [`Dataset::pose_groups`]) are held out: `round(test_fraction · poses)` of them
    /// (at least one, and at least one left for training), chosen by a ChaCha8 shuffle seeded
    /// with `seed`, so the split is reproducible.
    pub fn split(&self, test_fraction: f64, seed: u64) -> Result<Vec<SetLabel>, DatasetError> {
        let labels = match &self.set {
            Some(s) => s.clone(),
            None => {
                let groups = self.pose_groups();
                let n_groups = groups.iter().copied().max().map_or(0, |m| m + 1);
                let mut order: Vec<usize> = (0..n_groups).collect();
                order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
                let frac = if test_fraction.is_finite() {
                    test_fraction.clamp(0.0, 1.0)
                } else {
                    0.25
                };
                let n_test = ((frac * n_groups as f64).round() as usize)
                    .max(1)
                    .min(n_groups.saturating_sub(1));
                let mut is_test = vec![false; n_groups];
                for &g in &order[..n_test] {
                    is_test[g] = true;
                }
                groups
                    .iter()
                    .map(|&g| {
                        if is_test[g] {
                            SetLabel::Test
                        } else {
                            SetLabel::Train
                        }
                    })
                    .collect()
            }
        };
        for which in [SetLabel::Train, SetLabel::Test] {
            if !labels.contains(&which) {
                return Err(DatasetError::EmptySplit { which });
            }
        }
        Ok(labels)
    }

    /// A copy with the given set labels (length must equal [`Dataset::len`]).
    pub fn with_set(mut self, set: Vec<SetLabel>) -> Result<Self, DatasetError> {
        if set.len() != self.len() {
            return Err(DatasetError::Shape {
                name: "set",
                found: set.len(),
                expected: self.len(),
                rows: self.len(),
                per_row: 1,
            });
        }
        self.set = Some(set);
        Ok(self)
    }
}

/// "no joint columns", "1 joint column", "7 joint columns".
fn joint_columns(found: usize) -> String {
    match found {
        0 => "no joint columns".to_string(),
        1 => "1 joint column".to_string(),
        n => format!("{n} joint columns"),
    }
}

/// Refuses data that carry no information at all: every wrench zero, or every displacement
/// zero (shared by the file reader and [`Dataset::new`]).
fn check_information(wrench: &[f64], displacement: &[f64]) -> Result<(), DatasetError> {
    let rows = displacement.len() / 3;
    // The largest |force| and |moment| component, in one pass over the rows.
    let (force, moment) = wrench.chunks_exact(6).fold((0.0f64, 0.0f64), |(f, m), w| {
        (
            f.max(w[0].abs()).max(w[1].abs()).max(w[2].abs()),
            m.max(w[3].abs()).max(w[4].abs()).max(w[5].abs()),
        )
    });
    if force == 0.0 && moment == 0.0 {
        return Err(DatasetError::NoLoad { rows });
    }
    if force < MIN_INFORMATIVE_FORCE && moment < MIN_INFORMATIVE_MOMENT {
        return Err(DatasetError::NegligibleLoad {
            rows,
            force,
            moment,
        });
    }
    if displacement.iter().all(|&v| v == 0.0) {
        return Err(DatasetError::NoDisplacement { rows });
    }
    Ok(())
}
