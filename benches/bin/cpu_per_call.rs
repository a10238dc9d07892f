//! `cpu-per-call`: CPU time per call of the hot functions, next to wall time.
//!
//! criterion (the `benches/*.rs` targets) measures wall time, which grows when other
//! processes share the cores. This binary runs a fixed number of calls of each function on
//! the same seeded inputs as the benches and divides the process CPU time (all threads,
//! [`process_cpu_seconds`]) by the number of calls: on a busy machine that is the better
//! estimate of what the function costs on an idle one (cache pollution by the other
//! processes still counts against it). For `identify`, which runs on both cores, the CPU time
//! is the sum over the threads.
//!
//! ```text
//! cpu-per-call [--seconds S]    # each function for at least S seconds of CPU (default 2)
//! ```
use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;
use vjm::Measurements;

use robot_stiffness_benches::{process_cpu_seconds, rotation_vectors, rotations, VjmBatch, SEED};
use so3_stiffness::so3;
use vjm::{
    identify, jacobian_in_place, IdentifyOptions, SerialChain, VirtualJointModel, Workspace,
};

/// Repeats `batch` (which makes `calls_per_batch` calls) until `seconds` of CPU time have
/// passed; prints CPU and wall time per call.
fn measure(
    name: &str,
    seconds: f64,
    calls_per_batch: usize,
    mut batch: impl FnMut(),
) -> Result<(), String> {
    batch(); // warm-up: caches, lazy thread pools
    let cpu0 = process_cpu_seconds().ok_or("/proc/self/task/*/schedstat is unavailable")?;
    let t0 = Instant::now();
    let mut batches = 0usize;
    let mut cpu = 0.0;
    while cpu < seconds || batches < 3 {
        batch();
        batches += 1;
        cpu = process_cpu_seconds().ok_or("schedstat unreadable")? - cpu0;
    }
    let wall = t0.elapsed().as_secs_f64();
    let calls = (batches * calls_per_batch) as f64;
    println!(
        "{name:<38} {:>12} per call CPU {:>12} per call wall  ({} calls)",
        fmt(cpu / calls),
        fmt(wall / calls),
        calls
    );
    Ok(())
}

fn fmt(s: f64) -> String {
    match s {
        s if s >= 1.0 => format!("{s:.3} s"),
        s if s >= 1e-3 => format!("{:.2} ms", s * 1e3),
        s if s >= 1e-6 => format!("{:.2} µs", s * 1e6),
        s => format!("{:.1} ns", s * 1e9),
    }
}

fn run() -> Result<(), String> {
    let mut seconds = 2.0;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seconds" => {
                let v = args.next().ok_or("--seconds needs a value")?;
                seconds = v
                    .parse::<f64>()
                    .ok()
                    .filter(|s| s.is_finite() && *s > 0.0)
                    .ok_or_else(|| format!("--seconds must be a positive number, got {v:?}"))?;
            }
            other => return Err(format!("unknown argument {other:?} (only --seconds S)")),
        }
    }
    const BATCH: usize = 1024;
    let w = rotation_vectors(BATCH, 0.1, std::f64::consts::PI - 0.1, SEED);
    let r = rotations(BATCH, 0.1, std::f64::consts::PI - 0.1, SEED);
    measure("so3::exp (generic angle)", seconds, BATCH, || {
        for wi in &w {
            black_box(so3::exp(black_box(wi)));
        }
    })?;
    measure("so3::log (generic angle)", seconds, BATCH, || {
        for ri in &r {
            black_box(so3::log(black_box(ri)));
        }
    })?;

    let chain = SerialChain::bundled();
    let n = chain.n_joints();
    let data = VjmBatch::generate(&chain, BATCH, SEED).map_err(|e| e.to_string())?;
    for model in [
        VirtualJointModel::extended(n),
        VirtualJointModel::traditional(n),
    ] {
        let mut ws = Workspace::new(&chain, &model).map_err(|e| e.to_string())?;
        let mut out = vec![0.0; 6 * model.n_params()];
        let mut failed = None;
        measure(
            &format!(
                "vjm::jacobian_in_place ({}, {})",
                model.name(),
                model.n_params()
            ),
            seconds,
            BATCH,
            || {
                for qi in data.q.chunks_exact(n) {
                    if let Err(e) =
                        jacobian_in_place(&chain, &model, black_box(qi), &mut ws, &mut out)
                    {
                        failed = Some(e.to_string());
                    }
                    black_box(&out);
                }
            },
        )?;
        if let Some(e) = failed {
            return Err(e);
        }
    }

    let big = VjmBatch::generate(&chain, 1_000_000, SEED).map_err(|e| e.to_string())?;
    let opts = IdentifyOptions::default();
    for model in [
        VirtualJointModel::extended(n),
        VirtualJointModel::traditional(n),
    ] {
        let mut failed = None;
        measure(
            &format!(
                "vjm::identify N=1e6 ({}, {})",
                model.name(),
                model.n_params()
            ),
            seconds,
            1,
            || match identify(
                &chain,
                &model,
                Measurements::new(&big.q, &big.wrench, &big.displacement),
                &opts,
            ) {
                Ok(id) => {
                    black_box(id);
                }
                Err(e) => failed = Some(e.to_string()),
            },
        )?;
        if let Some(e) = failed {
            return Err(e);
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("cpu-per-call: {e}");
            ExitCode::FAILURE
        }
    }
}
