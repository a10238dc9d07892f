//! The VJM identification (regressor build + rank-revealing solve) on the bundled Panda,
//! N = 1e3 … 1e6 seeded measurements, extended (21 springs) and traditional (7) models.
//!
//! `streaming` is `identify` with its default reduction (`SolveMethod::Auto`: lane-wise normal
//! equations on rayon's pool, i.e. both cores; this design has κ ≈ 70 so they are kept);
//! `streaming_qr` forces the TSQR reduction; `identify_dense` (whole design + faer QR) is
//! measured up to N = 1e5 for reference. Throughput is in measurements. At N = 1e6
//! criterion's minimum of 10 samples keeps the bench short.
use std::time::Duration;
use vjm::Measurements;

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use robot_stiffness_benches::{VjmBatch, SEED};
use std::hint::black_box;
use vjm::{identify, identify_dense, IdentifyOptions, SerialChain, SolveMethod, VirtualJointModel};

const SIZES: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

fn bench_identify(c: &mut Criterion) {
    let chain = SerialChain::bundled();
    let n = chain.n_joints();
    let data = VjmBatch::generate(&chain, SIZES[3], SEED).expect("seeded data on the bundled arm");
    let opts = IdentifyOptions::default();
    let mut group = c.benchmark_group("vjm_identify");
    group.sampling_mode(SamplingMode::Flat);
    for &size in &SIZES {
        let batch = data.prefix(size);
        group.throughput(Throughput::Elements(size as u64));
        if size >= 100_000 {
            group.sample_size(10);
            group.measurement_time(Duration::from_secs(if size >= 1_000_000 { 8 } else { 4 }));
        } else {
            group.sample_size(30);
            group.measurement_time(Duration::from_secs(3));
        }
        for model in [
            VirtualJointModel::extended(n),
            VirtualJointModel::traditional(n),
        ] {
            let id = format!("{}_{}", model.name(), model.n_params());
            group.bench_with_input(
                BenchmarkId::new(format!("streaming/{id}"), size),
                &batch,
                |b, d| {
                    b.iter(|| {
                        black_box(
                            identify(
                                &chain,
                                &model,
                                Measurements::new(d.q, d.wrench, d.displacement),
                                &opts,
                            )
                            .expect("valid data"),
                        )
                    })
                },
            );
            let mut qr = opts;
            qr.method = SolveMethod::Qr;
            group.bench_with_input(
                BenchmarkId::new(format!("streaming_qr/{id}"), size),
                &batch,
                |b, d| {
                    b.iter(|| {
                        black_box(
                            identify(
                                &chain,
                                &model,
                                Measurements::new(d.q, d.wrench, d.displacement),
                                &qr,
                            )
                            .expect("valid data"),
                        )
                    })
                },
            );
            if size <= 100_000 {
                group.bench_with_input(
                    BenchmarkId::new(format!("dense/{id}"), size),
                    &batch,
                    |b, d| {
                        b.iter(|| {
                            black_box(
                                identify_dense(
                                    &chain,
                                    &model,
                                    Measurements::new(d.q, d.wrench, d.displacement),
                                    &opts,
                                )
                                .expect("valid data"),
                            )
                        })
                    },
                );
            }
        }
    }
    group.finish();
}

criterion_group!(benches, bench_identify);
criterion_main!(benches);
