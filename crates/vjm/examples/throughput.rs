//! Measures the batched Jacobian and the streaming identification on the bundled Panda.
//!
//! `cargo run --release -p vjm --example throughput -- [N]` (default N = 1 000 000).
//! Prints the wall-clock time per Jacobian (7 joints, 21 columns) and of `identify`
//! (build + solve, translational measurements) over N measurements on all rayon threads.

use std::time::Instant;
use vjm::Measurements;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::{
    identify, jacobian_batch_in_place, predict_deflection, IdentifyOptions, SerialChain,
    VirtualJointModel, Workspace,
};

/// CPU seconds (user + system) of this process from /proc/self/stat (Linux, 100 Hz ticks):
/// on a machine shared with other jobs, CPU time is the fair measure of the work done.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| {
        f.get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    // Fields 14 and 15 of stat; after the ")" they are at 11 and 12.
    (ticks(11) + ticks(12)) / 100.0
}

fn main() -> Result<(), vjm::VjmError> {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut q = Vec::with_capacity(7 * n);
    for _ in 0..n {
        for &(lo, hi) in chain.limits() {
            q.push(rng.random_range(lo..hi));
        }
    }
    let wrench: Vec<f64> = (0..6 * n)
        .map(|i| {
            if i % 6 < 3 {
                rng.random_range(-50.0..50.0)
            } else {
                rng.random_range(-5.0..5.0)
            }
        })
        .collect();
    let truth: Vec<f64> = (0..21).map(|k| 1e-6 * (1.0 + k as f64 * 0.1)).collect();
    let mut disp = Vec::with_capacity(3 * n);
    for i in 0..n {
        let mut f = [0.0; 6];
        f.copy_from_slice(&wrench[6 * i..6 * i + 6]);
        let d = predict_deflection(&chain, &model, &truth, &q[7 * i..7 * i + 7], &f, false)?;
        disp.extend(&d[..3]);
    }

    // Jacobians: one thread, batches of 1000 configurations into one buffer.
    let mut ws = Workspace::new(&chain, &model)?;
    let batch = 1000.min(n);
    let mut out = vec![0.0; batch * 6 * 21];
    let reps = (n / batch).max(1);
    let (mut best, mut best_cpu) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let (t, c) = (Instant::now(), cpu_seconds());
        for r in 0..reps {
            let off = (r * batch * 7) % (q.len() - batch * 7 + 1);
            jacobian_batch_in_place(&chain, &model, &q[off..off + batch * 7], &mut ws, &mut out)?;
        }
        let per = (reps * batch) as f64;
        best = best.min(t.elapsed().as_secs_f64() / per);
        best_cpu = best_cpu.min((cpu_seconds() - c) / per);
    }
    println!(
        "jacobian (7 joints, 21 columns, 1 thread, {} configurations per run): {:.1} ns wall, {:.1} ns CPU per configuration (best of 5)",
        reps * batch,
        best * 1e9,
        best_cpu * 1e9
    );

    let opts = IdentifyOptions::default();
    let (mut best, mut best_cpu, mut rank) = (f64::INFINITY, f64::INFINITY, 0);
    for _ in 0..5 {
        let (t, c) = (Instant::now(), cpu_seconds());
        let id = identify(&chain, &model, Measurements::new(&q, &wrench, &disp), &opts)?;
        best = best.min(t.elapsed().as_secs_f64());
        best_cpu = best_cpu.min(cpu_seconds() - c);
        rank = id.rank;
    }
    println!(
        "identify (streaming, N = {n}, 21 parameters, {} threads): {:.1} ms wall, {:.1} ms CPU summed over threads (best of 5), rank {rank}",
        rayon::current_num_threads(),
        best * 1e3,
        best_cpu * 1e3
    );
    Ok(())
}
