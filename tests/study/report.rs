//! Markdown tables of the study's results.

use std::fmt::Write;

use super::run::{CellResult, CsjmResult};

fn pct(x: f64) -> String {
    format!("{:.1} %", 100.0 * x)
}

fn verdicts(r: &CellResult, k: usize) -> String {
    let v = r.top_verdicts(k);
    if v.is_empty() {
        return "—".into();
    }
    v.iter()
        .map(|(l, n)| format!("{l} {n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The false-alarm table: one row per robot × tracker noise × noise mode.
pub fn false_alarm_table(cells: &[CellResult], fdr: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| robot | tracker σ | F/T accuracy | noise given | runs | any finding | unexplained | false-alarm rate | 95 % CI | stated FDR | median scaled RMS | verdicts (runs) |"
    );
    let _ = writeln!(
        s,
        "|---|---:|---:|---|---:|---:|---:|---:|---|---:|---:|---|"
    );
    for r in cells {
        let (lo, hi) = r.alarm_ci();
        let _ = writeln!(
            s,
            "| {} | {} µm | {} % | {} | {} | {} | {} | {} | [{}, {}] | {} | {:.2} | {} |",
            r.robot,
            r.tracker_sigma_um,
            100.0 * r.ft_accuracy,
            if r.noise_given { "yes" } else { "no" },
            r.runs,
            r.any_finding,
            r.unexplained,
            pct(r.alarm as f64 / r.runs.max(1) as f64),
            pct(lo),
            pct(hi),
            fdr,
            r.median_scaled_rms,
            verdicts(r, 3)
        );
    }
    s
}

/// The power table: one row per robot × effect × magnitude × noise mode.
pub fn power_table(cells: &[CellResult]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| robot | effect | magnitude | noise given | runs | detected | 95 % CI | any finding | unexplained | mean gain | median scaled RMS | verdicts (runs) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---:|---:|---|---:|---:|---:|---:|---|");
    for r in cells {
        let (lo, hi) = r.detected_ci();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | [{}, {}] | {} | {} | {:.2} | {:.2} | {} |",
            r.robot,
            r.effect,
            r.magnitude,
            if r.noise_given { "yes" } else { "no" },
            r.runs,
            pct(r.detected as f64 / r.runs.max(1) as f64),
            pct(lo),
            pct(hi),
            r.any_finding,
            r.unexplained,
            r.mean_gain,
            r.median_scaled_rms,
            verdicts(r, 3)
        );
    }
    s
}

/// The CSJM false-alarm line.
pub fn csjm_table(r: &CsjmResult) -> String {
    let (lo, hi) = super::stats::clopper_pearson(r.alarm, r.runs, 0.05);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| model | runs | defect finding | unexplained | false-alarm rate | 95 % CI | stated FDR | connection_term named | verdicts (runs) |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---|---:|---:|---|");
    let v = if r.verdicts.is_empty() {
        "—".to_string()
    } else {
        r.verdicts
            .iter()
            .map(|(l, n)| format!("{l} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        s,
        "| CSJM prototype (seed campaign) | {} | {} | {} | {} | [{}, {}] | {} | {} | {} |",
        r.runs,
        r.defect_finding,
        r.unexplained,
        pct(r.alarm as f64 / r.runs.max(1) as f64),
        pct(lo),
        pct(hi),
        r.fdr,
        r.connection_term,
        v
    );
    s
}

/// The power summary: one row per effect × magnitude, one column per robot, each cell
/// "detection rate without / with the noise given (median scaled RMS of the extended model
/// with the noise given)".
pub fn power_summary(cells: &[CellResult]) -> String {
    let mut robots: Vec<&str> = Vec::new();
    let mut rows: Vec<(&str, &str)> = Vec::new();
    for c in cells {
        if !robots.contains(&c.robot.as_str()) {
            robots.push(&c.robot);
        }
        if !rows.contains(&(c.effect.as_str(), c.magnitude.as_str())) {
            rows.push((&c.effect, &c.magnitude));
        }
    }
    let mut s = String::new();
    let _ = write!(s, "| effect | magnitude |");
    for r in &robots {
        let _ = write!(s, " {r} |");
    }
    let _ = writeln!(s);
    let _ = write!(s, "|---|---|");
    for _ in &robots {
        let _ = write!(s, "---:|");
    }
    let _ = writeln!(s);
    for (effect, magnitude) in rows {
        let _ = write!(s, "| {effect} | {magnitude} |");
        for robot in &robots {
            let rate = |given: bool| {
                cells
                    .iter()
                    .find(|c| {
                        c.robot == *robot
                            && c.effect == effect
                            && c.magnitude == magnitude
                            && c.noise_given == given
                    })
                    .map(|c| format!("{:.0}", 100.0 * c.detected as f64 / c.runs.max(1) as f64))
                    .unwrap_or_else(|| "–".into())
            };
            let rms = cells
                .iter()
                .find(|c| {
                    c.robot == *robot
                        && c.effect == effect
                        && c.magnitude == magnitude
                        && c.noise_given
                })
                .map(|c| format!("{:.1}", c.median_scaled_rms))
                .unwrap_or_else(|| "–".into());
            let _ = write!(s, " {} / {} ({rms}) |", rate(false), rate(true));
        }
        let _ = writeln!(s);
    }
    s
}

/// The power above the detectability threshold: one row per robot × effect × magnitude whose
/// effect acts on the arm, with the median λ and, among the runs with λ ≥ 64, how many found
/// the effect without / with the noise given; the last row sums every cell.
pub fn threshold_table(cells: &[CellResult]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| robot | effect | magnitude | median λ | runs with λ ≥ 64 | found (not given) | found (given) |"
    );
    let _ = writeln!(s, "|---|---|---|---:|---:|---:|---:|");
    let mut total = [0usize; 3];
    for given in cells.iter().filter(|c| c.noise_given) {
        let Some(lambda) = given.median_lambda else {
            continue;
        };
        let not_given = cells.iter().find(|c| {
            !c.noise_given
                && c.robot == given.robot
                && c.effect == given.effect
                && c.magnitude == given.magnitude
        });
        let found_ng = not_given.map_or(0, |c| c.detected_above);
        total[0] += given.runs_above;
        total[1] += found_ng;
        total[2] += given.detected_above;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.0} | {} / {} | {} | {} |",
            given.robot,
            given.effect,
            given.magnitude,
            lambda,
            given.runs_above,
            given.runs,
            found_ng,
            given.detected_above
        );
    }
    let share = |n: usize| pct(n as f64 / total[0].max(1) as f64);
    let _ = writeln!(
        s,
        "| **all** | | | | {} | {} ({}) | {} ({}) |",
        total[0],
        total[1],
        share(total[1]),
        total[2],
        share(total[2])
    );
    s
}
