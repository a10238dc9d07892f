//! CSJM (cable-driven spherical joint module) on the seed prototype: analytic stiffness
//! evaluation at a pose, the static equilibrium solve (Newton on SO(3)) under an external
//! moment, and the stiffness identification from a load sequence.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use nalgebra::{Rotation3, Vector3};
use rand::Rng;
use robot_stiffness_benches::{rng, rotations, SEED};
use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator, EquilibriumOptions};
use so3_stiffness::identification::{identify, CsjmDataset, CsjmMeasurement, FitOptions, FitOrder};
use std::hint::black_box;

/// The prototype with 60 N pretension and 4000 N/m cables at the identity pose.
fn prototype() -> CsjmSimulator {
    CsjmSimulator::with_pretension(
        CsjmGeometry::prototype(),
        [4000.0; 6],
        [60.0; 6],
        &Rotation3::identity(),
    )
    .expect("the prototype with 60 N pretension is valid")
}

/// `n` seeded external moments (N·m, frame A), each component uniform in ±`max`.
fn moments(n: usize, max: f64, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = rng(seed);
    (0..n)
        .map(|_| Vector3::from_fn(|_, _| rng.random_range(-max..max)))
        .collect()
}

/// A measurement set from the simulator: the unloaded reference and `n` loaded equilibria.
fn dataset(sim: &CsjmSimulator, n: usize, seed: u64) -> CsjmDataset {
    let opts = EquilibriumOptions::default();
    let reference = sim
        .equilibrium(&Vector3::zeros(), &opts)
        .expect("unloaded equilibrium");
    let loaded = moments(n, 0.5, seed)
        .iter()
        .map(|tau| {
            let eq = sim
                .equilibrium(tau, &opts)
                .expect("equilibrium under a small load");
            CsjmMeasurement::new(eq.pose, *tau)
        })
        .collect();
    CsjmDataset::new(
        CsjmMeasurement::new(reference.pose, Vector3::zeros()),
        loaded,
    )
    .expect("valid dataset")
}

fn bench_csjm(c: &mut Criterion) {
    let sim = prototype();
    let mut group = c.benchmark_group("csjm");

    const POSES: usize = 256;
    let poses = rotations(POSES, 0.0, 0.15, SEED);
    group.throughput(Throughput::Elements(POSES as u64));
    group.bench_function("stiffness", |b| {
        b.iter(|| {
            for p in &poses {
                black_box(
                    sim.stiffness(black_box(p))
                        .expect("taut cables near the identity"),
                );
            }
        })
    });

    const LOADS: usize = 64;
    let taus = moments(LOADS, 1.0, SEED + 1);
    let opts = EquilibriumOptions::default();
    group.throughput(Throughput::Elements(LOADS as u64));
    group.bench_function("equilibrium", |b| {
        b.iter(|| {
            for tau in &taus {
                black_box(
                    sim.equilibrium(black_box(tau), &opts)
                        .expect("equilibrium under ±1 N·m"),
                );
            }
        })
    });

    group.throughput(Throughput::Elements(1));
    for n in [20, 200] {
        let data = dataset(&sim, n, SEED + 2);
        for (name, order) in [
            ("first_order", FitOrder::First),
            ("second_order", FitOrder::Second),
        ] {
            let mut fit = FitOptions::with_order(order);
            fit.convergence_series = false;
            group.bench_with_input(
                BenchmarkId::new(format!("identify/{name}"), n),
                &data,
                |b, d| {
                    b.iter(|| black_box(identify(d, &fit).expect("well-conditioned load sequence")))
                },
            );
        }
        let with_series = FitOptions::default();
        group.bench_with_input(
            BenchmarkId::new("identify/first_order_with_det_series", n),
            &data,
            |b, d| {
                b.iter(|| {
                    black_box(identify(d, &with_series).expect("well-conditioned load sequence"))
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench_csjm);
criterion_main!(benches);
