//! The virtual-joint Jacobian of the bundled Panda, per configuration.
//!
//! `jacobian_in_place` over a batch of [`BATCH`] seeded configurations with one reusable
//! `Workspace` (the allocation-free path users call in loops): criterion's per-element time is
//! the cost of one 6×m Jacobian (forward kinematics of the 7 joints included). The
//! allocating `jacobian` is measured alongside, per call.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use robot_stiffness_benches::{VjmBatch, SEED};
use std::hint::black_box;
use vjm::{
    jacobian, jacobian_batch_in_place, jacobian_in_place, SerialChain, VirtualJointModel, Workspace,
};

const BATCH: usize = 1024;

fn bench_jacobian(c: &mut Criterion) {
    let chain = SerialChain::bundled();
    let n = chain.n_joints();
    let data = VjmBatch::generate(&chain, BATCH, SEED).expect("seeded data on the bundled arm");
    let mut group = c.benchmark_group("vjm_jacobian");
    for model in [
        VirtualJointModel::extended(n),
        VirtualJointModel::traditional(n),
    ] {
        let m = model.n_params();
        let label = format!("{}_{m}", model.name());
        let mut ws = Workspace::new(&chain, &model).expect("workspace for the bundled arm");
        let mut out = vec![0.0; 6 * m];
        group.throughput(Throughput::Elements(BATCH as u64));
        group.bench_function(BenchmarkId::new("in_place", &label), |b| {
            b.iter(|| {
                for qi in data.q.chunks_exact(n) {
                    jacobian_in_place(&chain, &model, black_box(qi), &mut ws, &mut out)
                        .expect("valid q");
                    black_box(&out);
                }
            })
        });
        let mut all = vec![0.0; BATCH * 6 * m];
        group.bench_function(BenchmarkId::new("batch_in_place", &label), |b| {
            b.iter(|| {
                jacobian_batch_in_place(&chain, &model, black_box(&data.q), &mut ws, &mut all)
                    .expect("valid q");
                black_box(&all);
            })
        });
        group.throughput(Throughput::Elements(1));
        let q0 = &data.q[..n];
        group.bench_function(BenchmarkId::new("allocating", &label), |b| {
            b.iter(|| black_box(jacobian(&chain, &model, black_box(q0)).expect("valid q")))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_jacobian);
criterion_main!(benches);
