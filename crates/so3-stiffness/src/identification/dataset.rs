//! The CSJM measurement file: one row per static equilibrium, strictly validated.
//!
//! Columns (header required, names case-insensitive, any order; extra columns are ignored):
//!
//! | column | meaning | unit |
//! |---|---|---|
//! | `r11,r12,r13,r21,r22,r23,r31,r32,r33` | platform orientation ᴮ_A R, row-major | — |
//! | `tx,ty,tz` | external moment on the platform about O, components in frame A | N·m |
//! | `ref` | 1 on exactly one row (the reference pose R₀ with pre-load τ₀), else 0 | — |
//!
//! Every problem is reported with its 1-based data row and file line; nothing is silently
//! dropped. Matrices are checked against SO(3): by default a matrix whose orthogonality error
//! ‖RᵀR − I‖_F exceeds [`DEFAULT_ORTHOGONALITY_TOL`] is an error, and accepted matrices are
//! replaced by their nearest rotation (so that `log` is exact); with
//! [`RotationPolicy::Project`] every matrix with det > 0 is projected and its error recorded.

use std::io::Read;
use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::error::IdentificationError;
use crate::so3;

/// Default tolerance on ‖RᵀR − I‖_F. Matrices printed with three decimals (as in the seed
/// paper's tables) have errors up to ≈ 2.2e-3; a dropped minus sign gives ≈ 0.5 or more.
pub const DEFAULT_ORTHOGONALITY_TOL: f64 = 5e-3;

/// Names of the nine orientation columns, row-major.
pub const ROTATION_COLUMNS: [&str; 9] = [
    "r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33",
];
/// Names of the three moment columns.
pub const MOMENT_COLUMNS: [&str; 3] = ["tx", "ty", "tz"];
/// Name of the reference flag column.
pub const REFERENCE_COLUMN: &str = "ref";

/// Minimum number of load increments (rows other than the reference) a file must hold:
/// K_D ≈ ΨΩ⁺ (seed eq. 49) needs Ω of rank 3.
pub const MIN_INCREMENTS: usize = 3;

/// What to do with an orientation that is not exactly a rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum RotationPolicy {
    /// Reject a matrix whose ‖RᵀR − I‖_F exceeds `tol`; accepted matrices are replaced by
    /// their nearest rotation.
    Reject {
        /// Tolerance on ‖RᵀR − I‖_F.
        tol: f64,
    },
    /// Project every matrix with det > 0 onto SO(3) (nearest rotation in the Frobenius norm).
    Project,
}

impl Default for RotationPolicy {
    fn default() -> Self {
        RotationPolicy::Reject {
            tol: DEFAULT_ORTHOGONALITY_TOL,
        }
    }
}

/// Options of the measurement-file reader.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub struct ReadOptions {
    /// How non-orthonormal orientation matrices are handled.
    pub rotation: RotationPolicy,
}

impl ReadOptions {
    /// Options that project every orientation onto SO(3) instead of rejecting it.
    pub fn projecting() -> Self {
        ReadOptions {
            rotation: RotationPolicy::Project,
        }
    }
}

/// One static equilibrium of the platform.
#[derive(Debug, Clone, PartialEq)]
pub struct CsjmMeasurement {
    /// Platform orientation ᴮ_A R (maps A-components to B-components).
    pub orientation: Rotation3<f64>,
    /// External moment on the platform about O, components in frame A, N·m.
    pub moment: Vector3<f64>,
    /// ‖RᵀR − I‖_F of the matrix as read (0 for programmatic data).
    pub orthogonality_error: f64,
    /// 1-based data row in the file (0 for programmatic data).
    pub row: usize,
}

impl CsjmMeasurement {
    /// A measurement built in code (row 0, no orthogonality error).
    pub fn new(orientation: Rotation3<f64>, moment: Vector3<f64>) -> Self {
        CsjmMeasurement {
            orientation,
            moment,
            orthogonality_error: 0.0,
            row: 0,
        }
    }
}

/// A validated measurement set: the reference (R₀, τ₀) and the loaded poses, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct CsjmDataset {
    reference: CsjmMeasurement,
    measurements: Vec<CsjmMeasurement>,
}

impl CsjmDataset {
    /// Builds a dataset from a reference and at least [`MIN_INCREMENTS`] loaded poses.
    ///
    /// Errors if there are too few poses or a moment is not finite.
    pub fn new(
        reference: CsjmMeasurement,
        measurements: Vec<CsjmMeasurement>,
    ) -> Result<Self, IdentificationError> {
        for m in std::iter::once(&reference).chain(measurements.iter()) {
            if !m.moment.iter().all(|x| x.is_finite()) {
                return Err(IdentificationError::NonFiniteInput {
                    what: "measurement moment",
                });
            }
            if !m.orientation.matrix().iter().all(|x| x.is_finite()) {
                return Err(IdentificationError::NonFiniteInput {
                    what: "measurement orientation",
                });
            }
        }
        if measurements.len() < MIN_INCREMENTS {
            return Err(IdentificationError::TooFewMeasurements {
                what: "measurement set",
                usable: measurements.len(),
                required: MIN_INCREMENTS,
            });
        }
        Ok(CsjmDataset {
            reference,
            measurements,
        })
    }

    /// Reads and validates a measurement file.
    pub fn from_csv_path(
        path: impl AsRef<Path>,
        options: &ReadOptions,
    ) -> Result<Self, IdentificationError> {
        let path = path.as_ref();
        let file = std::fs::File::open(path).map_err(|source| IdentificationError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_csv_reader(std::io::BufReader::new(file), options)
    }

    /// Reads and validates measurements from any CSV source (a file, a string's bytes, …).
    ///
    /// ```
    /// use so3_stiffness::identification::{CsjmDataset, ReadOptions};
    /// let csv = "r11,r12,r13,r21,r22,r23,r31,r32,r33,tx,ty,tz,ref\n\
    ///            1,0,0,0,1,0,0,0,1,0,0,0,1\n\
    ///            1,0,0,0,0.9998,-0.02,0,0.02,0.9998,0.6,0,0,0\n\
    ///            0.9998,0,0.02,0,1,0,-0.02,0,0.9998,0,0.6,0,0\n\
    ///            0.9998,-0.02,0,0.02,0.9998,0,0,0,1,0,0,0.6,0\n";
    /// let data = CsjmDataset::from_csv_reader(csv.as_bytes(), &ReadOptions::default()).unwrap();
    /// assert_eq!(data.measurements().len(), 3);
    /// ```
    pub fn from_csv_reader<R: Read>(
        source: R,
        options: &ReadOptions,
    ) -> Result<Self, IdentificationError> {
        if let RotationPolicy::Reject { tol } = options.rotation {
            if !(tol.is_finite() && tol >= 0.0) {
                return Err(IdentificationError::InvalidSetting {
                    field: "RotationPolicy::Reject tol",
                    message: format!(
                        "must be finite and ≥ 0, got {}",
                        stiffness_core::num::Short(tol)
                    ),
                });
            }
        }
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .flexible(false)
            .from_reader(source);
        let headers = reader.headers().map_err(csv_error)?.clone();
        let columns = ColumnMap::from_headers(&headers)?;

        let mut reference: Vec<CsjmMeasurement> = Vec::new();
        let mut measurements = Vec::new();
        for (index, record) in reader.records().enumerate() {
            let record = record.map_err(csv_error)?;
            let row = index + 1;
            let line = record.position().map_or(row as u64 + 1, |p| p.line());
            let (measurement, is_reference) = parse_row(&record, &columns, row, line, options)?;
            if is_reference {
                reference.push(measurement);
            } else {
                measurements.push(measurement);
            }
        }
        let reference = match reference.len() {
            0 => return Err(IdentificationError::MissingReference),
            1 => reference.remove(0),
            _ => {
                return Err(IdentificationError::MultipleReferences {
                    rows: reference.iter().map(|m| m.row).collect(),
                })
            }
        };
        if measurements.len() < MIN_INCREMENTS {
            return Err(IdentificationError::TooFewMeasurements {
                what: "measurement file (rows other than the reference)",
                usable: measurements.len(),
                required: MIN_INCREMENTS,
            });
        }
        Ok(CsjmDataset {
            reference,
            measurements,
        })
    }

    /// The reference measurement (R₀, τ₀).
    pub fn reference(&self) -> &CsjmMeasurement {
        &self.reference
    }

    /// The loaded measurements, in file order (the reference excluded).
    pub fn measurements(&self) -> &[CsjmMeasurement] {
        &self.measurements
    }

    /// Largest ‖RᵀR − I‖_F over all rows as read (0 for exact rotations).
    pub fn max_orthogonality_error(&self) -> f64 {
        std::iter::once(&self.reference)
            .chain(self.measurements.iter())
            .map(|m| m.orthogonality_error)
            .fold(0.0, f64::max)
    }

    /// Body-frame displacements Δζ_k = log(R₀ᵀ R_k) (rad, frame A at R₀) and load increments
    /// Δτ_k = τ_k − τ₀ (N·m, frame A), one per loaded measurement, in file order.
    pub fn increments(&self) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
        let r0_inv = self.reference.orientation.inverse();
        self.measurements
            .iter()
            .map(|m| {
                (
                    so3::log(&(r0_inv * m.orientation)),
                    m.moment - self.reference.moment,
                )
            })
            .unzip()
    }

    /// Writes the dataset in the measurement-file format (full round-trip precision).
    pub fn write_csv<W: std::io::Write>(&self, out: W) -> Result<(), IdentificationError> {
        let mut writer = csv::Writer::from_writer(out);
        let mut header: Vec<&str> = ROTATION_COLUMNS.to_vec();
        header.extend_from_slice(&MOMENT_COLUMNS);
        header.push(REFERENCE_COLUMN);
        writer.write_record(&header).map_err(csv_error)?;
        let rows = std::iter::once((&self.reference, true))
            .chain(self.measurements.iter().map(|m| (m, false)));
        for (m, is_ref) in rows {
            let r = m.orientation.matrix();
            let mut fields: Vec<String> = Vec::with_capacity(13);
            for i in 0..3 {
                for j in 0..3 {
                    fields.push(format!("{}", r[(i, j)]));
                }
            }
            fields.extend(m.moment.iter().map(|x| format!("{x}")));
            fields.push(if is_ref { "1".into() } else { "0".into() });
            writer.write_record(&fields).map_err(csv_error)?;
        }
        writer.flush().map_err(|source| IdentificationError::Io {
            path: "<writer>".into(),
            source,
        })?;
        Ok(())
    }
}

fn csv_error(e: csv::Error) -> IdentificationError {
    let line = e.position().map_or(0, |p| p.line());
    IdentificationError::Csv {
        line,
        message: e.to_string(),
    }
}

/// Field index of every required column.
struct ColumnMap {
    rotation: [usize; 9],
    moment: [usize; 3],
    reference: usize,
}

impl ColumnMap {
    fn from_headers(headers: &csv::StringRecord) -> Result<Self, IdentificationError> {
        let names: Vec<String> = headers
            .iter()
            // A UTF-8 byte-order mark (spreadsheet exports) must not hide the first name.
            .map(|h| h.trim_start_matches('\u{feff}').trim().to_ascii_lowercase())
            .collect();
        for (i, name) in names.iter().enumerate() {
            if !name.is_empty() && names[..i].contains(name) {
                return Err(IdentificationError::DuplicateColumn {
                    column: name.clone(),
                });
            }
        }
        let find = |column: &'static str| {
            names
                .iter()
                .position(|n| n == column)
                .ok_or(IdentificationError::MissingColumn { column })
        };
        let mut rotation = [0; 9];
        for (slot, name) in rotation.iter_mut().zip(ROTATION_COLUMNS) {
            *slot = find(name)?;
        }
        let mut moment = [0; 3];
        for (slot, name) in moment.iter_mut().zip(MOMENT_COLUMNS) {
            *slot = find(name)?;
        }
        Ok(ColumnMap {
            rotation,
            moment,
            reference: find(REFERENCE_COLUMN)?,
        })
    }
}

fn parse_field(
    record: &csv::StringRecord,
    index: usize,
    column: &'static str,
    row: usize,
    line: u64,
) -> Result<f64, IdentificationError> {
    let text = record.get(index).unwrap_or("");
    let value: f64 = text.parse().map_err(|_| IdentificationError::Parse {
        row,
        line,
        column,
        value: text.to_string(),
    })?;
    if !value.is_finite() {
        return Err(IdentificationError::NonFinite {
            row,
            line,
            column,
            value,
        });
    }
    Ok(value)
}

fn parse_row(
    record: &csv::StringRecord,
    columns: &ColumnMap,
    row: usize,
    line: u64,
    options: &ReadOptions,
) -> Result<(CsjmMeasurement, bool), IdentificationError> {
    let mut entries = [0.0; 9];
    for ((slot, &index), name) in entries
        .iter_mut()
        .zip(&columns.rotation)
        .zip(ROTATION_COLUMNS)
    {
        *slot = parse_field(record, index, name, row, line)?;
    }
    let mut moment = Vector3::zeros();
    for ((slot, &index), name) in moment.iter_mut().zip(&columns.moment).zip(MOMENT_COLUMNS) {
        *slot = parse_field(record, index, name, row, line)?;
    }
    let flag_text = record.get(columns.reference).unwrap_or("");
    let flag = flag_text.parse::<f64>().ok();
    let is_reference = match flag {
        Some(v) if v == 1.0 || v == 0.0 => v == 1.0,
        _ => {
            return Err(IdentificationError::BadReferenceFlag {
                row,
                line,
                value: flag_text.to_string(),
            })
        }
    };
    let matrix = Matrix3::from_row_slice(&entries);
    let orthogonality_error = so3::orthogonality_error(&matrix);
    if let RotationPolicy::Reject { tol } = options.rotation {
        if !(orthogonality_error <= tol) {
            return Err(IdentificationError::NotARotation {
                row,
                line,
                orthogonality_error,
                tol,
            });
        }
    }
    let det = matrix.determinant();
    if !(det > 0.0) {
        return Err(IdentificationError::Reflection { row, line, det });
    }
    let orientation = so3::project_to_rotation(&matrix)
        .map_err(|_| IdentificationError::Reflection { row, line, det })?;
    Ok((
        CsjmMeasurement {
            orientation,
            moment,
            orthogonality_error,
            row,
        },
        is_reference,
    ))
}
