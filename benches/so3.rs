//! SO(3) `exp` and `log`, per call, over a batch of seeded inputs.
//!
//! Each iteration maps a batch of [`BATCH`] inputs, so criterion's time per element (the
//! reported throughput) is the per-call cost without per-call timer overhead. Generic angles
//! and the small-angle / near-π branches are measured separately because they take different
//! code paths.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use robot_stiffness_benches::{rotation_vectors, rotations, SEED};
use so3_stiffness::so3;
use std::f64::consts::PI;
use std::hint::black_box;

const BATCH: usize = 1024;

fn bench_exp_log(c: &mut Criterion) {
    let mut group = c.benchmark_group("so3");
    group.throughput(Throughput::Elements(BATCH as u64));
    let cases = [
        ("generic", 0.1, PI - 0.1),
        ("small", 1e-6, 1e-2),
        ("near_pi", PI - 1e-3, PI - 1e-9),
    ];
    for (k, (name, lo, hi)) in cases.into_iter().enumerate() {
        let w = rotation_vectors(BATCH, lo, hi, SEED + k as u64);
        let r = rotations(BATCH, lo, hi, SEED + k as u64);
        group.bench_with_input(BenchmarkId::new("exp", name), &w, |b, w| {
            b.iter(|| {
                for wi in w {
                    black_box(so3::exp(black_box(wi)));
                }
            })
        });
        group.bench_with_input(BenchmarkId::new("log", name), &r, |b, r| {
            b.iter(|| {
                for ri in r {
                    black_box(so3::log(black_box(ri)));
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_exp_log);
criterion_main!(benches);
