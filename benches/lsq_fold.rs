//! The streaming triangular factor (`TriangularAccumulator`, TSQR with compact-WY panels) on
//! 65 536 seeded rows of 22, 49, 59 and 86 columns: the widths of the identification, of the
//! diagnosis' within-pose factor and of its full compressed design. Throughput is in rows;
//! `2·p²` flops a row is the figure to compare with a matrix product's speed.
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robot_stiffness_benches::SEED;
use vjm::lsq::TriangularAccumulator;

const ROWS: usize = 65_536;
/// Rows are taken cyclically from a pool this size, as a pass builds them: in cache.
const POOL: usize = 4096;

fn bench_fold(c: &mut Criterion) {
    let mut group = c.benchmark_group("lsq_fold");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(3));
    group.throughput(Throughput::Elements(ROWS as u64));
    for p in [22usize, 49, 59, 86] {
        let mut rng = ChaCha8Rng::seed_from_u64(SEED);
        let pool: Vec<f64> = (0..POOL * p).map(|_| rng.random_range(-1.0..1.0)).collect();
        group.bench_with_input(BenchmarkId::new("push_rows", p), &p, |b, &p| {
            b.iter(|| {
                let mut acc = TriangularAccumulator::new(p);
                for r in 0..ROWS {
                    let q = r % POOL;
                    acc.push_row_unchecked(&pool[q * p..(q + 1) * p]);
                }
                black_box(acc.finish())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_fold);
criterion_main!(benches);
