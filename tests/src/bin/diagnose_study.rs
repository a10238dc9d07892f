//! The diagnose study: false alarms and power of `vjm::diagnose` (and false alarms of the CSJM
//! diagnose) on simulated campaigns. Prints markdown tables; `--json PATH` also writes every
//! cell. See docs/diagnose-study.md for the command that produced the published tables.
//!
//! ```text
//! diagnose_study [--part all|false-alarm|power|csjm[,…]] [--seeds N] [--power-seeds N]
//!                [--robots panda,xarm7,ur5,kinova] [--power-robots …]
//!                [--noise-um 3,10,40] [--ft-accuracy 0.01[,…]] [--power-noise-um 10]
//!                [--json PATH] [--smoke]
//! ```

use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use robot_stiffness_tests::study::effects::{catalogue_grid, outside_grid, pair_grid, Hidden};
use robot_stiffness_tests::study::report::{
    csjm_table, false_alarm_table, power_summary, power_table, threshold_table,
};
use robot_stiffness_tests::study::robots::{load_robot, StudyRobot, ROBOTS};
use robot_stiffness_tests::study::run::{run_cell, run_csjm, CellResult, CsjmResult};
use vjm::diagnose::DiagnoseOptions;

/// First campaign seed of the false-alarm cells, the power cells and the CSJM cell (disjoint
/// from the seeds of the crates' own tests).
const FALSE_ALARM_SEED: u64 = 10_000;
const POWER_SEED: u64 = 20_000;
const CSJM_SEED: u64 = 10_000;

#[derive(Debug)]
struct Args {
    parts: Vec<String>,
    seeds: usize,
    power_seeds: usize,
    robots: Vec<String>,
    power_robots: Vec<String>,
    noise_um: Vec<f64>,
    ft_accuracy: Vec<f64>,
    power_noise_um: f64,
    json: Option<String>,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        parts: vec!["all".into()],
        seeds: 50,
        power_seeds: 50,
        robots: ROBOTS.iter().map(|s| s.to_string()).collect(),
        power_robots: Vec::new(),
        noise_um: vec![3.0, 10.0, 40.0],
        ft_accuracy: vec![0.01],
        power_noise_um: 10.0,
        json: None,
    };
    let list = |v: &str| -> Vec<String> { v.split(',').map(|s| s.trim().to_string()).collect() };
    let count = |flag: &str, v: &str| -> Result<usize, String> {
        v.parse::<usize>()
            .ok()
            .filter(|n| *n > 0)
            .ok_or_else(|| format!("{flag} needs a positive integer, got `{v}`"))
    };
    let um = |flag: &str, v: &str| -> Result<f64, String> {
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| format!("{flag} needs positive finite numbers (µm), got `{v}`"))
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--smoke" {
            a.seeds = 2;
            a.power_seeds = 2;
            continue;
        }
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--part" => a.parts = list(&value),
            "--seeds" => a.seeds = count(&flag, &value)?,
            "--power-seeds" => a.power_seeds = count(&flag, &value)?,
            "--robots" => a.robots = list(&value),
            "--power-robots" => a.power_robots = list(&value),
            "--noise-um" => {
                a.noise_um = list(&value)
                    .iter()
                    .map(|v| um(&flag, v))
                    .collect::<Result<_, _>>()?
            }
            "--ft-accuracy" => {
                a.ft_accuracy = list(&value)
                    .iter()
                    .map(|v| {
                        v.parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite() && *x > 0.0 && *x < 1.0)
                            .ok_or_else(|| {
                                format!("{flag} needs fractions of full scale in (0, 1), got `{v}`")
                            })
                    })
                    .collect::<Result<_, _>>()?
            }
            "--power-noise-um" => a.power_noise_um = um(&flag, &value)?,
            "--json" => a.json = Some(value),
            other => return Err(format!("unknown flag `{other}` (see the file header)")),
        }
    }
    for p in &a.parts {
        if !["all", "false-alarm", "power", "csjm"].contains(&p.as_str()) {
            return Err(format!(
                "--part `{p}`: expected all, false-alarm, power or csjm"
            ));
        }
    }
    if a.power_robots.is_empty() {
        a.power_robots = a.robots.clone();
    }
    Ok(a)
}

fn wants(a: &Args, part: &str) -> bool {
    a.parts.iter().any(|p| p == "all" || p == part)
}

fn cell(
    robot: &StudyRobot,
    hidden: &Hidden,
    sigma_um: f64,
    ft_accuracy: f64,
    first_seed: u64,
    runs: usize,
    out: &mut Vec<CellResult>,
) -> Result<(), String> {
    let t = Instant::now();
    let label = format!(
        "{} | {} {} | {} µm, F/T {} %",
        robot.name,
        hidden.family(),
        hidden.magnitude(),
        sigma_um,
        100.0 * ft_accuracy
    );
    let r = run_cell(
        robot,
        hidden,
        sigma_um * 1e-6,
        ft_accuracy,
        first_seed,
        runs,
        &mut |done| {
            eprint!("\r{label}: {done}/{runs}");
            let _ = std::io::stderr().flush();
        },
    )
    .map_err(|e| e.to_string())?;
    eprintln!(
        "\r{label}: {runs} runs in {:.1} s — detected {}/{} (given: {}/{})",
        t.elapsed().as_secs_f64(),
        r[0].detected,
        r[0].runs,
        r[1].detected,
        r[1].runs
    );
    out.extend(r);
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("diagnose_study: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("diagnose_study: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &Args) -> Result<(), String> {
    let start = Instant::now();
    let mut robots: Vec<StudyRobot> = Vec::new();
    let mut names = args.robots.clone();
    for r in &args.power_robots {
        if !names.contains(r) {
            names.push(r.clone());
        }
    }
    for name in &names {
        let r = load_robot(name).map_err(|e| e.to_string())?;
        eprintln!("{}: {} ({} joints)", r.name, r.source, r.chain.n_joints());
        robots.push(r);
    }
    let get = |name: &str| {
        robots
            .iter()
            .find(|r| r.name == name)
            .expect("loaded above")
    };
    let mut false_alarm = Vec::new();
    let mut power = Vec::new();
    let mut csjm: Option<CsjmResult> = None;
    if wants(args, "false-alarm") {
        for name in &args.robots {
            for (&ft, &s) in args
                .ft_accuracy
                .iter()
                .flat_map(|ft| args.noise_um.iter().map(move |s| (ft, s)))
            {
                cell(
                    get(name),
                    &Hidden::Clean,
                    s,
                    ft,
                    FALSE_ALARM_SEED,
                    args.seeds,
                    &mut false_alarm,
                )?;
            }
        }
    }
    if wants(args, "csjm") {
        let t = Instant::now();
        let r = run_csjm(CSJM_SEED, args.seeds).map_err(|e| e.to_string())?;
        eprintln!(
            "csjm: {} runs in {:.1} s — alarms {}",
            r.runs,
            t.elapsed().as_secs_f64(),
            r.alarm
        );
        csjm = Some(r);
    }
    if wants(args, "power") {
        let mut grid = catalogue_grid();
        grid.extend(outside_grid());
        grid.extend(pair_grid());
        for name in &args.power_robots {
            for h in &grid {
                cell(
                    get(name),
                    h,
                    args.power_noise_um,
                    args.ft_accuracy[0],
                    POWER_SEED,
                    args.power_seeds,
                    &mut power,
                )?;
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let cmd: Vec<String> = std::env::args().skip(1).collect();
    println!(
        "<!-- diagnose_study {}: {:.0} s wall -->\n",
        cmd.join(" "),
        secs
    );
    for r in &robots {
        println!(
            "- {}: {}, torsional compliances {:?} rad/(N·m)",
            r.name, r.source, r.torsion
        );
    }
    println!();
    if !false_alarm.is_empty() {
        println!("### False alarms on clean campaigns (seeds {FALSE_ALARM_SEED}…)\n");
        println!(
            "{}",
            false_alarm_table(&false_alarm, DiagnoseOptions::default().selection.fdr)
        );
    }
    if let Some(r) = &csjm {
        println!("### CSJM diagnose on clean campaigns (seeds {CSJM_SEED}…)\n");
        println!("{}", csjm_table(r));
    }
    if !power.is_empty() {
        println!(
            "### Power at {} µm tracker noise, F/T {} % (seeds {POWER_SEED}…): detected % without / with the noise given\n",
            args.power_noise_um,
            100.0 * args.ft_accuracy[0]
        );
        println!("{}", power_summary(&power));
        println!("#### Above the detectability threshold (λ ≥ 64, docs/diagnose.md §4)\n");
        println!("{}", threshold_table(&power));
        println!("#### Every power cell\n");
        println!("{}", power_table(&power));
    }
    println!("Total wall time {secs:.0} s.");
    if let Some(path) = &args.json {
        let doc = serde_json::json!({
            "command": cmd,
            "wall_seconds": secs,
            "false_alarm": false_alarm,
            "csjm": csjm,
            "power": power,
        });
        // Written next to the target and renamed, so a failed run leaves no partial file.
        let tmp = format!("{path}.partial");
        std::fs::write(
            &tmp,
            serde_json::to_string_pretty(&doc).expect("serialisable"),
        )
        .map_err(|e| format!("cannot write {path}: {e}"))?;
        std::fs::rename(&tmp, path).map_err(|e| format!("cannot write {path}: {e}"))?;
    }
    Ok(())
}
