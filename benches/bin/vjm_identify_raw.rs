//! `vjm-identify-raw`: times `vjm::identify` on the bundled Panda over raw data, and measures
//! the memory the identification needs beyond its input.
//!
//! Used by `benches/peer_compare.py` when the Python package is not installed, and for the
//! memory target of `docs/benchmarks.md`.
//!
//! ```text
//! vjm-identify-raw --dir DIR --n N [--model extended|traditional] [--repeats R] [--json]
//!     reads DIR/q.f64 (N×7), DIR/wrench.f64 (N×6), DIR/disp.f64 (N×3): row-major
//!     little-endian f64, as numpy's `ndarray.tofile` writes them
//! vjm-identify-raw --generate N [--seed S] [--model ...] [--repeats R] [--json] [--skip-identify]
//!     generates the seeded data of `robot_stiffness_benches::VjmBatch` instead
//! ```
//!
//! Memory: after the input is in memory, the peak-RSS counter of the process is reset
//! (`/proc/self/clear_refs`, value 5) and the resident size recorded; after the first
//! `identify` call the peak (`VmHWM` of `/proc/self/status`) minus that baseline is the memory
//! the call needed beyond its input. `--skip-identify` allows the same comparison from the
//! outside with `/usr/bin/time -v` (maximum resident set size with and without the call).
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;
use vjm::Measurements;

use robot_stiffness_benches::{process_cpu_seconds, reset_peak, rss_and_peak, VjmBatch, SEED};
use vjm::{identify, IdentifyOptions, SerialChain, VirtualJointModel};

struct Args {
    dir: Option<PathBuf>,
    n: Option<usize>,
    generate: Option<usize>,
    seed: u64,
    model: String,
    repeats: usize,
    json: bool,
    skip_identify: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        dir: None,
        n: None,
        generate: None,
        seed: SEED,
        model: "extended".into(),
        repeats: 1,
        json: false,
        skip_identify: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = |name: &str| it.next().ok_or_else(|| format!("{name} needs a value"));
        let count = |name: &str, v: String| {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x >= 1.0 && x.fract() == 0.0)
                .map(|x| x as usize)
                .ok_or_else(|| format!("{name} must be a positive integer, got {v:?}"))
        };
        match flag.as_str() {
            "--dir" => args.dir = Some(PathBuf::from(value("--dir")?)),
            "--n" => args.n = Some(count("--n", value("--n")?)?),
            "--generate" => args.generate = Some(count("--generate", value("--generate")?)?),
            "--seed" => {
                let v = value("--seed")?;
                args.seed = v
                    .parse()
                    .map_err(|_| format!("--seed must be an integer, got {v:?}"))?;
            }
            "--model" => args.model = value("--model")?,
            "--repeats" => args.repeats = count("--repeats", value("--repeats")?)?,
            "--json" => args.json = true,
            "--skip-identify" => args.skip_identify = true,
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    if args.dir.is_some() == args.generate.is_some() {
        return Err("give exactly one of --dir (with --n) and --generate".into());
    }
    if args.dir.is_some() && args.n.is_none() {
        return Err("--dir needs --n (number of measurements)".into());
    }
    Ok(args)
}

/// Reads `rows × cols` little-endian f64 values from `path`, checking the file size.
fn read_f64(path: &Path, rows: usize, cols: usize) -> Result<Vec<f64>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let expected = rows * cols * 8;
    if bytes.len() != expected {
        return Err(format!(
            "{}: expected {rows}×{cols} f64 ({expected} bytes), found {} bytes",
            path.display(),
            bytes.len()
        ));
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
        .collect())
}

fn run() -> Result<(), String> {
    let args = parse_args().map_err(|e| {
        if e.is_empty() {
            "usage: see the module documentation of benches/bin/vjm_identify_raw.rs".to_string()
        } else {
            e
        }
    })?;
    let chain = SerialChain::bundled();
    let joints = chain.n_joints();
    let model = match args.model.as_str() {
        "extended" => VirtualJointModel::extended(joints),
        "traditional" => VirtualJointModel::traditional(joints),
        other => {
            return Err(format!(
                "--model must be extended or traditional, got {other:?}"
            ))
        }
    };
    let (n, q, wrench, disp) = match (&args.dir, args.generate) {
        (Some(dir), _) => {
            let n = args.n.unwrap_or(0);
            (
                n,
                read_f64(&dir.join("q.f64"), n, joints)?,
                read_f64(&dir.join("wrench.f64"), n, 6)?,
                read_f64(&dir.join("disp.f64"), n, 3)?,
            )
        }
        (None, Some(n)) => {
            let b = VjmBatch::generate(&chain, n, args.seed).map_err(|e| e.to_string())?;
            (n, b.q, b.wrench, b.displacement)
        }
        (None, None) => unreachable!("parse_args requires --dir or --generate"),
    };
    let input_bytes = 8 * (q.len() + wrench.len() + disp.len()) as u64;
    if args.skip_identify {
        println!(
            "skipped identify; input {input_bytes} bytes; rss/peak {:?}",
            rss_and_peak()
        );
        return Ok(());
    }
    let opts = IdentifyOptions::default();
    let peak_reset = reset_peak();
    let baseline = rss_and_peak().map(|(rss, _)| rss);
    let mut seconds = Vec::with_capacity(args.repeats);
    let mut result = None;
    let mut peak_extra = None;
    // schedstat is only brought up to date at scheduler events, so CPU time is taken over all
    // runs together (mean per run), not per run.
    let cpu_start = process_cpu_seconds();
    for _ in 0..args.repeats {
        let t0 = Instant::now();
        let id = identify(&chain, &model, Measurements::new(&q, &wrench, &disp), &opts)
            .map_err(|e| e.to_string())?;
        seconds.push(t0.elapsed().as_secs_f64());
        if peak_extra.is_none() {
            peak_extra = match (peak_reset, baseline, rss_and_peak()) {
                (true, Some(base), Some((_, peak))) => Some(peak.saturating_sub(base)),
                _ => None,
            };
        }
        result = Some(id);
    }
    let id = result.ok_or("no run")?;
    let best = seconds.iter().copied().fold(f64::INFINITY, f64::min);
    let mean_cpu = match (cpu_start, process_cpu_seconds()) {
        (Some(a), Some(b)) => (b - a) / seconds.len() as f64,
        _ => f64::NAN,
    };
    let mean_cpu_json = if mean_cpu.is_finite() {
        format!("{mean_cpu:e}")
    } else {
        "null".to_string()
    };
    let compliance: Vec<String> = id
        .compliance
        .iter()
        .map(|c| c.map_or("null".to_string(), |v| format!("{v:e}")))
        .collect();
    if args.json {
        println!(
            "{{\"n\": {n}, \"model\": \"{}\", \"rank\": {}, \"compliance\": [{}], \"seconds\": [{}], \
             \"seconds_best\": {best:e}, \"cpu_seconds_mean\": {mean_cpu_json}, \"input_bytes\": {input_bytes}, \"peak_extra_bytes\": {}}}",
            args.model,
            id.rank,
            compliance.join(", "),
            seconds.iter().map(|s| format!("{s:e}")).collect::<Vec<_>>().join(", "),
            peak_extra.map_or("null".to_string(), |b| b.to_string()),
        );
    } else {
        println!(
            "N = {n}, {} model ({} params): rank {}, best of {} runs {:.2} ms",
            args.model,
            model.n_params(),
            id.rank,
            seconds.len(),
            best * 1e3
        );
        if mean_cpu.is_finite() {
            println!(
                "CPU time per run (all threads, mean): {:.2} ms",
                mean_cpu * 1e3
            );
        }
        println!("input: {:.1} MiB", input_bytes as f64 / 1048576.0);
        match peak_extra {
            Some(b) => println!(
                "peak memory beyond the input during identify: {:.2} MiB",
                b as f64 / 1048576.0
            ),
            None => println!("peak memory: /proc/self/clear_refs or /proc/self/status unavailable"),
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vjm-identify-raw: {e}");
            ExitCode::FAILURE
        }
    }
}
