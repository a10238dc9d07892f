//! A virtual CSJM testbed for the diagnosis: the seed's experiment (a pre-loaded pose and load
//! increments applied one after another, in measurement order) on a simulator that carries
//! the effects the diagnosis looks for.
//!
//! # Effects (all off by default; physically parameterised)
//! - **Platform gravity left out of the recorded moments** ([`GravityRecording::Omitted`]):
//!   the platform weight (prototype: G = 4.82 N at ᴬr_G = (0, 0, 0.081) m, gravity along −z_B)
//!   acts, but the recorded moment is the sensor's alone (seed eq. 56 skipped).
//! - **Friction hysteresis in the cables** (`cable_friction` f_s, N): while cable s slides,
//!   its tension at the platform is offset by `f_s·sign(ċ_s)` (lengthening: the platform
//!   pulls harder against the routing). Each load step is solved with the sliding directions
//!   of the step itself (fixed-point iteration from the frictionless step, at most
//!   [`MAX_FRICTION_ITERATIONS`]); every cable is assumed to slip (no sticking). Loading and
//!   unloading then reach different poses under the same load: a hysteresis loop of width
//!   ≈ 2 × the friction moment `Jᵀ(f∘σ)`. Realistic f_s: 0.5–3 N for cables over guide holes
//!   at 50–100 N pre-tension.
//! - **Non-linear (stiffening) cables** (`cable_stiffening` k₂, N/m²): `t = k e + k₂ e²`, see
//!   [`CsjmSimulator::with_cable_stiffening`]. With the prototype's k ≈ 5.25 kN/m and
//!   e ≈ 15 mm at 80 N, k₂ = 1.75e5 N/m² doubles the tangent stiffness at the pre-tension.
//!
//! # Noise
//! As [`crate::identification::campaign`]: tracker ([`TrackerNoise`], σ_θ = 1.35e-4 rad per
//! axis) and F/T sensor ([`MomentNoise`], σ ≈ (0.032, 0.038, 0.032) N·m).

use nalgebra::{Rotation3, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::csjm::{CsjmSimulator, EquilibriumOptions, PointLoad, Stiffness, CABLES};
use crate::identification::campaign::{prototype_simulator, Recorder};
// Re-exported so that a campaign spec can be built from this module alone (e.g. by bindings).
pub use crate::identification::campaign::{
    CampaignSchedule, GravityRecording, LoadPattern, MomentNoise, TrackerNoise,
    MAX_PLAUSIBLE_INCREMENT,
};
use crate::identification::{CsjmDataset, CsjmMeasurement, IdentificationError};

/// Largest number of fixed-point iterations on the cables' sliding directions per load step.
pub const MAX_FRICTION_ITERATIONS: usize = 8;

/// The effects hidden in a simulated campaign.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct CsjmEffects {
    /// Platform weight: absent, acting and recorded (eq. 56 at the measured pose), or acting
    /// and omitted from the recorded moment.
    pub gravity: GravityRecording,
    /// Coulomb friction f_s of each cable in its routing, N (≥ 0).
    pub cable_friction: [f64; CABLES],
    /// Quadratic coefficient k₂ of each cable law t = k e + k₂ e², N/m² (≥ 0).
    pub cable_stiffening: [f64; CABLES],
}

impl Default for CsjmEffects {
    fn default() -> Self {
        CsjmEffects {
            gravity: GravityRecording::Absent,
            cable_friction: [0.0; CABLES],
            cable_stiffening: [0.0; CABLES],
        }
    }
}

impl CsjmEffects {
    /// No effect.
    pub fn none() -> Self {
        Self::default()
    }

    /// The prototype's weight acting but left out of the recorded moments.
    pub fn omitted_gravity(weight: PointLoad) -> Self {
        CsjmEffects {
            gravity: GravityRecording::Omitted(weight),
            ..Self::default()
        }
    }

    /// The same friction `f` (N) in every cable.
    pub fn friction(f: f64) -> Self {
        CsjmEffects {
            cable_friction: [f; CABLES],
            ..Self::default()
        }
    }

    /// The same stiffening `k2` (N/m²) in every cable.
    pub fn stiffening(k2: f64) -> Self {
        CsjmEffects {
            cable_stiffening: [k2; CABLES],
            ..Self::default()
        }
    }
}

/// Settings of a diagnosis campaign: its schedule (the same as an identification campaign's)
/// and the effects hidden in it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub struct CsjmCampaignSpec {
    /// The loads, the instruments and the seed.
    pub schedule: CampaignSchedule,
    /// Hidden effects.
    pub effects: CsjmEffects,
}

impl CsjmCampaignSpec {
    /// The default campaign with the given effects and seed.
    pub fn new(effects: CsjmEffects, seed: u64) -> Self {
        CsjmCampaignSpec {
            schedule: CampaignSchedule::with_seed(seed),
            effects,
        }
    }

    fn validate(&self) -> Result<(), IdentificationError> {
        self.schedule.validate()?;
        for (i, f) in self.effects.cable_friction.iter().enumerate() {
            if !(f.is_finite() && *f >= 0.0) {
                return Err(IdentificationError::InvalidSetting {
                    field: "cable_friction",
                    message: format!("cable {}: must be finite and ≥ 0 N, got {f}", i + 1),
                });
            }
        }
        Ok(())
    }
}

/// A simulated campaign and its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct CsjmCampaign {
    /// The measurement file's content: reference row plus one row per increment, in order.
    pub dataset: CsjmDataset,
    /// True reference pose R₀.
    pub true_r0: Rotation3<f64>,
    /// The cables' stiffness at R₀ (without the weight; `covariant` is the symmetric K).
    pub true_stiffness: Stiffness,
    /// Applied external moments, N·m, frame A, one per increment (noise-free).
    pub applied: Vec<Vector3<f64>>,
    /// True poses, one per increment.
    pub true_poses: Vec<Rotation3<f64>>,
    /// Sliding direction of each cable during each step (+1 lengthening, −1 shortening);
    /// all 0 without friction.
    pub sliding: Vec<[i8; CABLES]>,
}

/// The physics of a campaign: cables (possibly stiffening), friction and the weight.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectSimulator {
    cables: CsjmSimulator,
    friction: [f64; CABLES],
    weight: Option<PointLoad>,
}

/// Where a load path stands: the pose and the cables' last sliding directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathState {
    /// Current pose ᴮ_A R.
    pub pose: Rotation3<f64>,
    /// Last sliding direction of each cable (+1, −1, or 0 before any motion).
    pub sliding: [i8; CABLES],
}

impl PathState {
    /// At rest at `pose`, no sliding history.
    pub fn at(pose: Rotation3<f64>) -> Self {
        PathState {
            pose,
            sliding: [0; CABLES],
        }
    }
}

impl EffectSimulator {
    /// Cables (`cables` may already be stiffening), per-cable friction (N, ≥ 0) and an
    /// optional weight acting on the platform.
    pub fn new(
        cables: CsjmSimulator,
        friction: [f64; CABLES],
        weight: Option<PointLoad>,
    ) -> Result<Self, IdentificationError> {
        for (i, f) in friction.iter().enumerate() {
            if !(f.is_finite() && *f >= 0.0) {
                return Err(IdentificationError::InvalidSetting {
                    field: "cable_friction",
                    message: format!("cable {}: must be finite and ≥ 0 N, got {f}", i + 1),
                });
            }
        }
        Ok(EffectSimulator {
            cables,
            friction,
            weight,
        })
    }

    /// The cables alone (no friction offsets, no weight).
    pub fn cables(&self) -> &CsjmSimulator {
        &self.cables
    }

    /// The simulator with friction offsets `f_s σ_s` and the weight.
    fn with_sliding(&self, sliding: &[i8; CABLES]) -> Result<CsjmSimulator, crate::CsjmError> {
        let offsets = std::array::from_fn(|i| self.friction[i] * f64::from(sliding[i]));
        let sim = self.cables.clone().with_tension_offsets(offsets)?;
        Ok(match self.weight {
            Some(w) => sim.with_load(w),
            None => sim,
        })
    }

    /// Applies the external moment `load` (N·m, frame A) from `state` and returns the new
    /// state. Sliding directions are found by fixed-point iteration: solve, read the sign of
    /// each cable's length change from the previous pose, re-solve with those friction
    /// offsets, until the signs repeat (at most [`MAX_FRICTION_ITERATIONS`] solves; cables
    /// still flipping then are treated as sticking, with no offset). The returned `sliding`
    /// is the one the returned pose was solved with.
    pub fn apply(
        &self,
        state: &PathState,
        load: &Vector3<f64>,
    ) -> Result<PathState, crate::CsjmError> {
        let options = EquilibriumOptions::starting_at(state.pose);
        let frictionless = self.friction.iter().all(|f| *f == 0.0);
        let start_lengths = crate::csjm::cable_lengths(self.cables.geometry(), &state.pose)?;
        let mut sliding = [0i8; CABLES];
        let mut pose = state.pose;
        let direction = |pose: &Rotation3<f64>| -> Result<[i8; CABLES], crate::CsjmError> {
            let lengths = crate::csjm::cable_lengths(self.cables.geometry(), pose)?;
            Ok(std::array::from_fn(|i| {
                let dc = lengths[i] - start_lengths[i];
                if dc > 0.0 {
                    1
                } else if dc < 0.0 {
                    -1
                } else {
                    0
                }
            }))
        };
        for iteration in 0..MAX_FRICTION_ITERATIONS {
            pose = self
                .with_sliding(&sliding)?
                .equilibrium(load, &options)?
                .pose;
            if frictionless {
                break;
            }
            let next = direction(&pose)?;
            if next == sliding {
                break;
            }
            if iteration + 1 == MAX_FRICTION_ITERATIONS {
                // A cable whose direction keeps flipping sticks: it carries no friction
                // offset for this step (its friction force lies between −f_s and f_s).
                for i in 0..CABLES {
                    if next[i] != sliding[i] {
                        sliding[i] = 0;
                    }
                }
                pose = self
                    .with_sliding(&sliding)?
                    .equilibrium(load, &options)?
                    .pose;
                break;
            }
            sliding = next;
        }
        Ok(PathState { pose, sliding })
    }
}

/// Simulates a campaign on the seed prototype's cables
/// ([`prototype_simulator`]: 80 N per cable at home, unloaded K_xx = 30 N·m/rad) with the
/// hidden `spec.effects`.
///
/// ```
/// use so3_stiffness::testbed::{simulate_campaign, CsjmCampaignSpec, CsjmEffects};
/// let mut spec = CsjmCampaignSpec::new(CsjmEffects::friction(1.0), 3);
/// spec.schedule.increments = 10;
/// let campaign = simulate_campaign(&spec).unwrap();
/// assert_eq!(campaign.dataset.measurements().len(), 10);
/// ```
pub fn simulate_campaign(spec: &CsjmCampaignSpec) -> Result<CsjmCampaign, IdentificationError> {
    simulate_campaign_on(&prototype_simulator()?, spec)
}

/// [`simulate_campaign`] on other cables (a simulator of the cables alone, linear; the
/// stiffening of `spec.effects` is added keeping the tensions at the home pose).
pub fn simulate_campaign_on(
    cables: &CsjmSimulator,
    spec: &CsjmCampaignSpec,
) -> Result<CsjmCampaign, IdentificationError> {
    spec.validate()?;
    let sim_error = |index: usize| {
        move |e: crate::CsjmError| IdentificationError::Simulation {
            index,
            message: e.to_string(),
        }
    };
    let home = Rotation3::identity();
    let cables = if spec.effects.cable_stiffening.iter().any(|k| *k != 0.0) {
        cables
            .clone()
            .with_cable_stiffening(spec.effects.cable_stiffening, &home)
            .map_err(sim_error(0))?
    } else {
        cables.clone()
    };
    let weight = match spec.effects.gravity {
        GravityRecording::Absent => None,
        GravityRecording::Recorded(w) | GravityRecording::Omitted(w) => Some(w),
    };
    let physics = EffectSimulator::new(cables.clone(), spec.effects.cable_friction, weight)?;

    let mut rng = StdRng::seed_from_u64(spec.schedule.seed);
    // The reference: the pre-load applied from rest at home.
    let mut state = physics
        .apply(&PathState::at(home), &spec.schedule.preload)
        .map_err(sim_error(0))?;
    let true_r0 = state.pose;
    let true_stiffness = cables.stiffness(&true_r0).map_err(sim_error(0))?;

    let (lo, hi) = match spec.schedule.pattern {
        LoadPattern::OneSided => (-0.25, 1.0),
        _ => (-1.0, 1.0),
    };
    let per_axis = spec.schedule.max_increment / 3f64.sqrt();
    let applied: Vec<Vector3<f64>> = (0..spec.schedule.increments)
        .map(|_| {
            spec.schedule.preload + Vector3::from_fn(|_, _| rng.random_range(lo..=hi) * per_axis)
        })
        .collect();
    let mut true_poses = Vec::with_capacity(applied.len());
    let mut sliding = Vec::with_capacity(applied.len());
    for (index, load) in applied.iter().enumerate() {
        state = physics.apply(&state, load).map_err(sim_error(index + 1))?;
        true_poses.push(state.pose);
        sliding.push(state.sliding);
    }

    let recorder = Recorder::new(
        &spec.schedule.tracker,
        &spec.schedule.moment_noise,
        spec.effects.gravity,
    )?;
    let mut measure =
        |pose: &Rotation3<f64>, external: &Vector3<f64>| recorder.record(&mut rng, pose, external);
    let reference = measure(&true_r0, &spec.schedule.preload);
    let rows: Vec<CsjmMeasurement> = true_poses
        .iter()
        .zip(&applied)
        .map(|(p, t)| measure(p, t))
        .collect();
    Ok(CsjmCampaign {
        dataset: CsjmDataset::new(reference, rows)?,
        true_r0,
        true_stiffness,
        applied,
        true_poses,
        sliding,
    })
}
