//! The run's record: executions, duration, failures, corpus size, machine and date, as JSON.

use std::collections::BTreeMap;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde_json::json;

use crate::targets::Target;

/// One saved failure (the first input of its class).
#[derive(Debug, Clone)]
pub struct Failure {
    /// The reader.
    pub target: Target,
    /// `panic`, `hang` or `died`.
    pub kind: String,
    /// Panic message or how the worker died.
    pub message: String,
    /// Input number in the run.
    pub iteration: u64,
    /// Input size, bytes.
    pub input_len: usize,
}

/// Counters of a run.
#[derive(Debug)]
pub struct Record {
    seed: u64,
    timeout_s: f64,
    seeds: usize,
    seed_bytes: usize,
    date: String,
    outcomes: BTreeMap<(Target, &'static str), u64>,
    executions: u64,
    duration: Duration,
    corpus_size: usize,
    discovered: usize,
    /// Failures, one per class.
    pub failures: Vec<Failure>,
}

impl Record {
    /// A record of a run starting now.
    pub fn new(seed: u64, timeout_s: f64, seeds: usize, seed_bytes: usize) -> Self {
        Record {
            seed,
            timeout_s,
            seeds,
            seed_bytes,
            date: utc_now(),
            outcomes: BTreeMap::new(),
            executions: 0,
            duration: Duration::ZERO,
            corpus_size: 0,
            discovered: 0,
            failures: Vec::new(),
        }
    }

    /// Counts one outcome.
    pub fn count(&mut self, target: Target, kind: &str) {
        let kind = match kind {
            "ok" => "ok",
            "error" => "error",
            "panic" => "panic",
            "hang" => "hang",
            _ => "died",
        };
        *self.outcomes.entry((target, kind)).or_default() += 1;
    }

    /// Closes the record.
    pub fn finish(
        &mut self,
        executions: u64,
        duration: Duration,
        corpus_size: usize,
        discovered: usize,
    ) {
        self.executions = executions;
        self.duration = duration;
        self.corpus_size = corpus_size;
        self.discovered = discovered;
    }

    fn total(&self, kinds: &[&str]) -> u64 {
        self.outcomes
            .iter()
            .filter(|((_, k), _)| kinds.contains(k))
            .map(|(_, n)| n)
            .sum()
    }

    /// One line for the terminal.
    pub fn summary(&self) -> String {
        format!(
            "fuzz: {} executions in {:.1} s ({:.0}/s), seed {}: {} results, {} errors, {} crashes ({} panics, {} dead workers), {} hangs; corpus {} ({} seeds + {} found); {} distinct failures",
            self.executions,
            self.duration.as_secs_f64(),
            self.executions as f64 / self.duration.as_secs_f64().max(1e-9),
            self.seed,
            self.total(&["ok"]),
            self.total(&["error"]),
            self.total(&["panic", "died"]),
            self.total(&["panic"]),
            self.total(&["died"]),
            self.total(&["hang"]),
            self.corpus_size,
            self.seeds,
            self.discovered,
            self.failures.len(),
        )
    }

    /// The record as pretty JSON.
    pub fn to_json(&self) -> String {
        let per_target: BTreeMap<&str, BTreeMap<&str, u64>> =
            self.outcomes
                .iter()
                .fold(BTreeMap::new(), |mut m, ((t, k), n)| {
                    m.entry(t.name()).or_default().insert(k, *n);
                    m
                });
        let failures: Vec<_> = self
            .failures
            .iter()
            .map(|f| {
                json!({
                    "target": f.target.name(),
                    "kind": f.kind,
                    "message": f.message,
                    "iteration": f.iteration,
                    "input_bytes": f.input_len,
                })
            })
            .collect();
        let value = json!({
            "command": std::env::args().collect::<Vec<_>>().join(" "),
            "date_utc": self.date,
            "seed": self.seed,
            "timeout_s": self.timeout_s,
            "duration_s": (self.duration.as_secs_f64() * 10.0).round() / 10.0,
            "executions": self.executions,
            "executions_per_target": per_target,
            "crashes": self.total(&["panic", "died"]),
            "hangs": self.total(&["hang"]),
            "distinct_failures": failures,
            "corpus": {
                "seeds": self.seeds,
                "seed_bytes": self.seed_bytes,
                "found_in_run": self.discovered,
                "size_at_end": self.corpus_size,
            },
            "machine": machine(),
            "profile": if cfg!(debug_assertions) { "debug" } else { "release" },
        });
        serde_json::to_string_pretty(&value).expect("a JSON value serialises") + "\n"
    }
}

/// CPU model, logical CPUs and kernel, read from /proc where there is one.
fn machine() -> serde_json::Value {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "unknown".into());
    json!({
        "cpu": cpu,
        "logical_cpus": std::thread::available_parallelism().map_or(0, |n| n.get()),
        "os": format!("{} {kernel}", std::env::consts::OS),
        "arch": std::env::consts::ARCH,
    })
}

/// Now as `YYYY-MM-DDTHH:MM:SSZ` (civil-from-days, proleptic Gregorian).
fn utc_now() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}
