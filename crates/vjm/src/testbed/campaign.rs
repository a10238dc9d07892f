//! Measurement campaigns: seeded poses within the joint limits and away from singularities,
//! several wrenches per pose, the true response, and instrument noise.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;
use stiffness_core::num::Short;

use super::effects::{ForceSensorNoise, TrackerNoise};
use super::kinematics::deflected_pose;
use super::truth::{Effect, RestUnderGravity, TrueModel};
use super::TestbedError;
use stiffness_core::{Monitor, Progress};

use crate::chain::SerialChain;
use crate::dataset::{Dataset, DatasetError, MAX_PLAUSIBLE_FORCE, MAX_PLAUSIBLE_MOMENT};
use crate::gravity::Gravity;
use crate::model::SpringAxis;

/// How to generate a campaign. Defaults: 40 poses × 4 wrenches, forces 10–80 N, moments up to
/// 3 N·m, a quarter of the poses held out, nominal instrument noise, a weightless arm.
///
/// Serialised (the `spec` of `truth.json`) with its fields by name; `gravity` is written as
/// `[gx, gy, gz]` (m/s², base frame) when set and left out for a weightless campaign, whose
/// serialised form is unchanged.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CampaignSpec {
    /// Number of configurations.
    pub n_poses: usize,
    /// Wrenches applied at each configuration.
    pub wrenches_per_pose: usize,
    /// Range of the force magnitude, N (uniform).
    pub force_range: (f64, f64),
    /// Largest moment magnitude, N·m (uniform in [0, max]).
    pub moment_max: f64,
    /// Fraction of the poses written with `set = test`.
    pub test_fraction: f64,
    /// Laser tracker noise.
    pub tracker: TrackerNoise,
    /// Force/torque sensor noise.
    pub force_sensor: ForceSensorNoise,
    /// Whether to add instrument noise at all.
    pub noise: bool,
    /// Poses stay this far inside each joint limit, rad.
    pub limit_margin: f64,
    /// Smallest accepted inverse condition number σ_min/σ_max of the actuated Jacobian
    /// `[J_lin; L·J_ang]` with L = 0.5 m (rejects poses near singularities).
    pub min_inverse_condition: f64,
    /// Smallest accepted tip height above the base, m (the robot does not push into its table).
    pub min_tip_height: f64,
    /// Seed of everything random; the same seed gives the same file.
    pub seed: u64,
    /// Gravity the campaign is measured under (base frame); `None` (the default): a weightless
    /// arm, unloaded = the rigid forward kinematics. With `Some(g)` every recorded displacement
    /// is the tip under load minus the tip unloaded, both under the arm's own weight (the
    /// chain's [`mass_model`](SerialChain::mass_model)): "unloaded" is the arm at rest under
    /// its weight, computed once per configuration, and the springs respond to the total
    /// torque, gravity's and the load's ([`TrueModel::rest_under_gravity`],
    /// [`TrueModel::displacement_under_gravity`]). Poses are drawn as without gravity (the
    /// same seed gives the same poses and wrenches).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Gravity>,
}

impl Default for CampaignSpec {
    fn default() -> Self {
        CampaignSpec {
            n_poses: 40,
            wrenches_per_pose: 4,
            force_range: (10.0, 80.0),
            moment_max: 3.0,
            test_fraction: 0.25,
            tracker: TrackerNoise::default(),
            force_sensor: ForceSensorNoise::default(),
            noise: true,
            limit_margin: 0.1,
            min_inverse_condition: 0.05,
            min_tip_height: 0.1,
            seed: 0,
            gravity: None,
        }
    }
}

/// A simulated campaign: the measurement file plus the hidden truth row by row.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// What the instruments recorded (with `pose` and `set` columns).
    pub dataset: Dataset<'static>,
    /// The wrench actually applied, base frame (N, N·m), per row.
    pub applied_wrench: Vec<[f64; 6]>,
    /// The true displacement before measurement effects and noise, base frame (m), per row.
    pub true_displacement: Vec<[f64; 3]>,
    /// Unloaded tip point, base frame (m), per row (under gravity: at rest under the arm's
    /// weight, see [`CampaignSpec::gravity`]).
    pub tip: Vec<[f64; 3]>,
}

/// Streams of the campaign RNG: the geometry (poses, wrenches) does not depend on whether
/// noise is drawn, so a noisy and a noise-free campaign with one seed share their poses.
fn stream(seed: u64, k: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(k);
    rng
}

pub(crate) fn check_truth(chain: &SerialChain, truth: &TrueModel) -> Result<(), TestbedError> {
    let n = chain.n_joints();
    if truth.compliance.len() != 3 * n {
        return Err(TestbedError::TruthSize {
            compliances: truth.compliance.len(),
            expected: 3 * n,
        });
    }
    if let Some(c) = truth
        .compliance
        .iter()
        .position(|c| !(c.is_finite() && *c >= 0.0))
    {
        // A negative compliance is an unstable spring: refused like a NaN, naming the spring.
        return Err(invalid(format!(
            "compliance of spring J{}{} must be finite and ≥ 0 rad/(N·m), got {}",
            c / 3 + 1,
            ["z", "x", "y"][c % 3],
            Short(truth.compliance[c])
        )));
    }
    for e in &truth.effects {
        if let Some(j) = check_effect(e)? {
            require(j < n, || {
                format!("effect at joint {} but the chain has {n} joints", j + 1)
            })?;
        }
    }
    Ok(())
}

/// An [`TestbedError::InvalidTruth`] saying `message`.
fn invalid(message: String) -> TestbedError {
    TestbedError::InvalidTruth { message }
}

/// `Ok` when `ok`, else [`TestbedError::InvalidTruth`] with the `message` built only then.
fn require(ok: bool, message: impl FnOnce() -> String) -> Result<(), TestbedError> {
    if ok {
        Ok(())
    } else {
        Err(invalid(message()))
    }
}

/// Whether `x` is a finite, non-negative number (a compliance, a lost motion, a σ).
fn finite_non_negative(x: f64) -> bool {
    x.is_finite() && x >= 0.0
}

/// Checks one effect's own parameters; returns the joint it sits at (0-based), if any, for the
/// caller to check against the chain.
fn check_effect(e: &Effect) -> Result<Option<usize>, TestbedError> {
    Ok(match e {
        Effect::JointTilt {
            joint,
            axis,
            compliance,
        } => {
            require(finite_non_negative(*compliance), || {
                format!(
                    "joint_tilt at joint {}: compliance must be finite and ≥ 0 rad/(N·m), got {}",
                    joint + 1,
                    Short(*compliance)
                )
            })?;
            require(*axis != SpringAxis::Z, || {
                format!(
                    "joint_tilt at joint {} has axis z; tilts are about x or y",
                    joint + 1
                )
            })?;
            Some(*joint)
        }
        Effect::LinkTranslation {
            joint, compliance, ..
        } => {
            require(finite_non_negative(*compliance), || {
                format!(
                    "link_translation after joint {}: compliance must be finite and ≥ 0 m/N, \
                     got {}",
                    joint + 1,
                    Short(*compliance)
                )
            })?;
            Some(*joint)
        }
        Effect::TorsionNonlinear { joint, spring } => {
            let ok = spring.k1 > 0.0
                && spring.k2 > 0.0
                && spring.k3 > 0.0
                && spring.t1 > 0.0
                && spring.t2 > spring.t1;
            require(ok, || {
                format!(
                    "harmonic-drive spring at joint {} needs k1, k2, k3 > 0 and 0 < t1 < t2",
                    joint + 1
                )
            })?;
            Some(*joint)
        }
        Effect::Backlash { joint, lost_motion } => {
            require(finite_non_negative(*lost_motion), || {
                format!(
                    "backlash at joint {} must be finite and ≥ 0, got {}",
                    joint + 1,
                    Short(*lost_motion)
                )
            })?;
            Some(*joint)
        }
        Effect::TorsionAngleDependent { joint, amplitude } => {
            require(amplitude.is_finite() && amplitude.abs() < 1.0, || {
                format!(
                    "joint_torsion_angle_dependent at joint {}: amplitude must be within \
                     (−1, 1) (the compliance c·(1 + amplitude·sin q) stays > 0), got {}",
                    joint + 1,
                    Short(*amplitude)
                )
            })?;
            Some(*joint)
        }
        Effect::MountCompliance {
            translation,
            rotation,
        } => {
            let ok = finite_non_negative(*translation) && finite_non_negative(*rotation);
            require(ok, || {
                format!(
                    "mount compliances must be finite and ≥ 0, got {} m/N and {} rad/(N·m)",
                    Short(*translation),
                    Short(*rotation)
                )
            })?;
            None
        }
        Effect::ToolAxialCompliance { compliance } => {
            require(finite_non_negative(*compliance), || {
                format!(
                    "tool axial compliance must be finite and ≥ 0, got {} m/N",
                    Short(*compliance)
                )
            })?;
            None
        }
        Effect::SensorCrosstalk { coupling } => {
            require(coupling.is_finite() && coupling.abs() <= 0.5, || {
                format!(
                    "sensor cross-talk coupling must be finite and within ±0.5, got {}",
                    Short(*coupling)
                )
            })?;
            None
        }
        Effect::PoseDrift { sigma } => {
            require(finite_non_negative(*sigma), || {
                format!(
                    "pose drift sigma must be finite and ≥ 0, got {}",
                    Short(*sigma)
                )
            })?;
            None
        }
        Effect::WrenchBias { bias } => {
            require(bias.iter().all(|b| b.is_finite()), || {
                format!("wrench_bias must be finite, got {bias:?}")
            })?;
            None
        }
        Effect::FrameMisalignment { rotation } => {
            require(rotation.iter().all(|r| r.is_finite()), || {
                format!("frame_misalignment rotation must be finite, got {rotation:?}")
            })?;
            None
        }
        _ => None,
    })
}

/// Inverse condition number of the actuated Jacobian `[J_lin; L·J_ang]`, L = 0.5 m.
pub fn inverse_condition(chain: &SerialChain, q: &[f64]) -> f64 {
    let n = chain.n_joints();
    // The testbed's own kinematics; the conditioning rule is the library's.
    let pose = deflected_pose(chain, q, &vec![0.0; 3 * n]);
    crate::kinematics::inverse_condition_of(DMatrix::from_fn(6, n, |r, c| {
        pose.jacobian[(r, 3 * c)]
    }))
}

/// Draws a campaign from `truth` on `chain` following `spec`.
///
/// ```
/// use vjm::testbed::{simulate, CampaignSpec, TrueModel};
/// let chain = vjm::SerialChain::bundled();
/// let spec = CampaignSpec { n_poses: 4, wrenches_per_pose: 2, seed: 7, ..Default::default() };
/// let campaign = simulate(&chain, &TrueModel::nominal(7), &spec)?;
/// assert_eq!(campaign.dataset.len(), 8);
/// # Ok::<(), vjm::testbed::TestbedError>(())
/// ```
pub fn simulate(
    chain: &SerialChain,
    truth: &TrueModel,
    spec: &CampaignSpec,
) -> Result<Campaign, TestbedError> {
    simulate_monitored(chain, truth, spec, &Monitor::none())
}

/// [`simulate`] under a [`Monitor`]: its token is polled per pose draw and every
/// [`CHECK_EVERY_ROWS`] simulated rows ([`TestbedError::Cancelled`]); progress is reported per
/// block of rows (stage `"simulate"`).
pub fn simulate_monitored(
    chain: &SerialChain,
    truth: &TrueModel,
    spec: &CampaignSpec,
    monitor: &Monitor<'_>,
) -> Result<Campaign, TestbedError> {
    check_truth(chain, truth)?;
    if spec.n_poses < 2 || spec.wrenches_per_pose == 0 {
        return Err(TestbedError::InvalidSpec {
            field: "n_poses/wrenches_per_pose",
            message: format!(
                "need at least 2 poses and 1 wrench per pose, got {} and {}",
                spec.n_poses, spec.wrenches_per_pose
            ),
        });
    }
    let (f_lo, f_hi) = spec.force_range;
    // The recorded loads must pass the same plausibility caps as a user's file.
    let ordered = f_lo >= 0.0 && f_hi >= f_lo && f_hi <= MAX_PLAUSIBLE_FORCE;
    let moment_ok = spec.moment_max >= 0.0 && spec.moment_max <= MAX_PLAUSIBLE_MOMENT;
    if !ordered || !moment_ok {
        return Err(TestbedError::InvalidSpec {
            field: "force_range/moment_max",
            message: format!(
                "force range ({f_lo}, {f_hi}) N and moment max {} N·m must be ordered, ≥ 0 and at \
                 most {MAX_PLAUSIBLE_FORCE} N and {MAX_PLAUSIBLE_MOMENT} N·m",
                spec.moment_max
            ),
        });
    }
    let n = chain.n_joints();
    let mut geo = stream(spec.seed, 0);
    let mut q_all: Vec<f64> = Vec::with_capacity(spec.n_poses * n);
    let mut attempts = 0usize;
    while q_all.len() < spec.n_poses * n {
        attempts += 1;
        monitor.check()?;
        if attempts > 2000 * spec.n_poses {
            return Err(TestbedError::NoPose { attempts });
        }
        let q: Vec<f64> = chain
            .limits()
            .iter()
            .map(|&(lo, hi)| {
                let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
                let (a, b) = (lo + spec.limit_margin, hi - spec.limit_margin);
                if b > a {
                    geo.random_range(a..b)
                } else {
                    0.5 * (lo + hi)
                }
            })
            .collect();
        let tip = deflected_pose(chain, &q, &vec![0.0; 3 * n]).tip;
        if tip.z < spec.min_tip_height || inverse_condition(chain, &q) < spec.min_inverse_condition
        {
            continue;
        }
        q_all.extend_from_slice(&q);
    }
    let mut q_rows = Vec::new();
    let mut wrenches = Vec::new();
    let mut poses = Vec::new();
    for p in 0..spec.n_poses {
        for _ in 0..spec.wrenches_per_pose {
            let fdir = unit(&mut geo);
            let mdir = unit(&mut geo);
            let fm = if f_hi > f_lo {
                geo.random_range(f_lo..f_hi)
            } else {
                f_lo
            };
            let mm = spec.moment_max * geo.random::<f64>();
            wrenches.push([
                fm * fdir[0],
                fm * fdir[1],
                fm * fdir[2],
                mm * mdir[0],
                mm * mdir[1],
                mm * mdir[2],
            ]);
            q_rows.extend_from_slice(&q_all[p * n..(p + 1) * n]);
            poses.push(p as i64);
        }
    }
    simulate_planned_monitored(chain, truth, &q_rows, &wrenches, &poses, spec, monitor)
}

/// Measures `truth` at planned rows — joint angles `q` (N×n, rad), applied wrenches (N·6, N and
/// N·m at the tip point, base frame), pose ids — as [`simulate`] measures its random ones: the
/// same noise and effects drawn from `spec.seed`, and whole poses held out (`set` column,
/// `spec.test_fraction`). `spec.n_poses`, `wrenches_per_pose`, the load ranges and the pose
/// filters are not used: the rows are the plan's (e.g. [`crate::design()`]'s).
///
/// ```
/// use vjm::testbed::{simulate_planned_monitored, CampaignSpec, TrueModel};
/// use stiffness_core::Monitor;
/// let chain = vjm::SerialChain::bundled();
/// let q = [0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.7].repeat(4);
/// let wrenches = [[20.0, 0.0, -30.0, 0.0, 1.0, 0.0], [0.0, 40.0, 0.0, 1.0, 0.0, 0.0]].repeat(2);
/// let poses = [0, 0, 1, 1];
/// let spec = CampaignSpec { seed: 3, ..Default::default() };
/// let campaign = simulate_planned_monitored(
///     &chain, &TrueModel::nominal(7), &q, &wrenches, &poses, &spec, &Monitor::none())?;
/// assert_eq!(campaign.dataset.len(), 4);
/// assert_eq!(campaign.applied_wrench[1], wrenches[1]);
/// # Ok::<(), vjm::testbed::TestbedError>(())
/// ```
pub fn simulate_planned_monitored(
    chain: &SerialChain,
    truth: &TrueModel,
    q: &[f64],
    wrenches: &[[f64; 6]],
    poses: &[i64],
    spec: &CampaignSpec,
    monitor: &Monitor<'_>,
) -> Result<Campaign, TestbedError> {
    let campaign = simulate_at_monitored(chain, truth, q, wrenches, poses, spec, monitor)?;
    // Hold out whole poses, reproducibly.
    let labels = campaign
        .dataset
        .split(spec.test_fraction, spec.seed)
        .map_err(TestbedError::Dataset)?;
    Ok(Campaign {
        dataset: campaign
            .dataset
            .with_set(labels)
            .map_err(TestbedError::Dataset)?,
        ..campaign
    })
}

fn unit(rng: &mut ChaCha8Rng) -> [f64; 3] {
    loop {
        let v: [f64; 3] = [
            StandardNormal.sample(rng),
            StandardNormal.sample(rng),
            StandardNormal.sample(rng),
        ];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 1e-6 {
            return [v[0] / n, v[1] / n, v[2] / n];
        }
    }
}

/// Simulates given rows: joint angles `q` (N×n, rad), applied wrenches (base frame), pose ids.
/// Noise (when `spec.noise`) and pose drift are drawn from `spec.seed`. The dataset has a `pose`
/// column and no `set` column.
pub fn simulate_at(
    chain: &SerialChain,
    truth: &TrueModel,
    q: &[f64],
    wrenches: &[[f64; 6]],
    poses: &[i64],
    spec: &CampaignSpec,
) -> Result<Campaign, TestbedError> {
    simulate_at_monitored(chain, truth, q, wrenches, poses, spec, &Monitor::none())
}

/// Rows simulated between two polls of the cancellation token (a few ms of work).
pub const CHECK_EVERY_ROWS: usize = 1024;

/// [`simulate_at`] under a [`Monitor`] (see [`simulate_monitored`]).
pub fn simulate_at_monitored(
    chain: &SerialChain,
    truth: &TrueModel,
    q: &[f64],
    wrenches: &[[f64; 6]],
    poses: &[i64],
    spec: &CampaignSpec,
    monitor: &Monitor<'_>,
) -> Result<Campaign, TestbedError> {
    check_truth(chain, truth)?;
    let n = chain.n_joints();
    let rows = wrenches.len();
    if q.len() != rows * n || poses.len() != rows {
        return Err(TestbedError::InvalidSpec {
            field: "q/wrenches/poses",
            message: format!(
                "{} joint values, {} wrenches and {} pose ids do not describe the same rows ({} joints)",
                q.len(),
                rows,
                poses.len(),
                n
            ),
        });
    }
    let mut noise_rng = stream(spec.seed, 1);
    let mut drift_rng = stream(spec.seed, 2);
    let drift_sigma = truth.pose_drift();
    let mut drift: std::collections::BTreeMap<i64, [f64; 3]> = Default::default();
    let fsig = spec.force_sensor.sigma();
    let mut disp = Vec::with_capacity(3 * rows);
    let mut wrec = Vec::with_capacity(6 * rows);
    let mut applied = Vec::with_capacity(rows);
    let mut true_d = Vec::with_capacity(rows);
    let mut tips = Vec::with_capacity(rows);
    if spec.gravity.is_some() {
        // A chain without masses fails here, once, naming the link without `<inertial>`.
        chain.mass_model().map_err(|e| TestbedError::Gravity {
            message: e.to_string(),
        })?;
    }
    // The rest under gravity of the last configuration: rows of one pose follow each other.
    let mut rest: Option<RestUnderGravity> = None;
    for i in 0..rows {
        if i % CHECK_EVERY_ROWS == 0 {
            monitor.report(Progress {
                stage: "simulate",
                done: i,
                total: rows,
            })?;
        }
        let qi = &q[i * n..(i + 1) * n];
        let (d, tip) = match &spec.gravity {
            None => truth.displacement(chain, qi, &wrenches[i]),
            Some(g) => {
                let at_row = |e: TestbedError| match e {
                    TestbedError::Gravity { message } => TestbedError::Gravity {
                        message: format!("row {} (pose {}): {message}", i + 1, poses[i]),
                    },
                    other => other,
                };
                let r = match rest.take() {
                    Some(r) if r.q() == qi => r,
                    _ => truth.rest_under_gravity(chain, qi, g).map_err(at_row)?,
                };
                let out = truth
                    .displacement_under_gravity(chain, qi, &wrenches[i], &r)
                    .map_err(at_row)?;
                rest = Some(r);
                out
            }
        };
        let (mut dm, mut wm) = truth.measured(d, wrenches[i]);
        if drift_sigma > 0.0 {
            let off = *drift.entry(poses[i]).or_insert_with(|| {
                let mut z = || -> f64 {
                    let v: f64 = StandardNormal.sample(&mut drift_rng);
                    drift_sigma * v
                };
                [z(), z(), z()]
            });
            for k in 0..3 {
                dm[k] += off[k];
            }
        }
        if spec.noise {
            let sd = spec.tracker.displacement_sigma([tip.x, tip.y, tip.z]);
            for v in dm.iter_mut() {
                let z: f64 = StandardNormal.sample(&mut noise_rng);
                *v += sd * z;
            }
            for (v, s) in wm.iter_mut().zip(fsig) {
                let z: f64 = StandardNormal.sample(&mut noise_rng);
                *v += s * z;
            }
        }
        disp.extend_from_slice(&dm);
        wrec.extend_from_slice(&wm);
        applied.push(wrenches[i]);
        true_d.push([d.x, d.y, d.z]);
        tips.push([tip.x, tip.y, tip.z]);
    }
    let dataset = Dataset::new(n, q.to_vec(), wrec, disp, None, Some(poses.to_vec()), None)
        .map_err(blame_the_simulation)?;
    Ok(Campaign {
        dataset,
        applied_wrench: applied,
        true_displacement: true_d,
        tip: tips,
    })
}

/// The dataset checks exist for users' files; when simulated data fail them the cause is the
/// simulation's own input (the true model, the loads), which the error must name instead of a
/// line and column of a file the user never wrote.
fn blame_the_simulation(e: DatasetError) -> TestbedError {
    match e {
        DatasetError::Implausible {
            line,
            column,
            value,
            limit,
            unit,
            ..
        } => TestbedError::InvalidTruth {
            message: format!(
                "the simulated {column} of row {} is {} {unit}, beyond the plausible {} \
                 {unit}: the true model's compliances or effects are implausibly large for these \
                 loads",
                line - 1,
                stiffness_core::num::Short(value),
                stiffness_core::num::Short(limit)
            ),
        },
        DatasetError::NonFinite { line, column, .. } => TestbedError::InvalidTruth {
            message: format!(
                "the simulation produced a non-finite {column} at row {} (a load beyond what the \
                 true model can carry?)",
                line - 1
            ),
        },
        DatasetError::NoDisplacement { .. } => TestbedError::InvalidTruth {
            message: "the true model produces no displacement at all (every compliance 0 and no \
                      noise)"
                .into(),
        },
        DatasetError::NoLoad { .. } => TestbedError::InvalidSpec {
            field: "force_range/moment_max",
            message: "every simulated load is zero".into(),
        },
        other => TestbedError::Dataset(other),
    }
}
