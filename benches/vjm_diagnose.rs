//! `vjm::diagnose::diagnose` at campaign scale on the bundled Panda, next to `identify`
//! (traditional model) on the same rows, so the ratio diagnose/identify comes from one run.
//!
//! Campaigns are seeded testbed simulations (`vjm::testbed::simulate`, nominal truth, instrument
//! noise, 10 loads per pose, a quarter of the poses held out) with N = 1e4 and 1e5 rows; N = 1e6
//! is added when `BENCH_LARGE=1` (about 20 s of simulation and several seconds per diagnosis).
//! `per_row: false`, as a large CLI run does. Throughput is in rows.
//!
//! `cargo bench -p robot-stiffness-benches --bench vjm_diagnose`
use std::hint::black_box;
use std::time::Duration;
use vjm::Measurements;

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use vjm::diagnose::{diagnose, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, TrueModel};
use vjm::{identify, IdentifyOptions, SerialChain, VirtualJointModel};

/// Seed of the simulated campaigns (geometry and noise streams).
const CAMPAIGN_SEED: u64 = 0x5eed_d1a9;
/// Loads per pose, as in the measurements.
const WRENCHES_PER_POSE: usize = 10;

fn sizes() -> Vec<usize> {
    let large = std::env::var("BENCH_LARGE").is_ok_and(|v| v == "1");
    let mut s = vec![10_000, 100_000];
    if large {
        s.push(1_000_000);
    }
    s
}

fn bench_diagnose(c: &mut Criterion) {
    let chain = SerialChain::bundled();
    let n = chain.n_joints();
    let truth = TrueModel::nominal(n);
    let model = VirtualJointModel::traditional(n);
    let diag_opts = DiagnoseOptions {
        per_row: false,
        ..Default::default()
    };
    let id_opts = IdentifyOptions::default();
    let mut group = c.benchmark_group("vjm_diagnose");
    group.sampling_mode(SamplingMode::Flat);
    for size in sizes() {
        let spec = CampaignSpec {
            n_poses: size / WRENCHES_PER_POSE,
            wrenches_per_pose: WRENCHES_PER_POSE,
            seed: CAMPAIGN_SEED,
            ..Default::default()
        };
        let data = simulate(&chain, &truth, &spec)
            .expect("seeded campaign on the bundled arm")
            .dataset;
        group.throughput(Throughput::Elements(size as u64));
        group.sample_size(10);
        group.measurement_time(Duration::from_secs(match size {
            s if s >= 1_000_000 => 60,
            s if s >= 100_000 => 15,
            _ => 5,
        }));
        group.bench_with_input(BenchmarkId::new("diagnose", size), &data, |b, d| {
            b.iter(|| black_box(diagnose(&chain, d, &diag_opts).expect("valid campaign")))
        });
        group.bench_with_input(
            BenchmarkId::new("identify/traditional_7", size),
            &data,
            |b, d| {
                b.iter(|| {
                    black_box(
                        identify(
                            &chain,
                            &model,
                            Measurements::new(d.q_flat(), d.wrench_flat(), d.displacement_flat()),
                            &id_opts,
                        )
                        .expect("valid campaign"),
                    )
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench_diagnose);
criterion_main!(benches);
