//! The table reader and writer of every command (`stiffness_core::table`) on 131 072 seeded
//! rows, on every core. Throughput is in rows.
//!
//! * `write/prediction_csv`: a 7-joint `PRED.csv` with the sag columns through `vjm`'s
//!   `PredictionTable` (33 columns, 27 numbers a row with full-precision values, the rotations
//!   empty as for a model without rotations), written to `io::sink`: the formatting alone.
//! * `read/measurements_csv`: that file's `q1..q7, fx..mz` and `dx..dz` (16 numbers a row
//!   of a 33-column file), read from memory: splitting and parsing alone.
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robot_stiffness_benches::SEED;
use stiffness_core::table::{CellKind, CsvReader, Layout};
use stiffness_core::Cancel;
use vjm::stiffness_model::{PredictionTable, SagColumns};

const ROWS: usize = 131_072;
const JOINTS: usize = 7;

fn bench_write(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let mut values = |n: usize, scale: f64, rotations: bool| -> Vec<f64> {
        (0..n)
            .map(|i| {
                // Rotations (the last three of each 6) empty, as for a model without them.
                if rotations && i % 6 >= 3 {
                    f64::NAN
                } else {
                    scale * rng.random_range(-1.0..1.0)
                }
            })
            .collect()
    };
    let q = values(ROWS * JOINTS, 3.0, false);
    let wrench = values(ROWS * 6, 50.0, false);
    let deflection = values(ROWS * 6, 1e-3, true);
    let stddev = values(ROWS * 6, 1e-5, true);
    let sag = values(ROWS * 6, 1e-3, true);
    let sag_stddev = values(ROWS * 6, 1e-5, true);
    let identified = vec![true; ROWS];
    let table = PredictionTable {
        n_joints: JOINTS,
        q: &q,
        wrench: &wrench,
        deflection: &deflection,
        stddev: &stddev,
        identified: &identified,
        sag: Some(SagColumns {
            deflection: &sag,
            stddev: &sag_stddev,
            identified: &identified,
        }),
    };
    let mut group = c.benchmark_group("table_io");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(4));
    group.throughput(Throughput::Elements(ROWS as u64));
    let cancel = Cancel::new();
    group.bench_function("write/prediction_csv", |b| {
        b.iter(|| black_box(table.write_csv(std::io::sink(), &cancel)))
    });
    let mut text = Vec::new();
    table
        .write_csv(&mut text, &cancel)
        .expect("writes to memory");
    let header: Vec<String> = table.header();
    let at = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .expect("a PRED.csv column")
    };
    let named = |names: &[&str]| names.iter().map(|n| (at(n), n.to_string())).collect();
    group.bench_function("read/measurements_csv", |b| {
        b.iter(|| {
            let mut layout = Layout::new();
            let q = layout.group(
                CellKind::Float,
                named(&["q1", "q2", "q3", "q4", "q5", "q6", "q7"]),
            );
            let w = layout.group(
                CellKind::Float,
                named(&["fx", "fy", "fz", "mx", "my", "mz"]),
            );
            let d = layout.group(CellKind::Float, named(&["dx", "dy", "dz"]));
            let reader = CsvReader::from_reader(text.as_slice()).expect("a header");
            let mut table = reader.read(&layout, &cancel).expect("a valid table");
            black_box((
                table.take_floats(q),
                table.take_floats(w),
                table.take_floats(d),
            ))
        })
    });
    group.finish();
}

criterion_group!(benches, bench_write);
criterion_main!(benches);
