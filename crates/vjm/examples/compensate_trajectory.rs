//! Times the compensation of a 10⁴-row trajectory on the bundled Panda (extended model,
//! 21 springs, K_C on), position only and full pose.
//!
//! `cargo run --release -p vjm --example compensate_trajectory -- [ROWS]` (default 10 000).
//! A smooth trajectory through the workspace (every joint a sinusoid inside its limits) under
//! a payload of 8 kg 0.1 m beyond the tip; prints wall and CPU time, the iterations and the
//! status counts. One thread: the call is sequential (one workspace).

use std::time::Instant;

use vjm::{
    compensate_in_place, CompensateOptions, CompensatedRow, CompensationBuffers,
    CompensationStatus, CompensationTargets, CompensationWorkspace, Load, PointMass, SerialChain,
    VirtualJointModel,
};

/// CPU seconds (user + system) of this process from /proc/self/stat (Linux, 100 Hz ticks).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| {
        f.get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let rows: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000);
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let torsion = vjm::testbed::NOMINAL_TORSION;
    let compliance: Vec<f64> = (0..21)
        .map(|k| torsion[k / 3] * if k % 3 == 0 { 1.0 } else { 0.4 })
        .collect();
    let mut q = Vec::with_capacity(7 * rows);
    for i in 0..rows {
        let t = i as f64 / rows as f64;
        for (j, &(lo, hi)) in chain.limits().iter().enumerate() {
            let mid = 0.5 * (lo + hi);
            let amp = 0.35 * (hi - lo);
            q.push(mid + amp * (std::f64::consts::TAU * (1.0 + j as f64 * 0.37) * t).sin());
        }
    }
    let load = Load::Payload(PointMass::new(8.0, [0.0, 0.0, 0.1]).expect("payload"));
    let blank = CompensatedRow {
        status: CompensationStatus::NotConverged,
        iterations: 0,
        position_error: 0.0,
        rotation_error: 0.0,
        deflection: 0.0,
        rotation_deflection: 0.0,
        inverse_condition: 0.0,
        limit_joint: None,
    };
    for match_orientation in [false, true] {
        let mut opts = CompensateOptions::default();
        opts.match_orientation = match_orientation;
        let mut ws = CompensationWorkspace::new(&chain, &model).expect("workspace");
        let mut q_out = vec![0.0; q.len()];
        let mut report = vec![blank; rows];
        let (t0, c0) = (Instant::now(), cpu_seconds());
        let targets = CompensationTargets {
            q_nominal: &q,
            load,
        };
        let out = CompensationBuffers {
            q: &mut q_out,
            rows: &mut report,
        };
        compensate_in_place(&chain, &model, &compliance, targets, &opts, &mut ws, out)
            .expect("compensation");
        let (wall, cpu) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
        let iters: usize = report.iter().map(|r| r.iterations).sum();
        let mut counts = std::collections::BTreeMap::new();
        for r in &report {
            *counts.entry(r.status.as_str()).or_insert(0usize) += 1;
        }
        let worst = report
            .iter()
            .filter(|r| r.status == CompensationStatus::Converged)
            .map(|r| r.position_error)
            .fold(0.0, f64::max);
        println!(
            "{rows} rows, {}: wall {wall:.3} s, CPU {cpu:.2} s, {:.1} µs/row, mean {:.2} iterations, \
             worst converged residual {worst:.1e} m, statuses {counts:?}",
            if match_orientation { "pose" } else { "position" },
            1e6 * wall / rows as f64,
            iters as f64 / rows as f64
        );
    }
}
