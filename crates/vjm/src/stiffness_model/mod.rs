//! The stiffness model file: what an identification learnt about a robot, saved so that it can
//! be used later (predict here, compensate and plan elsewhere) with the robot it describes.
//!
//! A [`StiffnessModel`] holds the robot it was identified on (URDF path and content hash, base,
//! tip, joints), the spring model, the identifiable combinations with their values, the
//! parameter vector used for prediction with its covariance, the null space (the directions
//! the data could not see), the noise model and where the data came from. It is built from an
//! [`Identification`] with [`StiffnessModel::from_identification`], written with
//! [`save`](StiffnessModel::save) and read with [`load`](StiffnessModel::load), which refuses a
//! file for another robot and a file edited after it was saved. The schema is documented field
//! by field in `docs/model-file.md`.
//!
//! Predictions ([`StiffnessModel::predict`]) use only what the data identified: the parameter
//! vector is the minimum-norm solution in the column-scaled coordinates of the design (see
//! [`EstimateRecord`]), so for any pose and load whose regressor lies in the row space of the
//! identification's design the prediction is the same whatever the aliased springs really
//! are. A row that excites a direction outside that space is flagged, not silently predicted.
//!
//! ```
//! use vjm::testbed::{simulate, CampaignSpec, TrueModel};
//! use vjm::{identify, DataSource, IdentifyOptions, Load, SerialChain, StiffnessModel, VirtualJointModel};
//! let chain = SerialChain::bundled();
//! let spec = CampaignSpec { n_poses: 10, noise: false, ..Default::default() };
//! let data = simulate(&chain, &TrueModel::nominal(7), &spec)?.dataset;
//! let (model, opts) = (VirtualJointModel::extended(7), IdentifyOptions::default());
//! let id = identify(&chain, &model, data.measurements(), &opts)?;
//! assert!(id.rank < 21); // the extended model aliases on the Panda
//! let sm = StiffnessModel::from_identification(&id, &chain, &model, &opts, DataSource::in_memory(data.len()))?
//!     .with_robust_covariance(&chain, data.measurements())?;
//! let text = sm.to_json();
//! let back = StiffnessModel::from_json(&text, "model.json")?;
//! back.check_robot(&chain, "model.json")?;
//! let p = back.predict(&chain, data.q(0), Load::Wrench(&data.wrench(0)))?;
//! let truth = data.displacement(0);
//! assert!(p[0].identified && (p[0].deflection[0] - truth[0]).abs() < 1e-9 * truth[0].abs().max(1e-6));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod columns;
mod error;
mod file;
mod gear_load;
mod output_table;
mod pose_table;
mod predict;
mod robust;
mod sag;
mod uncertainty;

use serde::{Deserialize, Serialize};
use stiffness_core::num::Short;

pub use columns::PredictionColumns;
pub use error::ModelError;
pub use file::{RecordedRobot, MODEL_SCHEMA};
pub use output_table::{
    status_from_name, CompensationTable, PredictionTable, SagColumns, COMPENSATION_COLUMNS,
    PREDICTION_COLUMNS, SAG_COLUMNS,
};
pub use pose_table::PoseTable;
pub use predict::{Load, PointMass, Prediction, GRAVITY, IDENTIFIED_TOL};
pub use robust::{COVARIANCE_MODEL, COVARIANCE_ROBUST};

use crate::chain::SerialChain;
use crate::gear::GearCurve;
use crate::gravity::Gravity;
use crate::hashing::{kinematics_sha256, sha256_hex_reader};
use crate::identify::{Identification, IdentifyOptions};
use crate::model::{Spring, VirtualJointModel};

/// The robot a model was identified on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct RobotRecord {
    /// The URDF path given when the chain was loaded, made absolute when the model was built
    /// (`bundled:panda_arm.urdf` for the bundled arm; older files may record a relative path,
    /// as given); where to find the robot (see [`StiffnessModel::recorded_robot`]), not what
    /// it is: a moved file with the same content still matches.
    pub urdf: Option<String>,
    /// SHA-256 of the URDF text (hex); `None` when the chain was not read from URDF text.
    pub urdf_sha256: Option<String>,
    /// Base link.
    pub base: String,
    /// Tip link; the tip point is its origin.
    pub tip: String,
    /// Actuated joints, base → tip.
    pub joint_names: Vec<String>,
    /// Number of actuated joints n.
    pub n_joints: usize,
    /// SHA-256 of the chain's kinematic parameters (see `docs/model-file.md`).
    pub kinematics_sha256: String,
}

/// The virtual springs (the parameters), in parameter order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct SpringRecord {
    /// `traditional`, `extended` or `custom`.
    pub model: String,
    /// Spring labels `J<joint><axis>`, 1-based joints, e.g. `J2x`.
    pub labels: Vec<String>,
    /// Per joint: centre of its springs in the joint's child frame, m.
    pub offsets: Vec<[f64; 3]>,
}

/// One term of an identifiable combination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct TermRecord {
    /// Spring label.
    pub spring: String,
    /// Coefficient (dimensionless).
    pub coefficient: f64,
}

/// An identifiable combination of compliances (a base parameter) and its estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct CombinationRecord {
    /// Human-readable form, e.g. `J1y + 1.000000*J2z`.
    pub label: String,
    /// Terms; the first is the independent spring with coefficient 1.
    pub terms: Vec<TermRecord>,
    /// Estimate, rad/(N·m).
    pub value: f64,
    /// Standard error, rad/(N·m); `None` when no noise scale was available.
    pub stderr: Option<f64>,
}

/// What the identification found (for reading; predictions use [`EstimateRecord`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct IdentificationRecord {
    /// Number of parameters m.
    pub n_params: usize,
    /// Numerical rank r: the number of identifiable combinations.
    pub rank: usize,
    /// Scalar equations used (3 or 6 per measurement).
    pub n_equations: usize,
    /// Reduction used: `normal_equations` or `qr`.
    pub method: String,
    /// The r identifiable combinations.
    pub combinations: Vec<CombinationRecord>,
    /// Groups of springs that alias each other.
    pub aliases: Vec<Vec<String>>,
    /// Singular values of the column-scaled, whitened design, descending.
    pub singular_values: Vec<f64>,
    /// σ₁/σ_r of the column-scaled design; `None` when the rank is 0.
    pub condition_number: Option<f64>,
    /// RMS of the whitened residuals (≈ 1 when the noise model is right).
    pub residual_rms: f64,
}

/// The parameter vector used for prediction and what is known about it.
///
/// `compliance` is the minimum-norm least-squares solution in the column-scaled coordinates
/// y = S·x (S = diag(`column_scale`)): of all compliance vectors that fit the data equally
/// well (they differ by null-space vectors) it is the one with y orthogonal to the null space.
/// Its entries for aliased springs are therefore not estimates of those springs, but any
/// prediction aᵀx with a in the row space of the design is: it equals aᵀx_true up to the
/// noise, whichever member of the family is stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct EstimateRecord {
    /// Parameter vector x (m values, rad/(N·m)).
    pub compliance: Vec<f64>,
    /// Covariance of x, m×m rows, (rad/(N·m))²: σ²·S⁻¹(A_sᵀA_s)⁺S⁻¹, meaningful on the row
    /// space only; `None` when no noise scale was available (no degrees of freedom).
    pub covariance: Option<Vec<Vec<f64>>>,
    /// How `covariance` was obtained: `model` — σ²(AᵀA)⁺ of the identification, which assumes
    /// independent noise of the assumed relative sizes on every equation; `robust` — the
    /// cluster-robust sandwich over measurements (see
    /// [`StiffnessModel::with_robust_covariance`]), valid for any noise correlation within a
    /// measurement (the force sensor's error makes it so).
    pub covariance_method: String,
    /// Column norms S of the whitened design (‖A e_k‖), the metric of the rank decisions.
    pub column_scale: Vec<f64>,
    /// Null-space basis in parameter units, m − r vectors of m values: N = S⁻¹V₀ with V₀
    /// orthonormal. Directions of x the data could not see.
    pub null_space: Vec<Vec<f64>>,
    /// A prediction row a is identified when ‖aᵀN‖ ≤ `identified_tol`·‖S⁻¹a‖ (the sine of the
    /// angle between the scaled row and the identified row space).
    pub identified_tol: f64,
}

/// The noise model of the identification and the options that shaped it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct NoiseRecord {
    /// Assumed per-axis standard deviations `[dx, dy, dz, rx, ry, rz]` (m, rad) used to
    /// whiten the rows.
    pub noise_sigma: [f64; 6],
    /// `true`: `noise_sigma` were the true standard deviations (σ² = 1).
    pub noise_scale_known: bool,
    /// σ² of the whitened residuals used for the covariance: the variance of a new
    /// measurement's axis k is `σ²·noise_sigma[k]²` under this model. `None` when unknown.
    pub sigma2: Option<f64>,
    /// Degrees of freedom, equations − rank.
    pub dof: usize,
    /// Whether measured rotations were used (6 rows per measurement); without them the
    /// model does not predict rotations.
    pub use_rotations: bool,
    /// Whether compliances were constrained to be ≥ 0 (then `compliance` is the NNLS
    /// solution and the covariance is the unconstrained one).
    pub nonnegative: bool,
}

/// Where the identification data came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct DataSource {
    /// Number of measurement rows used.
    pub rows: usize,
    /// The measurement file as given, when the data came from a file.
    pub file: Option<String>,
    /// SHA-256 of that file's bytes.
    pub sha256: Option<String>,
}

impl DataSource {
    /// Data given in memory (no file).
    pub fn in_memory(rows: usize) -> Self {
        DataSource {
            rows,
            file: None,
            sha256: None,
        }
    }

    /// Data read from `path` (`rows` rows used); the file is hashed now.
    pub fn file(path: impl AsRef<std::path::Path>, rows: usize) -> Result<Self, ModelError> {
        let path = path.as_ref();
        let read = |source| ModelError::Read {
            path: path.display().to_string(),
            source,
        };
        let sha256 = sha256_hex_reader(std::fs::File::open(path).map_err(read)?).map_err(read)?;
        DataSource::file_with_sha256(path, rows, sha256)
    }

    /// Data read from `path` whose bytes the reader hashed as it read them
    /// ([`Dataset::read_csv_with_sha256`](crate::dataset::Dataset::read_csv_with_sha256)):
    /// `sha256` (64 lowercase hex digits, else an error) is recorded as given, the file is
    /// not read again.
    pub fn file_with_sha256(
        path: impl AsRef<std::path::Path>,
        rows: usize,
        sha256: String,
    ) -> Result<Self, ModelError> {
        let hex = |c: u8| c.is_ascii_digit() || (b'a'..=b'f').contains(&c);
        if sha256.len() != 64 || !sha256.bytes().all(hex) {
            return Err(ModelError::Mismatch {
                message: format!(
                    "the data file's SHA-256 must be 64 lowercase hex digits, got {sha256:?}"
                ),
            });
        }
        Ok(DataSource {
            rows,
            file: Some(path.as_ref().display().to_string()),
            sha256: Some(sha256),
        })
    }
}

/// A saved stiffness model: see the [module documentation](self).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StiffnessModel {
    robot: RobotRecord,
    springs: SpringRecord,
    identification: IdentificationRecord,
    estimate: EstimateRecord,
    noise: NoiseRecord,
    data: DataSource,
    /// The gravity the model was identified under, `[gx, gy, gz]` m/s² in the base frame
    /// ([`IdentifyOptions::gravity`]); absent for a weightless model (so a weightless model's
    /// file, and its content hash, are those written before gravity was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    gravity: Option<[f64; 3]>,
    /// [`inertials_sha256`](crate::inertials_sha256) of the chain identified under gravity
    /// (its masses and centres of mass); absent for a weightless model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    inertials_sha256: Option<String>,
    /// Non-linear gears ([`GearCurveRecord`]); absent when there is none (so a model without
    /// curves writes, and hashes, what earlier versions wrote).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    gear_curves: Vec<GearCurveRecord>,
    /// The program that wrote the file, e.g. `robot-stiffness 0.1.0`.
    created_by: String,
}

/// Unit of [`GearCurveRecord::knots`].
pub const GEAR_KNOT_UNIT: &str = "N·m";
/// Unit of [`GearCurveRecord::coefficients`].
pub const GEAR_COEFFICIENT_UNIT: &str = "rad/(N·m)";

/// One joint's gear curve in the file ([`crate::gear::GearCurve`]): its torsion spring
/// deflects by `θ(T) = c·T + Σ_k a_k h_k(T) + ½ b·sign(T)` under a total torque T.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct GearCurveRecord {
    /// The joint, 1-based (its torsion spring `J<joint>z` must be in the model).
    pub joint: usize,
    /// Knots t_k, N·m, ≥ 0.
    pub knots: Vec<f64>,
    /// Coefficients a_k, rad/(N·m): the tangent compliance's change beyond each knot.
    pub coefficients: Vec<f64>,
    /// [`GEAR_KNOT_UNIT`].
    pub knot_unit: String,
    /// [`GEAR_COEFFICIENT_UNIT`].
    pub coefficient_unit: String,
    /// The lost motion b, rad, finite and > 0 (the gear's backlash, the width of its dead
    /// band); absent for a gear without lost motion (so a curve without it writes, and hashes,
    /// what earlier versions wrote).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lost_motion_rad: Option<f64>,
}

impl StiffnessModel {
    /// The model of identification `id`, obtained with `identify(chain, model, …, opts)` from
    /// the data described by `data`.
    pub fn from_identification(
        id: &Identification,
        chain: &SerialChain,
        model: &VirtualJointModel,
        opts: &IdentifyOptions,
        data: DataSource,
    ) -> Result<Self, ModelError> {
        model.check_chain(chain)?;
        let sol = &id.solution;
        let m = model.n_params();
        if id.n_params != m || sol.solution.len() != m || sol.column_scale.len() != m {
            return Err(ModelError::Mismatch {
                message: format!(
                    "the identification has {} parameters but the spring model `{}` has {m}",
                    id.n_params,
                    model.name()
                ),
            });
        }
        if sol.covariance.len() != m * m || sol.null_space.len() != m - sol.rank {
            return Err(ModelError::Mismatch {
                message: "the identification carries no covariance or null space".into(),
            });
        }
        let labels = model.labels();
        let robot = robot_record(chain);
        let springs = SpringRecord {
            model: model.name().to_string(),
            labels: labels.clone(),
            offsets: model.offsets().iter().map(|o| [o.x, o.y, o.z]).collect(),
        };
        let combinations = id
            .combinations
            .iter()
            .map(|c| CombinationRecord {
                label: c.label.clone(),
                terms: c
                    .terms
                    .iter()
                    .map(|t| TermRecord {
                        spring: labels[t.param].clone(),
                        coefficient: t.coefficient,
                    })
                    .collect(),
                value: c.value,
                stderr: c.stderr,
            })
            .collect();
        let identification = IdentificationRecord {
            n_params: m,
            rank: id.rank,
            n_equations: id.n_equations,
            method: match id.method {
                crate::SolveMethod::Qr => "qr",
                _ => "normal_equations",
            }
            .into(),
            combinations,
            aliases: id.alias_labels.clone(),
            singular_values: id.singular_values.clone(),
            condition_number: id
                .condition_number
                .is_finite()
                .then_some(id.condition_number),
            residual_rms: id.residual_rms,
        };
        let estimate = EstimateRecord {
            compliance: sol.solution.clone(),
            covariance: sol
                .sigma2
                .map(|_| sol.covariance.chunks(m).map(|r| r.to_vec()).collect()),
            covariance_method: robust::COVARIANCE_MODEL.to_string(),
            column_scale: sol.column_scale.clone(),
            null_space: sol.null_space.clone(),
            identified_tol: IDENTIFIED_TOL,
        };
        let noise = NoiseRecord {
            noise_sigma: opts.noise_sigma,
            noise_scale_known: opts.noise_scale_known,
            sigma2: sol.sigma2,
            dof: sol.dof,
            use_rotations: opts.use_rotations,
            nonnegative: opts.nonnegative,
        };
        // A model identified under gravity assumed the chain's masses: recorded, so that it is
        // not used with other ones.
        let inertials_sha256 = opts
            .gravity
            .map(|_| crate::hashing::inertials_sha256(chain))
            .transpose()?;
        let out = StiffnessModel {
            robot,
            springs,
            identification,
            estimate,
            noise,
            data,
            gravity: opts.gravity.map(|g| g.vector().into()),
            inertials_sha256,
            gear_curves: Vec::new(),
            created_by: format!("robot-stiffness {}", env!("CARGO_PKG_VERSION")),
        };
        out.validate()
            .map_err(|message| ModelError::Mismatch { message })?;
        Ok(out)
    }

    /// The robot the model was identified on.
    pub fn robot(&self) -> &RobotRecord {
        &self.robot
    }
    /// The springs (parameters).
    pub fn springs(&self) -> &SpringRecord {
        &self.springs
    }
    /// What the identification found: rank, combinations, aliases.
    pub fn identification(&self) -> &IdentificationRecord {
        &self.identification
    }
    /// The parameter vector used for prediction, its covariance and null space.
    pub fn estimate(&self) -> &EstimateRecord {
        &self.estimate
    }

    /// What the data determine: [`EstimateRecord::compliance`] without its weak directions
    /// ([`stiffness_core::lsq::WeakDirections`]: a standard error above the direction's
    /// magnitude or above [`MAX_PLAUSIBLE_COMPLIANCE`](crate::screening::MAX_PLAUSIBLE_COMPLIANCE)).
    /// The compliance every prediction and compensation uses; the covariance (and so each
    /// prediction's standard deviation) stays the identification's. Equal to the stored vector
    /// when the data determine every direction, or when the model has no covariance.
    pub fn determined_compliance(&self) -> Result<Vec<f64>, ModelError> {
        let e = &self.estimate;
        let covariance: Vec<f64> = e.covariance.iter().flatten().flatten().copied().collect();
        let weak = stiffness_core::lsq::WeakDirections::of(
            &e.compliance,
            &covariance,
            &e.column_scale,
            crate::screening::MAX_PLAUSIBLE_COMPLIANCE,
        )
        .map_err(|err| ModelError::Mismatch {
            message: format!("the model's covariance: {err}"),
        })?;
        Ok(weak.determined(&e.compliance))
    }
    /// The noise model.
    pub fn noise(&self) -> &NoiseRecord {
        &self.noise
    }
    /// Where the data came from.
    pub fn data(&self) -> &DataSource {
        &self.data
    }
    /// The program that wrote the model.
    pub fn created_by(&self) -> &str {
        &self.created_by
    }
    /// The gravity the model was identified under (base frame), `None` for a weightless
    /// model (also every file written before gravity was recorded).
    pub fn gravity(&self) -> Option<Gravity> {
        // Validated finite when built or loaded, so `Gravity::new` cannot fail.
        self.gravity.and_then(|g| Gravity::new(g).ok())
    }
    /// SHA-256 of the chain's masses the model was identified with
    /// ([`inertials_sha256`](crate::inertials_sha256)); `None` for a weightless model.
    pub fn inertials_sha256(&self) -> Option<&str> {
        self.inertials_sha256.as_deref()
    }
    /// The model's non-linear gears (none for a model without curves).
    pub fn gear_curves(&self) -> Result<Vec<GearCurve>, ModelError> {
        self.gear_curves
            .iter()
            .enumerate()
            .map(|(i, r)| gear_curve(i, r, self.robot.n_joints))
            .collect::<Result<_, String>>()
            .map_err(|message| ModelError::Mismatch { message })
    }

    /// This model with the gear curves `curves` (replacing any it had); an error names a curve
    /// whose joint has no torsion spring in the model.
    pub fn with_gear_curves(mut self, curves: &[GearCurve]) -> Result<Self, ModelError> {
        self.gear_curves = curves
            .iter()
            .map(|c| GearCurveRecord {
                joint: c.joint() + 1,
                knots: c.knots().to_vec(),
                coefficients: c.coefficients().to_vec(),
                knot_unit: GEAR_KNOT_UNIT.into(),
                coefficient_unit: GEAR_COEFFICIENT_UNIT.into(),
                lost_motion_rad: (c.lost_motion() != 0.0).then_some(c.lost_motion()),
            })
            .collect();
        self.validate()
            .map_err(|message| ModelError::Mismatch { message })?;
        Ok(self)
    }

    /// Whether the model predicts rotations (it was identified with measured rotations).
    pub fn has_rotations(&self) -> bool {
        self.noise.use_rotations
    }

    /// The spring model as a [`VirtualJointModel`] (parameter order of the file).
    pub fn spring_model(&self) -> Result<VirtualJointModel, ModelError> {
        let n = self.robot.n_joints;
        let springs = self
            .springs
            .labels
            .iter()
            .map(|l| parse_label(l))
            .collect::<Result<Vec<Spring>, String>>()
            .map_err(|message| ModelError::Mismatch { message })?;
        let base = match self.springs.model.as_str() {
            "traditional" if springs == VirtualJointModel::traditional(n).springs() => {
                VirtualJointModel::traditional(n)
            }
            "extended" if springs == VirtualJointModel::extended(n).springs() => {
                VirtualJointModel::extended(n)
            }
            "full" if springs == VirtualJointModel::full(n).springs() => VirtualJointModel::full(n),
            _ => VirtualJointModel::from_springs(n, springs)?,
        };
        let offsets = self
            .springs
            .offsets
            .iter()
            .map(|o| nalgebra::Vector3::new(o[0], o[1], o[2]))
            .collect();
        Ok(base.with_offsets(offsets)?)
    }

    /// Checks that `chain` is the robot of this model: joint count, base and tip links, joint
    /// names, URDF content hash (when both sides have one) and kinematic parameters.
    /// `path` names the model in the error (the file, or `<model>`).
    pub fn check_robot(&self, chain: &SerialChain, path: &str) -> Result<(), ModelError> {
        let r = &self.robot;
        let other = |what: &'static str, in_file: String, given: String| {
            Err(ModelError::OtherRobot {
                path: path.to_string(),
                what,
                in_file,
                given,
            })
        };
        if r.n_joints != chain.n_joints() {
            return other(
                "the joint count",
                r.n_joints.to_string(),
                chain.n_joints().to_string(),
            );
        }
        if r.base != chain.base_link() {
            return other("the base link", r.base.clone(), chain.base_link().into());
        }
        if r.tip != chain.tip_link() {
            return other("the tip link", r.tip.clone(), chain.tip_link().into());
        }
        if r.joint_names != chain.joint_names() {
            return other(
                "the joint list",
                r.joint_names.join(","),
                chain.joint_names().join(","),
            );
        }
        if let (Some(stored), Some(source)) = (&r.urdf_sha256, chain.urdf_source()) {
            // The bundled URDF gained inertials (for gravity) with its kinematics unchanged: a
            // model saved against an earlier revision of it still names the same arm (the
            // kinematics hash below still has to match).
            let earlier_bundled = r.urdf.as_deref() == Some(crate::BUNDLED_URDF_PATH)
                && source.path.as_deref() == Some(crate::BUNDLED_URDF_PATH)
                && crate::chain::BUNDLED_URDF_EARLIER_SHA256.contains(&stored.as_str());
            if *stored != source.sha256 && !earlier_bundled {
                return other(
                    "the URDF content (SHA-256)",
                    format!("{} ({})", short(stored), r.urdf.as_deref().unwrap_or("?")),
                    format!(
                        "{} ({})",
                        short(&source.sha256),
                        source.path.as_deref().unwrap_or("URDF text")
                    ),
                );
            }
        }
        let k = kinematics_sha256(chain);
        if r.kinematics_sha256 != k {
            return other(
                "the kinematics (SHA-256 of joint origins and axes)",
                short(&r.kinematics_sha256).into(),
                short(&k).into(),
            );
        }
        if let Some(stored) = &self.inertials_sha256 {
            // Identified under gravity: the springs were fitted about the sag these masses
            // cause, so other masses would give other springs.
            let what = "the inertials (SHA-256 of the link masses and centres of mass)";
            match crate::hashing::inertials_sha256(chain) {
                Ok(given) if given == *stored => {}
                Ok(given) => return other(what, short(stored).into(), short(&given).into()),
                Err(e) => return other(what, short(stored).into(), format!("unknown ({e})")),
            }
        }
        Ok(())
    }

    /// The values that cannot be negative, zero or lopsided, named by their path in the file
    /// (`estimate.covariance[2][2]`) with the value.
    fn validate_values(&self) -> Result<(), String> {
        let e = &self.estimate;
        let id = &self.identification;
        let bad = |field: String, v: f64, must: &str| {
            Err(format!("{field} is {}, it must be {must}", Short(v)))
        };
        // `x` finite and ≥ 0 (> 0 when `strict`).
        let non_negative = |field: &dyn Fn() -> String, x: f64, strict: bool| {
            if x.is_finite() && (x > 0.0 || (!strict && x == 0.0)) {
                Ok(())
            } else {
                bad(
                    field(),
                    x,
                    if strict {
                        "finite and > 0"
                    } else {
                        "finite and ≥ 0"
                    },
                )
            }
        };
        let all_non_negative = |field: &str, v: &[f64], strict: bool| {
            v.iter()
                .enumerate()
                .try_for_each(|(i, &x)| non_negative(&|| format!("{field}[{i}]"), x, strict))
        };
        // Whitening divides by them; identification refuses σ ≤ 0.
        all_non_negative("noise.noise_sigma", &self.noise.noise_sigma, true)?;
        if let Some(s2) = self.noise.sigma2 {
            non_negative(&|| "noise.sigma2".into(), s2, false)?;
        }
        // Prediction divides by the column scales (a zero column is stored as 1).
        all_non_negative("estimate.column_scale", &e.column_scale, true)?;
        all_non_negative("identification.singular_values", &id.singular_values, false)?;
        non_negative(
            &|| "identification.residual_rms".into(),
            id.residual_rms,
            false,
        )?;
        if let Some(c) = id.condition_number {
            if !(c.is_finite() && c >= 1.0) {
                return bad(
                    "identification.condition_number".into(),
                    c,
                    "finite and ≥ 1",
                );
            }
        }
        for (k, c) in id.combinations.iter().enumerate() {
            let field = format!("identification.combinations[{k}]");
            if !c.value.is_finite() {
                return bad(format!("{field}.value"), c.value, "finite");
            }
            if let Some(se) = c.stderr {
                non_negative(&|| format!("{field}.stderr"), se, false)?;
            }
            if let Some((t, term)) = c
                .terms
                .iter()
                .enumerate()
                .find(|(_, t)| !t.coefficient.is_finite())
            {
                return bad(
                    format!("{field}.terms[{t}].coefficient"),
                    term.coefficient,
                    "finite",
                );
            }
        }
        for (j, o) in self.springs.offsets.iter().enumerate() {
            if let Some(k) = o.iter().position(|x| !x.is_finite()) {
                return bad(format!("springs.offsets[{j}][{k}]"), o[k], "finite");
            }
        }
        if let Some(g) = &self.gravity {
            if let Some(k) = g.iter().position(|x| !x.is_finite()) {
                return bad(format!("gravity[{k}]"), g[k], "finite (m/s²)");
            }
        }
        match (&self.gravity, &self.inertials_sha256) {
            (None, None) => {}
            (Some(_), Some(h))
                if h.len() == 64
                    && h.bytes()
                        .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)) => {}
            (Some(_), Some(h)) => {
                // By characters: the text is not known to be ASCII here.
                return Err(format!(
                    "inertials_sha256 `{}` is not a SHA-256 (64 lowercase hex digits)",
                    h.chars().take(16).collect::<String>()
                ));
            }
            (Some(_), None) => {
                return Err(
                    "gravity is set but inertials_sha256 is missing: a model identified \
                            under gravity records the masses it assumed"
                        .into(),
                )
            }
            (None, Some(_)) => {
                return Err(
                    "inertials_sha256 is set but gravity is not: a weightless model \
                            records no masses"
                        .into(),
                )
            }
        }
        if let Some(c) = &e.covariance {
            // Non-finite entries were refused with the shapes, so `< 0` catches every bad one.
            for (i, row) in c.iter().enumerate() {
                if row[i] < 0.0 {
                    return bad(
                        format!("estimate.covariance[{i}][{i}]"),
                        row[i],
                        "≥ 0 (a variance)",
                    );
                }
            }
            // Symmetric up to rounding: the tolerance is relative to the entry and to the
            // variances it lies between (a covariance entry is at most √(cᵢᵢ·cⱼⱼ)).
            for i in 0..c.len() {
                for j in i + 1..c.len() {
                    let (a, b) = (c[i][j], c[j][i]);
                    let scale = a.abs().max(b.abs()).max((c[i][i] * c[j][j]).sqrt());
                    if (a - b).abs() > 1e-6 * scale {
                        return Err(format!(
                            "estimate.covariance is not symmetric: [{i}][{j}] is {} but \
                             [{j}][{i}] is {}",
                            Short(a),
                            Short(b)
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Internal consistency of the sizes and values (a file that passes its hash check was
    /// written by this code, but a hand-made one may not have been).
    fn validate(&self) -> Result<(), String> {
        let n = self.robot.n_joints;
        let m = self.springs.labels.len();
        let e = &self.estimate;
        let id = &self.identification;
        let finite = |what: &str, v: &[f64]| match v.iter().position(|x| !x.is_finite()) {
            Some(i) => Err(format!("{what}[{i}] is not finite")),
            None => Ok(()),
        };
        if self.robot.joint_names.len() != n || self.springs.offsets.len() != n {
            return Err(format!(
                "robot.n_joints is {n} but there are {} joint names and {} spring offsets",
                self.robot.joint_names.len(),
                self.springs.offsets.len()
            ));
        }
        if m == 0 || id.n_params != m || e.compliance.len() != m || e.column_scale.len() != m {
            return Err(format!(
                "{m} spring labels, identification.n_params {}, {} compliances and {} column scales",
                id.n_params,
                e.compliance.len(),
                e.column_scale.len()
            ));
        }
        if id.rank > m || e.null_space.len() != m - id.rank || id.combinations.len() != id.rank {
            return Err(format!(
                "rank {} of {m} parameters needs {} null-space vectors and {} combinations, found {} and {}",
                id.rank,
                m.saturating_sub(id.rank),
                id.rank,
                e.null_space.len(),
                id.combinations.len()
            ));
        }
        if let Some(v) = e.null_space.iter().position(|v| v.len() != m) {
            return Err(format!("null_space[{v}] does not have {m} values"));
        }
        if let Some(c) = &e.covariance {
            if c.len() != m || c.iter().any(|r| r.len() != m) {
                return Err(format!("covariance is not {m}×{m}"));
            }
            for (i, row) in c.iter().enumerate() {
                finite(&format!("covariance[{i}]"), row)?;
            }
        }
        finite("estimate.compliance", &e.compliance)?;
        for (i, v) in e.null_space.iter().enumerate() {
            finite(&format!("null_space[{i}]"), v)?;
        }
        // A file whose hash was recomputed after an edit passes the hash check, so what the
        // predictions rely on is checked for being possible at all: variances, scales and
        // noise levels (a negative variance gave sd = 0, a negative σ a negative stddev).
        self.validate_values()?;
        if e.covariance_method != robust::COVARIANCE_MODEL
            && e.covariance_method != robust::COVARIANCE_ROBUST
        {
            return Err(format!(
                "covariance_method must be `model` or `robust`, got `{}`",
                e.covariance_method
            ));
        }
        if !(e.identified_tol > 0.0 && e.identified_tol < 1.0) {
            return Err(format!(
                "identified_tol must be in (0, 1), got {}",
                Short(e.identified_tol)
            ));
        }
        let model = self.spring_model().map_err(|e| e.to_string())?;
        let curves = self
            .gear_curves
            .iter()
            .enumerate()
            .map(|(i, r)| gear_curve(i, r, n))
            .collect::<Result<Vec<_>, String>>()?;
        crate::gear::torsion_springs(&model, &curves).map_err(|e| format!("gear_curves: {e}"))?;
        Ok(())
    }
}

/// Record `i` of `gear_curves` as a [`GearCurve`] of a chain of `n` joints; an error names the
/// field (`gear_curves[0].knots`) and the joint.
fn gear_curve(i: usize, r: &GearCurveRecord, n: usize) -> Result<GearCurve, String> {
    let field = format!("gear_curves[{i}]");
    if r.joint == 0 || r.joint > n {
        return Err(format!(
            "{field}.joint is {}, it must be a joint 1..={n}",
            r.joint
        ));
    }
    for (name, unit, want) in [
        ("knot_unit", &r.knot_unit, GEAR_KNOT_UNIT),
        (
            "coefficient_unit",
            &r.coefficient_unit,
            GEAR_COEFFICIENT_UNIT,
        ),
    ] {
        if unit != want {
            return Err(format!(
                "{field}.{name} is `{unit}` (joint {}), it must be `{want}`",
                r.joint
            ));
        }
    }
    let lost_motion = match r.lost_motion_rad {
        None => 0.0,
        // Written only when > 0: a 0 in the file would be a second spelling of "none".
        Some(b) if b.is_finite() && b > 0.0 => b,
        Some(b) => {
            return Err(format!(
                "{field}.lost_motion_rad is {b} (joint {}), it must be finite and > 0 rad \
                 (absent for none)",
                r.joint
            ))
        }
    };
    GearCurve::with_lost_motion(
        r.joint - 1,
        r.knots.clone(),
        r.coefficients.clone(),
        lost_motion,
    )
    .map_err(|e| format!("{field} (knots, coefficients, lost_motion_rad): {e}"))
}

fn robot_record(chain: &SerialChain) -> RobotRecord {
    let source = chain.urdf_source();
    RobotRecord {
        urdf: source.and_then(|s| s.path.as_deref().map(file::recorded_urdf_path)),
        urdf_sha256: source.map(|s| s.sha256.clone()),
        base: chain.base_link().to_string(),
        tip: chain.tip_link().to_string(),
        joint_names: chain.joint_names().to_vec(),
        n_joints: chain.n_joints(),
        kinematics_sha256: kinematics_sha256(chain),
    }
}

/// The first 12 hex digits of a hash, enough to tell two apart in a message.
fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

/// `J<joint><axis>` or `J<joint>t<axis>` (1-based joint) → a [`Spring`], read by the
/// vocabulary's one parser ([`crate::model_spec::spring_label`]).
fn parse_label(label: &str) -> Result<Spring, String> {
    crate::model_spec::spring_label(label, usize::MAX).ok_or_else(|| {
        format!("`{label}` is not a spring label (J<joint><axis>, e.g. J2x or J2tx)")
    })
}
