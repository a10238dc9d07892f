//! `vjm-diagnose-raw`: one `vjm::diagnose::diagnose` (no per-row output) on a seeded campaign of
//! the bundled Panda, in Rust without the Python layer: wall and CPU time per stage and the peak
//! memory beyond the input, next to `identify` (traditional model) on the same rows.
//!
//! ```text
//! vjm-diagnose-raw N [N ...]     rows per campaign (10 loads per pose, nominal truth plus the
//!                                hidden J3x tilt of benches/diagnose_scale.py)
//! ```
//!
//! Memory: once the campaign is in memory the peak-RSS counter is reset (`/proc/self/clear_refs`)
//! and the resident size recorded; the peak after each stage minus that baseline is what the
//! diagnosis needed beyond its input up to that stage. The simulation's own buffers (the true
//! displacements, applied wrenches and tip points) are dropped before the baseline is taken.
use std::process::ExitCode;
use std::time::Instant;
use vjm::Measurements;

use robot_stiffness_benches::{
    process_cpu_seconds_with_exited as process_cpu_seconds, reset_peak, rss_and_peak,
};
use vjm::diagnose::{diagnose_with_progress, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, Effect, TrueModel};
use vjm::{identify, IdentifyOptions, SerialChain, SpringAxis, VirtualJointModel};

/// The campaign seed of `benches/diagnose_scale.py`.
const SEED: u64 = 20261201;

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

fn peak_beyond(baseline: u64) -> Option<f64> {
    rss_and_peak().map(|(_, peak)| mib(peak.saturating_sub(baseline)))
}

fn run(n_rows: usize) -> Result<(), String> {
    let chain = SerialChain::bundled();
    let n = chain.n_joints();
    let mut truth = TrueModel::nominal(n);
    truth.effects.push(Effect::JointTilt {
        joint: 2,
        axis: SpringAxis::X,
        compliance: 4.5e-5,
    });
    let spec = CampaignSpec {
        n_poses: n_rows / 10,
        wrenches_per_pose: 10,
        seed: SEED,
        ..Default::default()
    };
    let data = simulate(&chain, &truth, &spec)
        .map_err(|e| format!("simulate {n_rows} rows: {e}"))?
        .dataset;
    let baseline = rss_and_peak().map(|(rss, _)| rss);
    let memory_ok = reset_peak();
    let opts = DiagnoseOptions {
        per_row: false,
        ..Default::default()
    };
    println!("rows {n_rows}:");
    let start = Instant::now();
    let cpu_start = process_cpu_seconds();
    let (mut last_t, mut last_c) = (0.0, cpu_start.unwrap_or(0.0));
    let d = diagnose_with_progress(&chain, &data, &opts, &mut |p| {
        let t = start.elapsed().as_secs_f64();
        let c = process_cpu_seconds().unwrap_or(0.0);
        let mem = baseline
            .filter(|_| memory_ok)
            .and_then(peak_beyond)
            .map_or("n/a".to_string(), |m| format!("{m:.0} MiB"));
        println!(
            "  {:>10} {}/{}: +{:.2} s wall, +{:.2} s CPU, peak beyond input {mem}",
            p.stage,
            p.done,
            p.total,
            t - last_t,
            c - last_c
        );
        (last_t, last_c) = (t, c);
    })
    .map_err(|e| format!("diagnose: {e}"))?;
    let wall = start.elapsed().as_secs_f64();
    let cpu = match (cpu_start, process_cpu_seconds()) {
        (Some(a), Some(b)) => format!("{:.2} s", b - a),
        _ => "n/a".to_string(),
    };
    let mem = baseline
        .filter(|_| memory_ok)
        .and_then(peak_beyond)
        .map_or("n/a".to_string(), |m| format!("{m:.0} MiB"));
    let model = VirtualJointModel::traditional(n);
    let t = Instant::now();
    identify(
        &chain,
        &model,
        Measurements::new(data.q_flat(), data.wrench_flat(), data.displacement_flat()),
        &IdentifyOptions::default(),
    )
    .map_err(|e| format!("identify: {e}"))?;
    let id_wall = t.elapsed().as_secs_f64();
    let first = d.findings.first().map_or("none".to_string(), |f| {
        format!("{} joint {:?} axis {:?}", f.effect, f.joint, f.axis)
    });
    println!(
        "  diagnose {wall:.2} s wall, {cpu} CPU, peak beyond input {mem}; identify {:.4} s \
         (ratio {:.0}); first finding {first}",
        id_wall,
        wall / id_wall
    );
    Ok(())
}

fn main() -> ExitCode {
    let sizes: Result<Vec<usize>, String> = std::env::args()
        .skip(1)
        .map(|a| {
            a.parse::<usize>()
                .map_err(|_| format!("a row count (≥ 100) was expected, got {a:?}"))
        })
        .collect();
    let sizes = match sizes {
        Ok(s) if !s.is_empty() && s.iter().all(|&n| n >= 100) => s,
        Ok(_) => {
            eprintln!("usage: vjm-diagnose-raw N [N ...]   (rows per campaign, each ≥ 100)");
            return ExitCode::from(2);
        }
        Err(e) => {
            eprintln!("vjm-diagnose-raw: {e}");
            return ExitCode::from(2);
        }
    };
    for n in sizes {
        if let Err(e) = run(n) {
            eprintln!("vjm-diagnose-raw: {e}");
            return ExitCode::FAILURE;
        }
    }
    ExitCode::SUCCESS
}
