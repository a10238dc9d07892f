//! The measurement-file reader: valid files, round trip, and every rejection path.

use nalgebra::{Matrix3, Vector3};
use so3_stiffness::identification::{
    CsjmDataset, CsjmMeasurement, IdentificationError, ReadOptions,
};
use so3_stiffness::so3;

use super::common::{random_vector, rng};

const HEADER: &str = "r11,r12,r13,r21,r22,r23,r31,r32,r33,tx,ty,tz,ref";

fn row(r: &Matrix3<f64>, t: [f64; 3], reference: bool) -> String {
    let e: Vec<String> = (0..3)
        .flat_map(|i| (0..3).map(move |j| format!("{}", r[(i, j)])))
        .collect();
    format!(
        "{},{},{},{},{}",
        e.join(","),
        t[0],
        t[1],
        t[2],
        u8::from(reference)
    )
}

/// A valid file: reference plus `n` loaded rows at distinct small rotations.
fn valid_rows(n: usize) -> Vec<String> {
    let mut g = rng(7);
    let r0 = so3::exp(&Vector3::new(0.1, -0.2, 0.05));
    let mut rows = vec![row(r0.matrix(), [-0.06, -3.08, 1.07], true)];
    for _ in 0..n {
        let r = r0 * so3::exp(&random_vector(&mut g, 0.05));
        rows.push(row(r.matrix(), [0.5, -2.0, 1.5], false));
    }
    rows
}

fn file(rows: &[String]) -> String {
    format!("{HEADER}\n{}\n", rows.join("\n"))
}

fn read(text: &str) -> Result<CsjmDataset, IdentificationError> {
    CsjmDataset::from_csv_reader(text.as_bytes(), &ReadOptions::default())
}

#[test]
fn valid_file_reads_reference_and_rows_in_order() {
    let mut rows = valid_rows(4);
    rows.swap(0, 2); // the reference need not be first
    let data = read(&file(&rows)).expect("valid file");
    assert_eq!(data.measurements().len(), 4);
    assert_eq!(data.reference().row, 3);
    assert_eq!(data.reference().moment, Vector3::new(-0.06, -3.08, 1.07));
    let loaded_rows: Vec<usize> = data.measurements().iter().map(|m| m.row).collect();
    assert_eq!(loaded_rows, vec![1, 2, 4, 5]);
}

#[test]
fn columns_in_any_order_with_extras_and_spaces() {
    let text = "note, ref ,tz,ty,tx,r33,r32,r31,r23,r22,r21,r13,r12,r11\n\
                a,1,3,2,1,1,0,0,0,1,0,0,0,1\n\
                b,0,0,0,0.5,0.9998,0.02,0,-0.02,0.9998,0,0,0,1\n\
                c,0,0,0.5,0,0.9998,0,-0.02,0,1,0,0.02,0,0.9998\n\
                d,0,0.5,0,0,1,0,0,0,0.9998,0.02,0,-0.02,0.9998\n";
    let data = read(text).expect("valid");
    assert_eq!(data.reference().moment, Vector3::new(1.0, 2.0, 3.0));
    // Row b: r23 = -0.02, r32 = 0.02 → rotation about +x.
    let (dz, dt) = data.increments();
    assert!(
        dz[0].x > 0.019 && dz[0].y.abs() < 1e-9 && dz[0].z.abs() < 1e-9,
        "{:?}",
        dz[0]
    );
    assert_eq!(dt[0], Vector3::new(-0.5, -2.0, -3.0));
}

#[test]
fn write_then_read_round_trips_exactly() {
    let mut g = rng(11);
    let r0 = so3::exp(&random_vector(&mut g, 1.0));
    let reference = CsjmMeasurement::new(r0, random_vector(&mut g, 3.0));
    let loaded = (0..6)
        .map(|_| {
            CsjmMeasurement::new(
                r0 * so3::exp(&random_vector(&mut g, 0.1)),
                random_vector(&mut g, 3.0),
            )
        })
        .collect();
    let data = CsjmDataset::new(reference, loaded).unwrap();
    let mut bytes = Vec::new();
    data.write_csv(&mut bytes).unwrap();
    let back = CsjmDataset::from_csv_reader(bytes.as_slice(), &ReadOptions::default()).unwrap();
    assert_eq!(back.measurements().len(), 6);
    for (a, b) in data.measurements().iter().zip(back.measurements()) {
        assert_eq!(a.moment, b.moment);
        assert!(so3::distance(&a.orientation, &b.orientation) < 1e-15);
    }
    let (dz_a, _) = data.increments();
    let (dz_b, _) = back.increments();
    for (a, b) in dz_a.iter().zip(&dz_b) {
        assert!((a - b).norm() < 1e-14);
    }
}

#[test]
fn non_rotation_reports_row_line_and_orthogonality_error() {
    let mut rows = valid_rows(4);
    // Data row 3 (line 4): r32 sign dropped, as in the seed's printed R₀.
    let r = Matrix3::new(
        0.992, -0.060, -0.111, 0.090, 0.952, 0.292, 0.088, 0.300, 0.950,
    );
    rows[2] = row(&r, [0.0, 0.0, 0.0], false);
    match read(&file(&rows)) {
        Err(IdentificationError::NotARotation {
            row,
            line,
            orthogonality_error,
            ..
        }) => {
            assert_eq!((row, line), (3, 4));
            let expected = (r.transpose() * r - Matrix3::identity()).norm();
            assert!((orthogonality_error - expected).abs() < 1e-12);
            assert!(orthogonality_error > 0.8 && orthogonality_error < 0.82);
        }
        other => panic!("expected NotARotation, got {other:?}"),
    }
    let message = read(&file(&rows)).unwrap_err().to_string();
    assert!(
        message.contains("data row 3")
            && message.contains("line 4")
            && message.contains("project=True"),
        "{message}"
    );

    // The explicit option projects it instead and records its error.
    let data =
        CsjmDataset::from_csv_reader(file(&rows).as_bytes(), &ReadOptions::projecting()).unwrap();
    let m = &data.measurements()[1];
    assert_eq!(m.row, 3);
    assert!(m.orthogonality_error > 0.8);
    assert!(so3::orthogonality_error(m.orientation.matrix()) < 1e-14);
    assert!(data.max_orthogonality_error() > 0.8);
}

#[test]
fn reflection_is_rejected_even_when_projecting() {
    let mut rows = valid_rows(4);
    rows[1] = row(
        &Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)),
        [0.0; 3],
        false,
    );
    for options in [ReadOptions::default(), ReadOptions::projecting()] {
        match CsjmDataset::from_csv_reader(file(&rows).as_bytes(), &options) {
            Err(IdentificationError::Reflection {
                row: 2,
                line: 3,
                det,
            }) => assert!((det + 1.0).abs() < 1e-12),
            other => panic!("expected Reflection at row 2, got {other:?}"),
        }
    }
}

#[test]
fn reference_row_must_be_unique() {
    let mut rows = valid_rows(4);
    // Clear the flag of the reference row.
    rows[0] = format!("{},0", rows[0].rsplit_once(',').unwrap().0);
    assert!(matches!(
        read(&file(&rows)),
        Err(IdentificationError::MissingReference)
    ));

    let mut rows = valid_rows(4);
    for i in [2, 4] {
        rows[i] = format!("{},1", rows[i].rsplit_once(',').unwrap().0);
    }
    match read(&file(&rows)) {
        Err(IdentificationError::MultipleReferences { rows }) => assert_eq!(rows, vec![1, 3, 5]),
        other => panic!("expected MultipleReferences, got {other:?}"),
    }
}

#[test]
fn reference_flag_must_be_zero_or_one() {
    let mut rows = valid_rows(4);
    rows[3] = format!("{},yes", rows[3].rsplit_once(',').unwrap().0);
    match read(&file(&rows)) {
        Err(IdentificationError::BadReferenceFlag {
            row: 4,
            line: 5,
            value,
        }) => assert_eq!(value, "yes"),
        other => panic!("expected BadReferenceFlag, got {other:?}"),
    }
}

/// Blank lines are skipped: a data row keeps its number (rows counted without them) and the
/// error names the line it is on in the file.
#[test]
fn blank_lines_shift_the_line_but_not_the_row() {
    let mut rows = valid_rows(4);
    rows[3] = format!("{},2", rows[3].rsplit_once(',').unwrap().0);
    rows.insert(1, String::new());
    rows.insert(1, "  ".to_string());
    match read(&file(&rows)) {
        Err(IdentificationError::BadReferenceFlag {
            row: 4,
            line: 7,
            value,
        }) => assert_eq!(value, "2"),
        other => panic!("expected BadReferenceFlag at row 4, line 7, got {other:?}"),
    }
}

#[test]
fn fewer_than_three_increments_is_an_error() {
    let rows = valid_rows(2);
    match read(&file(&rows)) {
        Err(IdentificationError::TooFewMeasurements {
            usable: 2,
            required: 3,
            ..
        }) => {}
        other => panic!("expected TooFewMeasurements, got {other:?}"),
    }
    assert!(read(&file(&valid_rows(3))).is_ok());
}

#[test]
fn non_finite_and_unparsable_values_name_row_and_column() {
    for (bad, is_parse) in [
        ("NaN", false),
        ("inf", false),
        ("-inf", false),
        ("1.2.3", true),
        ("", true),
    ] {
        let mut rows = valid_rows(4);
        let mut fields: Vec<String> = rows[2].split(',').map(String::from).collect();
        fields[10] = bad.to_string(); // ty
        rows[2] = fields.join(",");
        match (read(&file(&rows)), is_parse) {
            (
                Err(IdentificationError::NonFinite {
                    row: 3,
                    line: 4,
                    column: "ty",
                    ..
                }),
                false,
            ) => {}
            (
                Err(IdentificationError::Parse {
                    row: 3,
                    line: 4,
                    column: "ty",
                    value,
                }),
                true,
            ) => assert_eq!(value, bad),
            (other, _) => panic!("{bad:?}: unexpected {other:?}"),
        }
    }
}

#[test]
fn missing_and_duplicate_columns() {
    let rows = valid_rows(4);
    let text = file(&rows).replacen("tz", "tq", 1);
    assert!(matches!(
        read(&text),
        Err(IdentificationError::MissingColumn { column: "tz" })
    ));
    let text = file(&rows).replacen("r31", "r11", 1);
    match read(&text) {
        Err(IdentificationError::DuplicateColumn { column }) => assert_eq!(column, "r11"),
        other => panic!("expected DuplicateColumn, got {other:?}"),
    }
}

#[test]
fn ragged_row_is_a_csv_error_with_its_line() {
    let mut rows = valid_rows(4);
    rows[3].push_str(",7");
    match read(&file(&rows)) {
        Err(IdentificationError::Csv { line: 5, .. }) => {}
        other => panic!("expected Csv error at line 5, got {other:?}"),
    }
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let err =
        CsjmDataset::from_csv_path("/nonexistent/csjm.csv", &ReadOptions::default()).unwrap_err();
    assert!(matches!(err, IdentificationError::Io { .. }));
    assert!(err.to_string().contains("/nonexistent/csjm.csv"));
}

#[test]
fn byte_order_mark_and_bad_tolerance() {
    let text = format!("\u{feff}{}", file(&valid_rows(3)));
    assert_eq!(read(&text).unwrap().measurements().len(), 3);
    let mut options = ReadOptions::default();
    options.rotation = so3_stiffness::identification::RotationPolicy::Reject { tol: f64::NAN };
    assert!(matches!(
        CsjmDataset::from_csv_reader(file(&valid_rows(3)).as_bytes(), &options),
        Err(IdentificationError::InvalidSetting { .. })
    ));
}

/// Mangled files (random fields replaced, removed, duplicated; random bytes) never panic and
/// never yield a dataset that violates the invariants.
#[test]
fn mangled_files_error_cleanly() {
    use rand::Rng;
    let mut g = rng(99);
    let pieces = [
        "", "nan", "1e309", "-", "1,2", "\"", "0x10", "é", "1", "0", "-0.0", " 2 ", "\u{feff}",
    ];
    for _ in 0..500 {
        let mut rows = valid_rows(4);
        for _ in 0..g.random_range(1..4) {
            let r = g.random_range(0..rows.len());
            let mut fields: Vec<String> = rows[r].split(',').map(String::from).collect();
            let f = g.random_range(0..fields.len());
            match g.random_range(0..4) {
                0 => fields[f] = pieces[g.random_range(0..pieces.len())].to_string(),
                1 => {
                    fields.remove(f);
                }
                2 => fields.insert(f, "0".into()),
                _ => fields[f] = format!("{}", g.random_range(-2.0..2.0)),
            }
            rows[r] = fields.join(",");
        }
        let mut text = file(&rows);
        if g.random_range(0..10) == 0 {
            let cut = g.random_range(0..text.len());
            text = String::from_utf8_lossy(&text.as_bytes()[..cut]).into_owned();
        }
        if let Ok(data) = read(&text) {
            assert!(data.measurements().len() >= 3);
            assert!(data
                .measurements()
                .iter()
                .all(|m| m.moment.iter().all(|x| x.is_finite())));
            assert!(data.max_orthogonality_error() <= 5e-3);
        }
    }
}
