//! Fuzz harness for every reader of the workspace, on the stable toolchain.
//!
//! ```text
//! cargo run --release -p robot-stiffness-tests --bin fuzz -- --seconds 60 --seed 1 --record fuzz.json
//! ```
//!
//! Inputs are seeds from `tests/fuzz/corpus/<target>/` (plus the bundled Panda URDF), mutated
//! over raw bytes and over their structure (numeric cells, lines, columns, header names, XML
//! attributes), and run in a worker process: each must end with a result or one error within
//! the time limit (2 s) without panicking. A panic, a dead worker or a timeout is saved to the
//! crash folder (input + message) and makes the exit status 1. The sequence of inputs is a
//! function of `--seed` alone; `--seconds` only decides how far along it the run gets.

mod corpus;
mod mutate;
mod record;
mod supervisor;
mod targets;
mod worker;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use corpus::{outcome_class, Corpus};
use record::{Failure, Record};
use supervisor::{Supervisor, Verdict};
use targets::Target;
use worker::Outcome;

const USAGE: &str = "usage: fuzz [--seconds S] [--seed N] [--record FILE] [--corpus DIR] \
[--crashes DIR] [--timeout S] [--max-execs N]\n       fuzz --replay FILE --target vjm|csjm|urdf|model";

/// Command-line options.
#[derive(Debug)]
struct Options {
    seconds: f64,
    seed: u64,
    record: Option<PathBuf>,
    corpus: PathBuf,
    crashes: PathBuf,
    timeout: f64,
    max_execs: Option<u64>,
    replay: Option<(PathBuf, Target)>,
}

fn parse_args(args: &[String]) -> Result<Options, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut o = Options {
        seconds: 10.0,
        seed: 0,
        record: None,
        corpus: root.join("fuzz/corpus"),
        crashes: root.join("../target/fuzz-crashes"),
        timeout: 2.0,
        max_execs: None,
        replay: None,
    };
    let mut replay_file = None;
    let mut replay_target = None;
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        let number = |text: &String| -> Result<f64, String> {
            text.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| format!("{flag}: expected a positive number, got '{text}'"))
        };
        match flag.as_str() {
            "--seconds" => o.seconds = number(value()?)?,
            "--timeout" => o.timeout = number(value()?)?,
            "--seed" => {
                let v = value()?;
                o.seed = v
                    .parse()
                    .map_err(|_| format!("--seed: expected an integer ≥ 0, got '{v}'"))?;
            }
            "--max-execs" => {
                let v = value()?;
                o.max_execs = Some(
                    v.parse()
                        .map_err(|_| format!("--max-execs: expected an integer, got '{v}'"))?,
                );
            }
            "--record" => o.record = Some(PathBuf::from(value()?)),
            "--corpus" => o.corpus = PathBuf::from(value()?),
            "--crashes" => o.crashes = PathBuf::from(value()?),
            "--replay" => replay_file = Some(PathBuf::from(value()?)),
            "--target" => {
                let v = value()?;
                replay_target = Some(
                    Target::from_name(v)
                        .ok_or_else(|| format!("--target: unknown target '{v}'"))?,
                );
            }
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown option '{other}'\n{USAGE}")),
        }
    }
    match (replay_file, replay_target) {
        (Some(f), Some(t)) => o.replay = Some((f, t)),
        (None, None) => {}
        _ => return Err("--replay and --target go together".into()),
    }
    Ok(o)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--worker") {
        return match worker::serve() {
            Ok(()) => ExitCode::SUCCESS,
            Err(_) => ExitCode::from(3),
        };
    }
    let opts = match parse_args(&args) {
        Ok(o) => o,
        Err(message) => {
            eprintln!("fuzz: {message}");
            return ExitCode::from(2);
        }
    };
    match run(&opts) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("fuzz: {e}");
            ExitCode::from(2)
        }
    }
}

/// The random stream of input number `i`: independent of every other input's, so the run is
/// reproducible whatever the time budget.
fn stream(seed: u64, i: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(i);
    rng
}

/// Runs the campaign; `Ok(true)` when nothing crashed or hung.
fn run(opts: &Options) -> std::io::Result<bool> {
    let timeout = Duration::from_secs_f64(opts.timeout);
    let mut supervisor = Supervisor::new(timeout);
    if let Some((file, target)) = &opts.replay {
        let input = std::fs::read(file)?;
        let verdict = supervisor.run(*target, &input)?;
        println!("{}: {}", file.display(), describe(&verdict));
        return Ok(matches!(
            verdict,
            Verdict::Done(Outcome::Ok(_) | Outcome::Err(_))
        ));
    }
    let mut corpus = Corpus::load(&opts.corpus)?;
    let mut record = Record::new(opts.seed, opts.timeout, corpus.seeds, corpus.seed_bytes);
    let start = Instant::now();
    let deadline = start + Duration::from_secs_f64(opts.seconds);
    // Every seed once as it is, then mutations until the budget is spent.
    let seeds = corpus.all();
    let mut i: u64 = 0;
    loop {
        if Instant::now() >= deadline || opts.max_execs.is_some_and(|m| i >= m) {
            break;
        }
        let (target, input) = match seeds.get(i as usize) {
            Some((t, b)) => (*t, b.clone()),
            None => {
                let mut rng = stream(opts.seed, i);
                let target = Target::ALL[rng.random_range(0..Target::ALL.len())];
                // Now and then a seed of another reader (a URDF given as a CSV, …).
                let source = if rng.random_bool(0.03) {
                    Target::ALL[rng.random_range(0..Target::ALL.len())]
                } else {
                    target
                };
                let pool = corpus.of(source);
                let base = &pool[rng.random_range(0..pool.len())];
                (target, mutate::mutate(base, target.is_xml(), &mut rng))
            }
        };
        let verdict = supervisor.run(target, &input)?;
        let (kind, text) = match &verdict {
            Verdict::Done(Outcome::Ok(s)) => ("ok", s.as_str()),
            Verdict::Done(Outcome::Err(s)) => ("error", s.as_str()),
            Verdict::Done(Outcome::Panic(s)) => ("panic", s.as_str()),
            Verdict::Hang => ("hang", ""),
            Verdict::Died(s) => ("died", s.as_str()),
        };
        record.count(target, kind);
        let class = outcome_class(kind, text);
        let new_class = corpus.observe(target, class, &input);
        if !matches!(kind, "ok" | "error") && new_class {
            let failure = Failure {
                target,
                kind: kind.to_string(),
                message: text.to_string(),
                iteration: i,
                input_len: input.len(),
            };
            let path = save_failure(&opts.crashes, &failure, &input)?;
            eprintln!(
                "fuzz: {} on {} input #{i}: {} (saved {})",
                kind,
                target.name(),
                text,
                path.display()
            );
            record.failures.push(failure);
        }
        i += 1;
        if i.is_multiple_of(1000) {
            eprintln!(
                "fuzz: {i} executions, {:.0} s, corpus {}",
                start.elapsed().as_secs_f64(),
                corpus.len()
            );
        }
    }
    record.finish(i, start.elapsed(), corpus.len(), corpus.discovered);
    println!("{}", record.summary());
    if let Some(path) = &opts.record {
        std::fs::write(path, record.to_json())?;
    }
    Ok(record.failures.is_empty())
}

fn describe(verdict: &Verdict) -> String {
    match verdict {
        Verdict::Done(Outcome::Ok(s)) => format!("ok: {s}"),
        Verdict::Done(Outcome::Err(s)) => format!("error: {s}"),
        Verdict::Done(Outcome::Panic(s)) => format!("PANIC: {s}"),
        Verdict::Hang => "HANG: no answer within the time limit".into(),
        Verdict::Died(s) => format!("CRASH: {s}"),
    }
}

/// Writes `<target>-<kind>-<hash>.input` and a `.txt` with the message next to it.
fn save_failure(dir: &Path, failure: &Failure, input: &[u8]) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let name = format!(
        "{}-{}-{:016x}",
        failure.target.name(),
        failure.kind,
        fnv1a(input)
    );
    let path = dir.join(format!("{name}.input"));
    std::fs::write(&path, input)?;
    std::fs::write(
        dir.join(format!("{name}.txt")),
        format!(
            "target: {}\nkind: {}\niteration: {}\nmessage: {}\nreplay: cargo run -p robot-stiffness-tests --bin fuzz -- --replay {} --target {}\n",
            failure.target.name(),
            failure.kind,
            failure.iteration,
            failure.message,
            path.display(),
            failure.target.name()
        ),
    )?;
    Ok(path)
}

/// FNV-1a, 64 bit: a stable file name for an input.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}
