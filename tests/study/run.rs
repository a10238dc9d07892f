//! Running the study: one cell = one robot × one hidden effect × one tracker noise level, over
//! a range of campaign seeds, each campaign diagnosed twice (noise level given to diagnose, and
//! the default noise assumption).

use std::collections::BTreeMap;
use std::time::Instant;

use serde::Serialize;
use so3_stiffness::testbed::{simulate_campaign, CsjmCampaignSpec, CsjmEffects};
use vjm::diagnose::report::Diagnosis;
use vjm::diagnose::{diagnose, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, ForceSensorNoise, TrackerNoise, TrueModel};

use super::effects::{rms_torque, tool_axis_translations, Hidden, EFFECT_JOINT};
use super::robots::StudyRobot;
use super::stats::clopper_pearson;

/// Why a study run failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StudyError {
    /// Simulating a campaign failed.
    #[error("{robot}, seed {seed}: simulation failed: {message}")]
    Simulate {
        /// Robot.
        robot: String,
        /// Campaign seed.
        seed: u64,
        /// The testbed's message.
        message: String,
    },
    /// Diagnosing a campaign failed.
    #[error("{robot}, seed {seed}: diagnose failed: {message}")]
    Diagnose {
        /// Robot.
        robot: String,
        /// Campaign seed.
        seed: u64,
        /// Diagnose's message.
        message: String,
    },
}

/// The outcome of one cell under one noise mode.
#[derive(Debug, Clone, Serialize)]
pub struct CellResult {
    /// Robot name.
    pub robot: String,
    /// Effect family (see [`Hidden::family`]).
    pub effect: String,
    /// Magnitude with unit.
    pub magnitude: String,
    /// Whether the effect is outside the catalogue.
    pub outside: bool,
    /// Per-axis tracker noise of the campaigns, µm.
    pub tracker_sigma_um: f64,
    /// F/T sensor accuracy of the campaigns, fraction of full scale (100 N, 10 N·m) read as 2σ.
    pub ft_accuracy: f64,
    /// Whether diagnose was given the instruments' noise (tracker σ and F/T σ), else its
    /// default assumption (≈ 21 µm, 1 % of full scale).
    pub noise_given: bool,
    /// Campaign seeds `first_seed .. first_seed + runs`.
    pub first_seed: u64,
    /// Runs.
    pub runs: usize,
    /// Runs where the hidden effect was detected (for `clean`: no finding and not unexplained).
    pub detected: usize,
    /// Runs with at least one finding.
    pub any_finding: usize,
    /// Runs with `unexplained: true`.
    pub unexplained: usize,
    /// Runs with a finding or `unexplained` (the false-alarm count on clean data).
    pub alarm: usize,
    /// Verdict labels (`effect(Jja)`, `unexplained`) and how many runs carried each.
    pub verdicts: BTreeMap<String, usize>,
    /// Mean held-out gain of the extension.
    pub mean_gain: f64,
    /// Median over runs of the extended model's `scaled_rms` (RMS of the residuals in units of
    /// the assumed noise, ≈ 1 when only noise of the assumed size remains).
    pub median_scaled_rms: f64,
    /// Median over runs of the effect's detectability λ (docs/diagnose.md §4: the signal energy
    /// the baseline cannot absorb, in units of the instruments' true noise variance), for
    /// effects on the arm ([`Hidden::arm_side`]); `None` otherwise. The same in both modes.
    pub median_lambda: Option<f64>,
    /// Runs whose λ reaches the threshold [`LAMBDA_THRESHOLD`] (0 when λ is not computed).
    pub runs_above: usize,
    /// Of those, runs where the effect was detected.
    pub detected_above: usize,
    /// Wall time of the cell (both modes share simulation), s.
    pub seconds: f64,
}

/// The detectability threshold of docs/diagnose.md §4: an effect with λ ≥ 64 (its orthogonal
/// signal 8 σ) must be found.
pub const LAMBDA_THRESHOLD: f64 = 64.0;

impl CellResult {
    /// 95 % Clopper–Pearson interval of the detection rate.
    pub fn detected_ci(&self) -> (f64, f64) {
        clopper_pearson(self.detected, self.runs, 0.05)
    }

    /// 95 % Clopper–Pearson interval of the alarm rate.
    pub fn alarm_ci(&self) -> (f64, f64) {
        clopper_pearson(self.alarm, self.runs, 0.05)
    }

    /// The `k` most frequent verdict labels with their counts, most frequent first.
    pub fn top_verdicts(&self, k: usize) -> Vec<(String, usize)> {
        let mut v: Vec<(String, usize)> =
            self.verdicts.iter().map(|(a, b)| (a.clone(), *b)).collect();
        v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        v.truncate(k);
        v
    }
}

fn labels(d: &Diagnosis) -> Vec<String> {
    let mut out: Vec<String> = d
        .findings
        .iter()
        .map(|f| match (f.joint, &f.axis) {
            (Some(j), Some(a)) => format!("{}(J{j}{a})", f.effect),
            (Some(j), None) => format!("{}(J{j})", f.effect),
            _ => f.effect.to_string(),
        })
        .collect();
    if d.unexplained {
        out.push("unexplained".into());
    }
    out
}

/// Runs one cell: `runs` campaigns (seeds `first_seed..`) of `robot` carrying `hidden`, with
/// isotropic tracker noise `sigma` (m) per axis and an F/T sensor of accuracy `ft_accuracy`
/// (fraction of full scale, the testbed's default is 0.01); each campaign is diagnosed with
/// the instruments' noise given and with diagnose's default assumption.
/// Returns `[not given, given]`. `progress` is called after each seed.
pub fn run_cell(
    robot: &StudyRobot,
    hidden: &Hidden,
    sigma: f64,
    ft_accuracy: f64,
    first_seed: u64,
    runs: usize,
    progress: &mut dyn FnMut(usize),
) -> Result<[CellResult; 2], StudyError> {
    let start = Instant::now();
    let empty = |given: bool| CellResult {
        robot: robot.name.into(),
        effect: hidden.family(),
        magnitude: hidden.magnitude(),
        outside: hidden.outside(),
        tracker_sigma_um: sigma * 1e6,
        ft_accuracy,
        noise_given: given,
        first_seed,
        runs: 0,
        detected: 0,
        any_finding: 0,
        unexplained: 0,
        alarm: 0,
        verdicts: BTreeMap::new(),
        mean_gain: 0.0,
        median_scaled_rms: 0.0,
        median_lambda: None,
        runs_above: 0,
        detected_above: 0,
        seconds: 0.0,
    };
    let mut out = [empty(false), empty(true)];
    let mut scaled_rms: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut lambdas: Vec<f64> = Vec::new();
    let chain = &robot.chain;
    let needs_rms = format!("{hidden:?}").contains("TorsionNonlinear");
    let force_sensor = ForceSensorNoise {
        relative_accuracy: ft_accuracy,
        ..Default::default()
    };
    for (done, seed) in (first_seed..first_seed + runs as u64).enumerate() {
        let sim_err = |e: vjm::testbed::TestbedError| StudyError::Simulate {
            robot: robot.name.into(),
            seed,
            message: e.to_string(),
        };
        let base = CampaignSpec {
            tracker: TrackerNoise::isotropic(sigma),
            force_sensor,
            seed,
            ..Default::default()
        };
        let spec = hidden.spec(&base);
        // The torsion-only arm without noise: the same seed gives the same poses and loads.
        // It scales the non-linear torsion's knots and is the reference of λ.
        let nominal = if needs_rms || hidden.arm_side() {
            let quiet = CampaignSpec {
                noise: false,
                ..spec.clone()
            };
            Some(
                simulate(chain, &TrueModel::torsion_only(&robot.torsion), &quiet)
                    .map_err(sim_err)?,
            )
        } else {
            None
        };
        let rms = match &nominal {
            Some(c) if needs_rms => {
                let q: Vec<Vec<f64>> = (0..c.dataset.len())
                    .map(|i| c.dataset.q(i).to_vec())
                    .collect();
                rms_torque(chain, &q, &c.applied_wrench, EFFECT_JOINT)
            }
            _ => 0.0,
        };
        let truth = hidden.truth(&robot.torsion, rms);
        let campaign = simulate(chain, &truth, &spec).map_err(sim_err)?;
        let q_rows: Vec<Vec<f64>> = (0..campaign.dataset.len().min(8))
            .map(|i| campaign.dataset.q(i).to_vec())
            .collect();
        let tool_axes = tool_axis_translations(chain, &q_rows);
        let lambda = match &nominal {
            Some(nominal) if hidden.arm_side() => Some(detectability_of(
                robot,
                seed,
                &campaign,
                nominal,
                sigma,
                force_sensor.sigma(),
            )?),
            _ => None,
        };
        lambdas.extend(lambda);
        for (k, given) in [false, true].into_iter().enumerate() {
            let mut opts = DiagnoseOptions::default();
            if given {
                opts.noise.displacement_sigma = sigma;
                opts.noise.wrench_sigma = force_sensor.sigma();
                opts.noise_known = true;
            }
            let d =
                diagnose(chain, &campaign.dataset, &opts).map_err(|e| StudyError::Diagnose {
                    robot: robot.name.into(),
                    seed,
                    message: e.to_string(),
                })?;
            let r = &mut out[k];
            r.runs += 1;
            let found = hidden.detected(&d, &tool_axes);
            r.detected += found as usize;
            if lambda.is_some_and(|l| l >= LAMBDA_THRESHOLD) {
                r.runs_above += 1;
                r.detected_above += found as usize;
            }
            r.any_finding += (!d.findings.is_empty()) as usize;
            r.unexplained += d.unexplained as usize;
            r.alarm += (!d.findings.is_empty() || d.unexplained) as usize;
            r.mean_gain += if d.gain.is_finite() { d.gain } else { 0.0 };
            scaled_rms[k].push(d.residuals.extended.scaled_rms);
            for l in labels(&d) {
                *r.verdicts.entry(l).or_insert(0) += 1;
            }
        }
        progress(done + 1);
    }
    let secs = start.elapsed().as_secs_f64();
    let median_lambda = median(&mut lambdas);
    for (r, v) in out.iter_mut().zip(scaled_rms.iter_mut()) {
        r.mean_gain /= r.runs.max(1) as f64;
        r.median_scaled_rms = median(v).unwrap_or(f64::NAN);
        r.seconds = secs;
        r.median_lambda = median_lambda;
    }
    Ok(out)
}

fn median(v: &mut [f64]) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => None,
        n if n % 2 == 1 => Some(v[n / 2]),
        n => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// λ of the effect in `campaign` (seed `seed`): its noise-free displacement minus `nominal`'s,
/// the torsion-only arm's noise-free campaign at the same poses and applied wrenches, whitened
/// with the instruments' true noise (tracker `sigma`, F/T `wrench_sigma`).
fn detectability_of(
    robot: &StudyRobot,
    seed: u64,
    campaign: &vjm::testbed::Campaign,
    nominal: &vjm::testbed::Campaign,
    sigma: f64,
    wrench_sigma: [f64; 6],
) -> Result<f64, StudyError> {
    let signal: Vec<[f64; 3]> = campaign
        .true_displacement
        .iter()
        .zip(&nominal.true_displacement)
        .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
        .collect();
    let mut opts = DiagnoseOptions::default();
    opts.noise.displacement_sigma = sigma;
    opts.noise.wrench_sigma = wrench_sigma;
    opts.noise_known = true;
    vjm::diagnose::detectability(&robot.chain, &campaign.dataset, &signal, &opts).map_err(|e| {
        StudyError::Diagnose {
            robot: robot.name.into(),
            seed,
            message: format!("detectability: {e}"),
        }
    })
}

/// The CSJM false-alarm cell: clean campaigns (`CsjmEffects::none()`, the seed's campaign) with
/// CSJM diagnose's default options (FDR 0.05).
#[derive(Debug, Clone, Serialize)]
pub struct CsjmResult {
    /// Campaign seeds `first_seed .. first_seed + runs`.
    pub first_seed: u64,
    /// Runs.
    pub runs: usize,
    /// Runs with a defect finding (anything but `connection_term`, which is physically present
    /// under the pre-load).
    pub defect_finding: usize,
    /// Runs with `unexplained: true`.
    pub unexplained: usize,
    /// Runs with a defect finding or `unexplained`.
    pub alarm: usize,
    /// Runs naming `connection_term` (expected in almost every run).
    pub connection_term: usize,
    /// Defect labels and counts.
    pub verdicts: BTreeMap<String, usize>,
    /// The FDR CSJM diagnose states (its default).
    pub fdr: f64,
    /// Wall time, s.
    pub seconds: f64,
}

/// Runs the CSJM false-alarm cell.
pub fn run_csjm(first_seed: u64, runs: usize) -> Result<CsjmResult, StudyError> {
    use so3_stiffness::diagnose::{diagnose as csjm_diagnose, DiagnoseOptions as CsjmOptions};
    let start = Instant::now();
    let opts = CsjmOptions::default();
    let mut r = CsjmResult {
        first_seed,
        runs: 0,
        defect_finding: 0,
        unexplained: 0,
        alarm: 0,
        connection_term: 0,
        verdicts: BTreeMap::new(),
        fdr: opts.selection.fdr,
        seconds: 0.0,
    };
    for seed in first_seed..first_seed + runs as u64 {
        let c =
            simulate_campaign(&CsjmCampaignSpec::new(CsjmEffects::none(), seed)).map_err(|e| {
                StudyError::Simulate {
                    robot: "csjm prototype".into(),
                    seed,
                    message: e.to_string(),
                }
            })?;
        let d = csjm_diagnose(&c.dataset, &opts).map_err(|e| StudyError::Diagnose {
            robot: "csjm prototype".into(),
            seed,
            message: e.to_string(),
        })?;
        let defects = d.defect_effects();
        r.runs += 1;
        r.defect_finding += (!defects.is_empty()) as usize;
        r.unexplained += d.unexplained as usize;
        r.alarm += (!defects.is_empty() || d.unexplained) as usize;
        r.connection_term += d.names(so3_stiffness::diagnose::CONNECTION_TERM) as usize;
        for l in defects {
            *r.verdicts.entry(l.to_string()).or_insert(0) += 1;
        }
        if d.unexplained {
            *r.verdicts.entry("unexplained".into()).or_insert(0) += 1;
        }
    }
    r.seconds = start.elapsed().as_secs_f64();
    Ok(r)
}
