//! The output tables of a prediction (the CLI's `PRED.csv`) and of a compensation
//! (`COMP.csv`): their columns in one place, written by the one CSV writer of
//! [`stiffness_core::table`] (shortest round-trip numbers, formatted on every core).
//!
//! A cell whose value is not finite is empty (a rotation the model does not predict, the
//! standard deviation of a row that is not identified, the numbers of an `unstable` row);
//! `limit_joint` is the 1-based joint, empty when no joint leaves its limits.
//!
//! ```
//! use vjm::stiffness_model::PredictionTable;
//! let table = PredictionTable {
//!     n_joints: 1,
//!     q: &[0.5],
//!     wrench: &[10.0, 0.0, 0.0, 0.0, 0.0, 0.0],
//!     deflection: &[1e-4, 0.0, 0.0, f64::NAN, f64::NAN, f64::NAN],
//!     stddev: &[2e-6, 0.0, 0.0, f64::NAN, f64::NAN, f64::NAN],
//!     identified: &[true],
//!     sag: None,
//! };
//! let mut out = Vec::new();
//! table.write_csv(&mut out, &Default::default())?;
//! let text = String::from_utf8(out).unwrap();
//! let mut lines = text.lines();
//! assert_eq!(lines.next(), Some(table.header().join(",").as_str()));
//! assert_eq!(lines.next(), Some("0.5,10.0,0.0,0.0,0.0,0.0,0.0,0.0001,0.0,0.0,,,,2e-6,0.0,0.0,,,,true"));
//! # Ok::<(), stiffness_core::table::TableError>(())
//! ```

use std::io::Write;

use stiffness_core::table::{write_csv, Column, TableError};
use stiffness_core::Cancel;

use crate::compensate::CompensationStatus;

/// The columns of `PRED.csv` after `q1..qn`: the wrench used, the deflection, its standard
/// deviations and whether the row is identified.
pub const PREDICTION_COLUMNS: [&str; 19] = [
    "fx",
    "fy",
    "fz",
    "mx",
    "my",
    "mz",
    "dx",
    "dy",
    "dz",
    "rx",
    "ry",
    "rz",
    "sdx",
    "sdy",
    "sdz",
    "srx",
    "sry",
    "srz",
    "identified",
];

/// The sag columns of `PRED.csv` (a prediction under gravity).
pub const SAG_COLUMNS: [&str; 7] = [
    "sag_dx",
    "sag_dy",
    "sag_dz",
    "sag_sd_dx",
    "sag_sd_dy",
    "sag_sd_dz",
    "sag_identified",
];

/// The columns of `COMP.csv` after `q1..qn` (corrected) and `q1_nominal..qn_nominal`.
pub const COMPENSATION_COLUMNS: [&str; 8] = [
    "position_error",
    "rotation_error",
    "deflection",
    "rotation_deflection",
    "inverse_condition",
    "iterations",
    "limit_joint",
    "status",
];

/// Every compensation status, in the order of the label codes written.
const STATUSES: [CompensationStatus; 5] = [
    CompensationStatus::Converged,
    CompensationStatus::OutsideLimits,
    CompensationStatus::NearSingular,
    CompensationStatus::NotConverged,
    CompensationStatus::Unstable,
];

/// The status written as `name` in `COMP.csv` (`converged`, `outside_limits`, …), if any.
pub fn status_from_name(name: &str) -> Option<CompensationStatus> {
    STATUSES.into_iter().find(|s| s.as_str() == name)
}

/// The index of `status` in [`STATUSES`]; exhaustive, so that a new status cannot be written
/// under another's name.
fn status_code(status: CompensationStatus) -> u8 {
    match status {
        CompensationStatus::Converged => 0,
        CompensationStatus::OutsideLimits => 1,
        CompensationStatus::NearSingular => 2,
        CompensationStatus::NotConverged => 3,
        CompensationStatus::Unstable => 4,
    }
}

fn joint_names(n_joints: usize, suffix: &str) -> impl Iterator<Item = String> + '_ {
    (1..=n_joints).map(move |j| format!("q{j}{suffix}"))
}

/// The sag under the arm's own weight of every row of a [`PredictionTable`]: the arrays of
/// `StiffnessModel::predict_sag`, N rows, row-major, of which the position part is written.
#[derive(Debug, Clone, Copy)]
pub struct SagColumns<'a> {
    /// N×6 sag `[dx, dy, dz, rx, ry, rz]`, m and rad, base frame; `dx..dz` are written.
    pub deflection: &'a [f64],
    /// N×6 standard deviations of the sag; those of `dx..dz` are written.
    pub stddev: &'a [f64],
    /// Whether the load the weight puts on the springs is identified, per row.
    pub identified: &'a [bool],
}

/// The columns of a prediction table (`PRED.csv`), N rows, row-major.
#[derive(Debug, Clone, Copy)]
pub struct PredictionTable<'a> {
    /// Actuated joints n.
    pub n_joints: usize,
    /// N×n joint positions, rad.
    pub q: &'a [f64],
    /// N×6 wrench used `[fx, fy, fz, mx, my, mz]`, N and N·m at the tip point, base frame.
    pub wrench: &'a [f64],
    /// N×6 predicted deflection `[dx, dy, dz, rx, ry, rz]`, m and rad, base frame.
    pub deflection: &'a [f64],
    /// N×6 standard deviations of the deflection.
    pub stddev: &'a [f64],
    /// Whether the row lies in the identified space.
    pub identified: &'a [bool],
    /// The sag columns, written after the others when given.
    pub sag: Option<SagColumns<'a>>,
}

impl PredictionTable<'_> {
    /// The column names: `q1..qn`, [`PREDICTION_COLUMNS`], then [`SAG_COLUMNS`] with a sag.
    pub fn header(&self) -> Vec<String> {
        let mut header: Vec<String> = joint_names(self.n_joints, "").collect();
        header.extend(PREDICTION_COLUMNS.iter().map(|c| c.to_string()));
        if self.sag.is_some() {
            header.extend(SAG_COLUMNS.iter().map(|c| c.to_string()));
        }
        header
    }

    /// Writes the table as CSV to `out`; polls `cancel` once per window of rows. Errors
    /// before writing anything when the arrays do not have the same number of rows.
    pub fn write_csv(&self, out: impl Write, cancel: &Cancel) -> Result<(), TableError> {
        let mut columns = vec![
            Column::Floats {
                data: self.q,
                width: self.n_joints,
            },
            Column::Floats {
                data: self.wrench,
                width: 6,
            },
            Column::Floats {
                data: self.deflection,
                width: 6,
            },
            Column::Floats {
                data: self.stddev,
                width: 6,
            },
            Column::Bools(self.identified),
        ];
        if let Some(sag) = &self.sag {
            columns.extend([
                Column::FloatsStrided {
                    data: sag.deflection,
                    width: 3,
                    stride: 6,
                },
                Column::FloatsStrided {
                    data: sag.stddev,
                    width: 3,
                    stride: 6,
                },
                Column::Bools(sag.identified),
            ]);
        }
        let header = self.header();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        write_csv(out, &header, &columns, cancel)
    }
}

/// The columns of a compensation table (`COMP.csv`), N rows, row-major.
#[derive(Debug, Clone, Copy)]
pub struct CompensationTable<'a> {
    /// Actuated joints n.
    pub n_joints: usize,
    /// N×n corrected joint targets, rad.
    pub q: &'a [f64],
    /// N×n nominal joint targets (the input), rad.
    pub q_nominal: &'a [f64],
    /// Predicted remaining position error, m.
    pub position_error: &'a [f64],
    /// Predicted remaining orientation error, rad.
    pub rotation_error: &'a [f64],
    /// Predicted deflection without compensation, m.
    pub deflection: &'a [f64],
    /// Predicted rotation without compensation, rad.
    pub rotation_deflection: &'a [f64],
    /// Inverse condition number of the task Jacobian at the corrected targets.
    pub inverse_condition: &'a [f64],
    /// Gauss–Newton steps.
    pub iterations: &'a [i64],
    /// First joint outside its limits, 0-based; negative when none (written 1-based or empty).
    pub limit_joint: &'a [i64],
    /// Outcome per row.
    pub status: &'a [CompensationStatus],
}

impl CompensationTable<'_> {
    /// The column names: `q1..qn`, `q1_nominal..qn_nominal`, then [`COMPENSATION_COLUMNS`].
    pub fn header(&self) -> Vec<String> {
        let mut header: Vec<String> = joint_names(self.n_joints, "").collect();
        header.extend(joint_names(self.n_joints, "_nominal"));
        header.extend(COMPENSATION_COLUMNS.iter().map(|c| c.to_string()));
        header
    }

    /// Writes the table as CSV to `out`; polls `cancel` once per window of rows. Errors
    /// before writing anything when the arrays do not have the same number of rows.
    pub fn write_csv(&self, out: impl Write, cancel: &Cancel) -> Result<(), TableError> {
        // 1-based as the columns q1..qn are named; 0 (no joint) is written as an empty cell.
        let limit: Vec<i64> = self
            .limit_joint
            .iter()
            .map(|&j| if j < 0 { 0 } else { j + 1 })
            .collect();
        let codes: Vec<u8> = self.status.iter().map(|&s| status_code(s)).collect();
        let names = STATUSES.map(CompensationStatus::as_str);
        let one = |data| Column::Floats { data, width: 1 };
        let columns = [
            Column::Floats {
                data: self.q,
                width: self.n_joints,
            },
            Column::Floats {
                data: self.q_nominal,
                width: self.n_joints,
            },
            one(self.position_error),
            one(self.rotation_error),
            one(self.deflection),
            one(self.rotation_deflection),
            one(self.inverse_condition),
            Column::Integers {
                data: self.iterations,
                width: 1,
                empty: None,
            },
            Column::Integers {
                data: &limit,
                width: 1,
                empty: Some(0),
            },
            Column::Labels {
                codes: &codes,
                names: &names,
            },
        ];
        let header = self.header();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        write_csv(out, &header, &columns, cancel)
    }
}
