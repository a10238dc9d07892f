//! The input of a prediction (and of a compensation): a CSV file of joint positions and,
//! optionally, the wrench on every row.
//!
//! Columns (header required, any order, case-insensitive): `q1..qn` (rad) and either all of
//! `fx,fy,fz,mx,my,mz` (N, N·m, at the tip point, base frame) or none of them (the load is then
//! given separately, e.g. as a payload), and optionally `pose` (integer pose ids, as in a
//! measurement file or a plan). Other columns (`dx`, `set`, …) are ignored, so a measurement
//! file — and a plan of `design` — is a valid pose table. Read by the one table reader
//! ([`stiffness_core::table::CsvReader`]: chunked, on every core); errors name the file, the
//! line (header = 1) and the column.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use stiffness_core::table::{CellKind, CsvReader, Layout, TableError};
use stiffness_core::Cancel;

use super::ModelError;
use crate::dataset::{is_joint_column, DatasetError};

const WRENCH: [&str; 6] = ["fx", "fy", "fz", "mx", "my", "mz"];

/// Joint positions and optional wrenches read from a pose table.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct PoseTable {
    /// Actuated joints n.
    pub n_joints: usize,
    /// N×n joint positions, rad, row-major.
    pub q: Vec<f64>,
    /// N×6 wrenches when the file has the `fx..mz` columns.
    pub wrench: Option<Vec<f64>>,
    /// N pose ids when the file has a `pose` column.
    pub pose: Option<Vec<i64>>,
}

impl PoseTable {
    /// Number of rows N.
    pub fn len(&self) -> usize {
        self.q.len() / self.n_joints.max(1)
    }
    /// Whether the table has no rows (never true for a table that was read).
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// Reads and validates `path` for a chain of `n_joints` joints. Errors name the file,
    /// the line (header = 1) and the column.
    pub fn read_csv(path: impl AsRef<Path>, n_joints: usize) -> Result<Self, ModelError> {
        Self::read_csv_cancellable(path, n_joints, &Cancel::new())
    }

    /// [`PoseTable::read_csv`], stopping with [`ModelError::Cancelled`] once `cancel` is set
    /// (polled once per chunk of the file).
    pub fn read_csv_cancellable(
        path: impl AsRef<Path>,
        n_joints: usize,
        cancel: &Cancel,
    ) -> Result<Self, ModelError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        let reader = CsvReader::open(path).map_err(|e| table_error(e, &shown, n_joints))?;
        read_table(reader, n_joints, cancel).map_err(|e| table_error(e, &shown, n_joints))
    }

    /// Reads a pose table from any reader (`<reader>` in messages).
    pub fn from_reader(reader: impl Read, n_joints: usize) -> Result<Self, ModelError> {
        let shown = "<reader>";
        let reader = CsvReader::from_reader(reader).map_err(|e| table_error(e, shown, n_joints))?;
        read_table(reader, n_joints, &Cancel::new()).map_err(|e| table_error(e, shown, n_joints))
    }
}

/// What can fail while reading, before the file's name is attached.
enum Failure {
    Table(TableError),
    Data(DatasetError),
    Missing(String),
}

impl From<TableError> for Failure {
    fn from(e: TableError) -> Self {
        Failure::Table(e)
    }
}

impl From<DatasetError> for Failure {
    fn from(e: DatasetError) -> Self {
        Failure::Data(e)
    }
}

fn table_error(e: impl Into<Failure>, shown: &str, n_joints: usize) -> ModelError {
    let table = |message: String| ModelError::Table {
        path: shown.to_string(),
        message,
    };
    match e.into() {
        Failure::Table(TableError::Io { source, .. }) => ModelError::Read {
            path: shown.to_string(),
            source,
        },
        Failure::Table(TableError::Cancelled) => ModelError::Cancelled,
        Failure::Table(TableError::NoHeader) => table(format!(
            "the file is empty: no header line (expected columns q1..q{n_joints} and, unless the \
             load is given separately, fx,fy,fz,mx,my,mz)"
        )),
        Failure::Table(other) => table(DatasetError::from(other).to_string()),
        Failure::Data(e) => table(e.to_string()),
        Failure::Missing(column) => table(format!(
            "missing column '{column}' (need q1..q{n_joints}, and fx,fy,fz,mx,my,mz unless the \
             load is given separately)"
        )),
    }
}

fn read_table<R: Read>(
    reader: CsvReader<R>,
    n_joints: usize,
    cancel: &Cancel,
) -> Result<PoseTable, Failure> {
    let mut index: BTreeMap<String, usize> = BTreeMap::new();
    for (k, h) in reader.header().iter().enumerate() {
        if index.insert(h.to_ascii_lowercase(), k).is_some() {
            return Err(DatasetError::DuplicateColumn {
                column: h.to_string(),
            }
            .into());
        }
    }
    let q_found = index.keys().filter(|c| is_joint_column(c)).count();
    if q_found != n_joints {
        return Err(DatasetError::JointCount {
            found: q_found,
            expected: n_joints,
        }
        .into());
    }
    let need = |c: String| match index.get(&c) {
        Some(&k) => Ok((k, c)),
        None => Err(Failure::Missing(c)),
    };
    let q_cols = (1..=n_joints)
        .map(|j| need(format!("q{j}")))
        .collect::<Result<Vec<_>, _>>()?;
    let w_cols = if WRENCH.iter().any(|c| index.contains_key(*c)) {
        Some(
            WRENCH
                .iter()
                .map(|c| need(c.to_string()))
                .collect::<Result<Vec<_>, _>>()?,
        )
    } else {
        None
    };
    let pose_col = index.get("pose").map(|&k| (k, "pose".to_string()));
    let mut layout = Layout::new();
    let q_g = layout.group(CellKind::Float, q_cols);
    let w_g = w_cols.map(|c| layout.group(CellKind::Float, c));
    let p_g = pose_col.map(|c| layout.group(CellKind::Integer, vec![c]));
    let mut table = reader.read(&layout, cancel)?;
    let q = table.take_floats(q_g);
    let wrench = w_g.map(|g| table.take_floats(g));
    let pose = p_g.map(|g| table.take_integers(g));
    if q.is_empty() {
        return Err(DatasetError::Empty.into());
    }
    // A measurement file's checks (finite, plausible for the unit): a pose in degrees or a
    // load in the wrong unit is refused here as in `identify`, at the file's line.
    crate::dataset::check_cells(n_joints, &q, wrench.as_deref(), None, None)
        .map_err(|e| e.at_file_lines(&table))?;
    Ok(PoseTable {
        n_joints,
        q,
        wrench,
        pose,
    })
}
