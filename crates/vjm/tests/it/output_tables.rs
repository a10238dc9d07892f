//! The PRED/COMP output tables: read back by a naive independent parser (split on commas,
//! Rust's own `f64` parser), every value must come back bit for bit, non-finite values and
//! "no joint" as empty cells, and bad shapes or a cancelled token leave nothing written.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stiffness_core::table::TableError;
use stiffness_core::Cancel;
use vjm::stiffness_model::{
    status_from_name, CompensationTable, PredictionTable, SagColumns, COMPENSATION_COLUMNS,
    PREDICTION_COLUMNS, SAG_COLUMNS,
};
use vjm::CompensationStatus;

/// Values spanning the magnitudes a table holds (µm deflections, kN wrenches, rad), with a
/// sprinkling of NaN and ±∞ that must become empty cells.
fn values(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| match rng.random_range(0..20) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            3 => 0.0,
            _ => {
                let mag = 10f64.powf(rng.random_range(-12.0..4.0));
                if rng.random_bool(0.5) {
                    mag
                } else {
                    -mag
                }
            }
        })
        .collect()
}

fn cells(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

/// The value a cell must hold: empty for a non-finite value, else exactly `v`.
fn assert_cell(cell: &str, v: f64, what: &str) {
    if v.is_finite() {
        let got: f64 = cell
            .parse()
            .unwrap_or_else(|_| panic!("{what}: '{cell}' is not a number"));
        assert_eq!(got.to_bits(), v.to_bits(), "{what}: '{cell}' is not {v:e}");
    } else {
        assert_eq!(cell, "", "{what}: {v} must be an empty cell");
    }
}

fn bools(n: usize, seed: u64) -> Vec<bool> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| rng.random_bool(0.7)).collect()
}

#[test]
fn prediction_table_round_trips_every_value_and_names_its_columns() {
    let (n_rows, nj) = (257, 7);
    let q = values(n_rows * nj, 1);
    let wrench = values(n_rows * 6, 2);
    let deflection = values(n_rows * 6, 3);
    let stddev = values(n_rows * 6, 4);
    let identified = bools(n_rows, 5);
    let sag_d = values(n_rows * 6, 6);
    let sag_sd = values(n_rows * 6, 7);
    let sag_id = bools(n_rows, 8);
    for with_sag in [false, true] {
        let table = PredictionTable {
            n_joints: nj,
            q: &q,
            wrench: &wrench,
            deflection: &deflection,
            stddev: &stddev,
            identified: &identified,
            sag: with_sag.then_some(SagColumns {
                deflection: &sag_d,
                stddev: &sag_sd,
                identified: &sag_id,
            }),
        };
        let mut out = Vec::new();
        table.write_csv(&mut out, &Cancel::new()).unwrap();
        let (header, rows) = cells(std::str::from_utf8(&out).unwrap());
        let mut expected: Vec<String> = (1..=nj).map(|j| format!("q{j}")).collect();
        expected.extend(PREDICTION_COLUMNS.iter().map(|c| c.to_string()));
        if with_sag {
            expected.extend(SAG_COLUMNS.iter().map(|c| c.to_string()));
        }
        assert_eq!(header, expected);
        assert_eq!(rows.len(), n_rows);
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(row.len(), expected.len(), "row {i}");
            let groups: [(&[f64], usize); 4] =
                [(&q, nj), (&wrench, 6), (&deflection, 6), (&stddev, 6)];
            let mut c = 0;
            for (data, w) in groups {
                for k in 0..w {
                    assert_cell(&row[c], data[i * w + k], &format!("row {i}, {}", header[c]));
                    c += 1;
                }
            }
            assert_eq!(row[c], identified[i].to_string(), "row {i} identified");
            c += 1;
            if with_sag {
                // dx..dz of each 6-long row.
                for data in [&sag_d, &sag_sd] {
                    for k in 0..3 {
                        assert_cell(&row[c], data[i * 6 + k], &format!("row {i}, {}", header[c]));
                        c += 1;
                    }
                }
                assert_eq!(row[c], sag_id[i].to_string(), "row {i} sag_identified");
            }
        }
    }
}

#[test]
fn prediction_table_with_rows_that_disagree_writes_nothing() {
    let q = [0.1, 0.2, 0.3];
    let six = [0.0; 18];
    let short = [0.0; 12]; // 2 rows where the others have 3
    let identified = [true; 3];
    let table = PredictionTable {
        n_joints: 1,
        q: &q,
        wrench: &six,
        deflection: &short,
        stddev: &six,
        identified: &identified,
        sag: None,
    };
    let mut out = Vec::new();
    let err = table.write_csv(&mut out, &Cancel::new()).unwrap_err();
    assert!(matches!(err, TableError::Shape { .. }), "{err}");
    assert!(out.is_empty(), "{} bytes written", out.len());
}

#[test]
fn compensation_table_writes_one_based_limit_joints_and_status_names() {
    let statuses = [
        CompensationStatus::Converged,
        CompensationStatus::OutsideLimits,
        CompensationStatus::NearSingular,
        CompensationStatus::NotConverged,
        CompensationStatus::Unstable,
    ];
    let (n_rows, nj) = (statuses.len() * 3, 3);
    let q = values(n_rows * nj, 11);
    let q0 = values(n_rows * nj, 12);
    let per_row: Vec<Vec<f64>> = (0..5).map(|k| values(n_rows, 20 + k)).collect();
    let iterations: Vec<i64> = (0..n_rows as i64).map(|i| i % 9).collect();
    // -1: no joint outside its limits; k: the 0-based joint.
    let limit: Vec<i64> = (0..n_rows as i64).map(|i| i % 4 - 1).collect();
    let status: Vec<CompensationStatus> = (0..n_rows).map(|i| statuses[i % 5]).collect();
    let table = CompensationTable {
        n_joints: nj,
        q: &q,
        q_nominal: &q0,
        position_error: &per_row[0],
        rotation_error: &per_row[1],
        deflection: &per_row[2],
        rotation_deflection: &per_row[3],
        inverse_condition: &per_row[4],
        iterations: &iterations,
        limit_joint: &limit,
        status: &status,
    };
    let mut out = Vec::new();
    table.write_csv(&mut out, &Cancel::new()).unwrap();
    let (header, rows) = cells(std::str::from_utf8(&out).unwrap());
    let mut expected: Vec<String> = (1..=nj).map(|j| format!("q{j}")).collect();
    expected.extend((1..=nj).map(|j| format!("q{j}_nominal")));
    expected.extend(COMPENSATION_COLUMNS.iter().map(|c| c.to_string()));
    assert_eq!(header, expected);
    assert_eq!(rows.len(), n_rows);
    for (i, row) in rows.iter().enumerate() {
        for j in 0..nj {
            assert_cell(&row[j], q[i * nj + j], "q");
            assert_cell(&row[nj + j], q0[i * nj + j], "q_nominal");
        }
        for (k, col) in per_row.iter().enumerate() {
            assert_cell(&row[2 * nj + k], col[i], COMPENSATION_COLUMNS[k]);
        }
        assert_eq!(
            row[2 * nj + 5],
            iterations[i].to_string(),
            "row {i} iterations"
        );
        let want_limit = if limit[i] < 0 {
            String::new()
        } else {
            (limit[i] + 1).to_string()
        };
        assert_eq!(row[2 * nj + 6], want_limit, "row {i} limit_joint");
        assert_eq!(row[2 * nj + 7], status[i].as_str(), "row {i} status");
        assert_eq!(status_from_name(&row[2 * nj + 7]), Some(status[i]));
    }
    assert_eq!(status_from_name("Converged"), None, "names are lower-case");
    assert_eq!(status_from_name(""), None);
}

#[test]
fn a_cancelled_write_returns_cancelled() {
    let q = vec![0.5; 100_000];
    let six = vec![1.0; 600_000];
    let identified = vec![true; 100_000];
    let table = PredictionTable {
        n_joints: 1,
        q: &q,
        wrench: &six,
        deflection: &six,
        stddev: &six,
        identified: &identified,
        sag: None,
    };
    let cancel = Cancel::new();
    cancel.cancel();
    let err = table.write_csv(Vec::new(), &cancel).unwrap_err();
    assert!(matches!(err, TableError::Cancelled), "{err}");
}
