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
use stiffness_core::table::{write_csv, CellKind, Column, CsvReader, Layout, TableError};
use stiffness_core::Cancel;

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
        let reader = CsvReader::from_reader(source).map_err(table_error)?;
        let columns = ColumnMap::from_headers(reader.header())?;
        let mut layout = Layout::new();
        let named = |fields: &[usize], names: &[&str]| -> Vec<(usize, String)> {
            fields
                .iter()
                .zip(names)
                .map(|(&f, &n)| (f, n.to_string()))
                .collect()
        };
        let rotation = layout.group(CellKind::Float, named(&columns.rotation, &ROTATION_COLUMNS));
        let moment = layout.group(CellKind::Float, named(&columns.moment, &MOMENT_COLUMNS));
        let flag = layout.group(
            CellKind::Float,
            named(&[columns.reference], &[REFERENCE_COLUMN]),
        );
        // CSJM files are a few hundred rows: the whole file is one read, not cancellable.
        let mut table = reader.read(&layout, &Cancel::new()).map_err(table_error)?;
        let (rotation, moment, flag) = (
            table.take_floats(rotation),
            table.take_floats(moment),
            table.take_floats(flag),
        );

        let mut reference: Vec<CsjmMeasurement> = Vec::new();
        let mut measurements = Vec::new();
        for (index, &flag) in flag.iter().enumerate() {
            let row = index + 1;
            let line = table.line_of(index);
            let cells = Cells {
                rotation: &rotation[9 * index..9 * index + 9],
                moment: &moment[3 * index..3 * index + 3],
                flag,
            };
            let (measurement, is_reference) = parse_row(cells, row, line, options)?;
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

    /// Writes the dataset in the measurement-file format (numbers in their shortest
    /// round-trip form, so reading the file back gives the same values bit for bit).
    pub fn write_csv<W: std::io::Write>(&self, out: W) -> Result<(), IdentificationError> {
        let mut header: Vec<&str> = ROTATION_COLUMNS.to_vec();
        header.extend_from_slice(&MOMENT_COLUMNS);
        header.push(REFERENCE_COLUMN);
        let rows = std::iter::once((&self.reference, true))
            .chain(self.measurements.iter().map(|m| (m, false)));
        let n = 1 + self.measurements.len();
        let (mut rotation, mut moment, mut flag) = (
            Vec::with_capacity(9 * n),
            Vec::with_capacity(3 * n),
            Vec::with_capacity(n),
        );
        for (m, is_ref) in rows {
            let r = m.orientation.matrix();
            for i in 0..3 {
                rotation.extend((0..3).map(|j| r[(i, j)]));
            }
            moment.extend(m.moment.iter());
            flag.push(i64::from(is_ref));
        }
        let columns = [
            Column::Floats {
                data: &rotation,
                width: 9,
            },
            Column::Floats {
                data: &moment,
                width: 3,
            },
            Column::Integers {
                data: &flag,
                width: 1,
                empty: None,
            },
        ];
        write_csv(out, &header, &columns, &Cancel::new()).map_err(table_error)
    }
}

/// The table layer's error as this crate's: the same row and line, the column by its name.
fn table_error(e: TableError) -> IdentificationError {
    let static_name = |column: &str| {
        ROTATION_COLUMNS
            .iter()
            .chain(&MOMENT_COLUMNS)
            .chain(std::iter::once(&REFERENCE_COLUMN))
            .copied()
            .find(|c| *c == column)
    };
    match e {
        TableError::Io { path, source } => IdentificationError::Io {
            path: path.display().to_string(),
            source,
        },
        TableError::Parse {
            line,
            row,
            column,
            text,
            ..
        } => match static_name(&column) {
            Some(REFERENCE_COLUMN) => IdentificationError::BadReferenceFlag {
                row: row + 1,
                line,
                value: text,
            },
            Some(column) => IdentificationError::Parse {
                row: row + 1,
                line,
                column,
                value: text,
            },
            None => IdentificationError::Csv {
                line,
                message: format!("column '{column}': cannot parse '{text}' as a number"),
            },
        },
        TableError::Malformed { line, message } => IdentificationError::Csv { line, message },
        // An empty file lacks every column; name the first.
        TableError::NoHeader => IdentificationError::MissingColumn {
            column: ROTATION_COLUMNS[0],
        },
        other => IdentificationError::Csv {
            line: 0,
            message: other.to_string(),
        },
    }
}

/// Field index of every required column.
struct ColumnMap {
    rotation: [usize; 9],
    moment: [usize; 3],
    reference: usize,
}

impl ColumnMap {
    /// From the header's names (trimmed, byte-order mark removed by the reader); names are
    /// compared case-insensitively.
    fn from_headers(headers: &[String]) -> Result<Self, IdentificationError> {
        let names: Vec<String> = headers.iter().map(|h| h.to_ascii_lowercase()).collect();
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

/// One data row's cells as the table reader parsed them.
struct Cells<'a> {
    rotation: &'a [f64],
    moment: &'a [f64],
    flag: f64,
}

fn finite(
    value: f64,
    column: &'static str,
    row: usize,
    line: u64,
) -> Result<f64, IdentificationError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(IdentificationError::NonFinite {
            row,
            line,
            column,
            value,
        })
    }
}

fn parse_row(
    cells: Cells<'_>,
    row: usize,
    line: u64,
    options: &ReadOptions,
) -> Result<(CsjmMeasurement, bool), IdentificationError> {
    let mut entries = [0.0; 9];
    for ((slot, &value), name) in entries.iter_mut().zip(cells.rotation).zip(ROTATION_COLUMNS) {
        *slot = finite(value, name, row, line)?;
    }
    let mut moment = Vector3::zeros();
    for ((slot, &value), name) in moment.iter_mut().zip(cells.moment).zip(MOMENT_COLUMNS) {
        *slot = finite(value, name, row, line)?;
    }
    let is_reference = match cells.flag {
        v if v == 1.0 || v == 0.0 => v == 1.0,
        v => {
            return Err(IdentificationError::BadReferenceFlag {
                row,
                line,
                value: stiffness_core::num::Short(v).to_string(),
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
