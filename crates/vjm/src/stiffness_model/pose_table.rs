//! The input of a prediction (and of a compensation): a CSV file of joint positions and,
//! optionally, the wrench on every row.
//!
//! Columns (header required, any order, case-insensitive): `q1..qn` (rad) and either all of
//! `fx,fy,fz,mx,my,mz` (N, N·m, at the tip point, base frame) or none of them (the load is then
//! given separately, e.g. as a payload). Other columns (`dx`, `pose`, `set`, …) are ignored,
//! so a measurement file is a valid pose table.

use std::collections::BTreeMap;
use std::path::Path;

use super::ModelError;
use crate::dataset::DatasetError;

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
        let path = path.as_ref();
        let shown = path.display().to_string();
        let bad = |e: DatasetError| ModelError::Table {
            path: shown.clone(),
            message: e.to_string(),
        };
        let file = std::fs::File::open(path).map_err(|source| ModelError::Read {
            path: shown.clone(),
            source,
        })?;
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .from_reader(std::io::BufReader::new(file));
        let csv_err = |e: csv::Error| {
            bad(DatasetError::Csv {
                line: e.position().map(|p| p.line()).unwrap_or(0),
                message: e.to_string(),
            })
        };
        let headers = rdr.headers().map_err(csv_err)?.clone();
        let mut index: BTreeMap<String, usize> = BTreeMap::new();
        for (k, h) in headers.iter().enumerate() {
            if index.insert(h.to_ascii_lowercase(), k).is_some() {
                return Err(bad(DatasetError::DuplicateColumn {
                    column: h.to_string(),
                }));
            }
        }
        let q_found = index
            .keys()
            .filter(|c| {
                c.len() > 1
                    && c.starts_with('q')
                    && c[1..].bytes().all(|b| b.is_ascii_digit())
                    && !c[1..].starts_with('0')
            })
            .count();
        if q_found != n_joints {
            return Err(bad(DatasetError::JointCount {
                found: q_found,
                expected: n_joints,
            }));
        }
        let missing = |column: String| {
            ModelError::Table {
            path: shown.clone(),
            message: format!("missing column '{column}' (need q1..q{n_joints}, and fx,fy,fz,mx,my,mz unless the load is given separately)"),
        }
        };
        let q_idx = (1..=n_joints)
            .map(|j| {
                let c = format!("q{j}");
                index.get(&c).copied().ok_or_else(|| missing(c))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let present: Vec<&str> = WRENCH
            .iter()
            .copied()
            .filter(|c| index.contains_key(*c))
            .collect();
        let w_idx = if present.is_empty() {
            None
        } else {
            Some(
                WRENCH
                    .iter()
                    .map(|c| index.get(*c).copied().ok_or_else(|| missing(c.to_string())))
                    .collect::<Result<Vec<_>, _>>()?,
            )
        };
        let mut q = Vec::new();
        let mut wrench = w_idx.as_ref().map(|_| Vec::new());
        let mut record = csv::StringRecord::new();
        loop {
            match rdr.read_record(&mut record) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return Err(csv_err(e)),
            }
            let line = record.position().map(|p| p.line()).unwrap_or(0);
            let num = |k: usize, column: &str| -> Result<f64, ModelError> {
                let text = record.get(k).unwrap_or("");
                let v: f64 = text.parse().map_err(|_| {
                    bad(DatasetError::Parse {
                        line,
                        column: column.to_string(),
                        text: text.to_string(),
                        expected: "a number",
                    })
                })?;
                // A measurement file's checks (finite, plausible for the unit): a pose in
                // degrees or a load in the wrong unit is refused here as in `identify`.
                crate::dataset::check_value(line, column, v).map_err(bad)?;
                Ok(v)
            };
            for (j, &k) in q_idx.iter().enumerate() {
                q.push(num(k, &format!("q{}", j + 1))?);
            }
            if let (Some(idx), Some(w)) = (&w_idx, wrench.as_mut()) {
                for (c, &k) in WRENCH.iter().zip(idx) {
                    w.push(num(k, c)?);
                }
            }
        }
        if q.is_empty() {
            return Err(bad(DatasetError::Empty));
        }
        Ok(PoseTable {
            n_joints,
            q,
            wrench,
        })
    }
}
