//! The catalogue of candidate extensions and their design-matrix columns.
//!
//! Every candidate adds columns that are linear in new parameters; where the effect is bilinear
//! in the baseline compliances (wrench bias, frame misalignment, geometric non-linearity) the
//! columns are taken at the current fit (a Gauss–Newton step around it). See
//! `docs/diagnose.md` for the derivation of each column.

use nalgebra::{DMatrix, Matrix3};

use super::rows::RowBuilder;
use crate::model::SpringAxis;

/// Knots of the torsion non-linearity hinges, in units of the joint's RMS training torque.
pub const TORSION_KNOTS: [f64; 2] = [0.33, 1.0];

/// The knots (N·m) of a joint's `joint_torsion_nonlinear` hinges: [`TORSION_KNOTS`] times the
/// joint's RMS total torsion torque over the training rows, `tau_scale` (N·m; floored at
/// 1e-12 so that an unloaded joint has distinct knots). The one rule of the candidate's
/// column and of the gear curve a finding reports
/// ([`GearFinding::gear_curve`](super::report::GearFinding::gear_curve)).
pub fn torsion_knots(tau_scale: f64) -> [f64; 2] {
    let s = tau_scale.max(1e-12);
    TORSION_KNOTS.map(|k| k * s)
}

/// One candidate extension of the model. Joints are 0-based here and 1-based in the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Candidate {
    /// A tilting spring at `joint` about `axis` (`X` or `Y`).
    JointTilt {
        /// 0-based joint.
        joint: usize,
        /// `X` or `Y`.
        axis: SpringAxis,
    },
    /// Torque-dependent torsional compliance at `joint`.
    JointTorsionNonlinear {
        /// 0-based joint.
        joint: usize,
    },
    /// Lost motion at `joint`.
    JointBacklash {
        /// 0-based joint.
        joint: usize,
    },
    /// A constant bias in the recorded wrench (6 parameters).
    WrenchBias,
    /// A small rotation between the measurement frame and the base (3 parameters).
    FrameMisalignment,
    /// The geometric non-linearity (K_C) correction, one scale parameter.
    GeometricNonlinearity,
    /// The arm's mount translates under the load: `δ = diag(c_x, c_y, c_z) f` (3 parameters,
    /// m/N, base frame).
    MountTranslation,
    /// A translational spring of the link after `joint` along its spring axis `axis` (`Z`, `X`
    /// or `Y`, the joint's child frame): the full VJM's 6-D link spring beyond its rotations
    /// (1 parameter, m/N).
    LinkTranslation {
        /// 0-based joint: the link after it.
        joint: usize,
        /// `Z`, `X` or `Y`.
        axis: SpringAxis,
    },
    /// The arm's mount rotates about the base origin under the moment the load exerts there:
    /// `φ = diag(c_x, c_y, c_z) (m + p × f)`, moving the tip by `φ × p` (3 parameters,
    /// rad/(N·m), base frame).
    MountRotation,
}

impl Candidate {
    /// The effect name of the output contract.
    pub fn effect(&self) -> &'static str {
        match self {
            Candidate::JointTilt { .. } => "joint_tilt",
            Candidate::JointTorsionNonlinear { .. } => "joint_torsion_nonlinear",
            Candidate::JointBacklash { .. } => "joint_backlash",
            Candidate::WrenchBias => "wrench_bias",
            Candidate::FrameMisalignment => "frame_misalignment",
            Candidate::GeometricNonlinearity => "geometric_nonlinearity",
            Candidate::MountTranslation => "mount_translation",
            Candidate::LinkTranslation { .. } => "link_translation",
            Candidate::MountRotation => "mount_rotation",
        }
    }

    /// 0-based joint, when the effect sits at a joint.
    pub fn joint(&self) -> Option<usize> {
        match self {
            Candidate::JointTilt { joint, .. }
            | Candidate::LinkTranslation { joint, .. }
            | Candidate::JointTorsionNonlinear { joint }
            | Candidate::JointBacklash { joint } => Some(*joint),
            _ => None,
        }
    }

    /// Spring axis, for `joint_tilt` and `link_translation`.
    pub fn axis(&self) -> Option<SpringAxis> {
        match self {
            Candidate::JointTilt { axis, .. } | Candidate::LinkTranslation { axis, .. } => {
                Some(*axis)
            }
            _ => None,
        }
    }

    /// Number of new parameters (design columns).
    pub fn n_columns(&self) -> usize {
        match self {
            Candidate::WrenchBias => 6,
            Candidate::FrameMisalignment
            | Candidate::MountTranslation
            | Candidate::MountRotation => 3,
            Candidate::JointTorsionNonlinear { .. } => TORSION_KNOTS.len(),
            _ => 1,
        }
    }

    /// Whether the columns depend on the current fit (re-linearised after each refit).
    pub fn bilinear(&self) -> bool {
        matches!(
            self,
            Candidate::WrenchBias | Candidate::FrameMisalignment | Candidate::GeometricNonlinearity
        )
    }

    /// Human-readable label, 1-based joints, e.g. `joint_tilt(J3x)`.
    pub fn label(&self) -> String {
        match (self.joint(), self.axis()) {
            (Some(j), Some(a)) => format!("{}(J{}{})", self.effect(), j + 1, a),
            (Some(j), None) => format!("{}(J{})", self.effect(), j + 1),
            _ => self.effect().to_string(),
        }
    }

    /// Unit of the parameters the columns multiply.
    pub fn unit(&self) -> &'static str {
        match self {
            Candidate::JointTilt { .. } => "rad/(N·m)",
            Candidate::JointTorsionNonlinear { .. } => {
                "rad/(N·m) (compliance change beyond each knot)"
            }
            Candidate::JointBacklash { .. } => "rad",
            Candidate::WrenchBias => "N, N·m",
            Candidate::FrameMisalignment => "rad",
            Candidate::GeometricNonlinearity => "1 (1 = the physical K_C)",
            Candidate::MountTranslation | Candidate::LinkTranslation { .. } => "m/N",
            Candidate::MountRotation => "rad/(N·m)",
        }
    }
}

/// The full catalogue for a model whose springs are `in_model` (flags over the 3n springs,
/// joint-major `[z, x, y]`): tilts not in the model, torsion non-linearity and backlash at every
/// joint whose torsion spring is modelled, the links' translations, and the global effects.
pub fn catalogue(in_model: &[bool]) -> Vec<Candidate> {
    let n = in_model.len() / 3;
    let mut out = Vec::new();
    for joint in 0..n {
        for (k, axis) in [(1, SpringAxis::X), (2, SpringAxis::Y)] {
            if !in_model[3 * joint + k] {
                out.push(Candidate::JointTilt { joint, axis });
            }
        }
    }
    for joint in 0..n {
        if in_model[3 * joint] {
            out.push(Candidate::JointTorsionNonlinear { joint });
            out.push(Candidate::JointBacklash { joint });
        }
    }
    for joint in 0..n {
        for axis in SpringAxis::ALL {
            out.push(Candidate::LinkTranslation { joint, axis });
        }
    }
    out.push(Candidate::WrenchBias);
    out.push(Candidate::FrameMisalignment);
    out.push(Candidate::GeometricNonlinearity);
    out.push(Candidate::MountTranslation);
    out.push(Candidate::MountRotation);
    out
}

/// Kinematic quantities of one measurement row, computed once.
#[derive(Debug, Clone)]
pub struct RowKinematics {
    /// Joint angles, rad.
    pub q: Vec<f64>,
    /// 6×3n virtual-joint Jacobian at the tip point, base frame.
    pub jacobian: DMatrix<f64>,
    /// The recorded load's torque on each spring, N·m (3n): `Jᵀ W`, and under gravity
    /// `Jᵀ W + K_G Δθ` at the pass's linearisation (gravity's stiffness acting on the
    /// deflection the load causes, [`GravityWorkspace::effective_torques`](crate::gravity::GravityWorkspace::effective_torques)),
    /// so that a spring's column `J_t[:, s] τ_s` is what a measurement under gravity records.
    pub tau: Vec<f64>,
    /// `Jᵀ W` alone, N·m (3n): the load's torque without gravity's coupling (the geometric
    /// non-linearity's linear part).
    pub tau_load: Vec<f64>,
    /// The weight's torque on each spring at the unloaded pose, τ_g(q), N·m (3n; zeros for a
    /// weightless diagnosis): the preload on which the load's torque acts, where the gear
    /// curves of the non-linear candidates are evaluated.
    pub tau_gravity: Vec<f64>,
    /// Recorded wrench, base frame.
    pub wrench: [f64; 6],
    /// Measured displacement, base frame, m.
    pub displacement: [f64; 3],
    /// Unloaded tip point, base frame, m.
    pub tip: [f64; 3],
    /// Standard deviation of each joint's torsion torque τ_jz caused by the force-sensor noise,
    /// `√(J_zᵀ Σ_W J_z)`, N·m (n values; zeros when the wrench is taken as exact).
    pub tau_sigma: Vec<f64>,
    /// Rotation of the unloaded tip frame (base ← tip).
    pub tip_rotation: nalgebra::Matrix3<f64>,
    /// The exact tip displacement (m, base frame) of the deflected equilibrium at the pass's
    /// linearisation, when the pass computed it for a batch of rows
    /// ([`RowBuilder::rows_into`]); otherwise `None`, and the geometric non-linearity column
    /// computes it for the row alone.
    pub deflected: Option<[f64; 3]>,
}

/// The point the bilinear columns are linearised at: the full 3n compliance vector of the
/// current fit (a row's spring-only prediction `J_t C Jᵀ W` follows from it, see
/// [`spring_prediction`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Linearisation {
    /// Compliance of every spring (0 for springs not in the model), rad/(N·m).
    pub compliance: Vec<f64>,
}

/// `J_t C τ` of a row for compliances `c` (3n), m: the spring-only prediction, with the
/// row's load torque τ ([`RowKinematics::tau`], gravity's coupling included).
pub fn spring_prediction(row: &RowKinematics, c: &[f64]) -> [f64; 3] {
    linear_prediction(row, c, &row.tau)
}

/// `J_t C t` of a row for compliances `c` and spring torques `t` (3n each), m.
fn linear_prediction(row: &RowKinematics, c: &[f64], tau: &[f64]) -> [f64; 3] {
    let mut d = [0.0; 3];
    for (s, (ci, t)) in c.iter().zip(tau).enumerate() {
        let a = ci * t;
        if a != 0.0 {
            for (r, dr) in d.iter_mut().enumerate() {
                *dr += row.jacobian[(r, s)] * a;
            }
        }
    }
    d
}

fn col3(j: &DMatrix<f64>, s: usize) -> [f64; 3] {
    [j[(0, s)], j[(1, s)], j[(2, s)]]
}

fn scale3(v: [f64; 3], a: f64) -> [f64; 3] {
    [v[0] * a, v[1] * a, v[2] * a]
}

/// `J_t C Jᵀ` (3×6) of a row for compliances `c` (3n): `Σ_s c_s J_t[:, s] J[:, s]ᵀ`, summed
/// over the springs with a non-zero compliance only (no allocation).
pub fn compliance_map3x6(row: &RowKinematics, c: &[f64]) -> nalgebra::Matrix3x6<f64> {
    let mut g = nalgebra::Matrix3x6::zeros();
    let j = &row.jacobian;
    for (s, &cs) in c.iter().enumerate() {
        if cs == 0.0 {
            continue;
        }
        for r in 0..3 {
            let a = cs * j[(r, s)];
            for k in 0..6 {
                g[(r, k)] += a * j[(k, s)];
            }
        }
    }
    g
}

/// [`compliance_map3x6`] as a dynamic matrix.
pub fn compliance_map(row: &RowKinematics, c: &[f64]) -> DMatrix<f64> {
    let g = compliance_map3x6(row, c);
    DMatrix::from_fn(3, 6, |r, k| g[(r, k)])
}

/// The raw (unwhitened) 3-vector of spring `s` (index into the 3n springs) for a row:
/// `J_t[:, s] · τ_s`.
pub fn spring_column(row: &RowKinematics, s: usize) -> [f64; 3] {
    scale3(col3(&row.jacobian, s), row.tau[s])
}

/// The raw 3-vector of the translational spring of the link after joint `s / 3` along spring
/// axis `s % 3` (`[z, x, y]`) for a row: `a (a·f)`, with a the spring's unit axis (the angular
/// part of the Jacobian's column s) and f the recorded force; the parameter is the compliance,
/// m/N. A load at the tip sends its whole force through every link, so the link moves by
/// `c (a·f)` along a and carries the tip with it.
pub fn link_translation_column(row: &RowKinematics, s: usize) -> [f64; 3] {
    let j = &row.jacobian;
    let a = [j[(3, s)], j[(4, s)], j[(5, s)]];
    let f = &row.wrench;
    scale3(a, a[0] * f[0] + a[1] * f[1] + a[2] * f[2])
}

/// Raw columns of `cand` for one row: one 3-vector per parameter.
///
/// - `joint_tilt (j, a)`: `J_t[:, ja] · τ_ja`;
/// - `link_translation (j, a)`: `a (a·f)`, [`link_translation_column`];
/// - `joint_torsion_nonlinear (j)`: `J_t[:, jz] · (h_k(τ_g + τ) − h_k(τ_g))` with the hinge
///   `h_k(t) = sign(t)·max(|t| − t_k, 0)` for the knots `t_k = TORSION_KNOTS[k] · s_j`, `s_j`
///   the RMS of the total torque τ_g + τ_jz over the training rows, τ_g the weight's preload
///   (0 when weightless); each parameter is the change of tangent compliance beyond its knot,
///   rad/(N·m);
/// - `joint_backlash (j)`: `J_t[:, jz] · ½ (erf((τ_g + τ_jz)/(√2 σ_τ)) − sign(τ_g))`, the
///   expected change of `½ sign` of the applied total torque given the recorded one (the
///   parameter is the lost motion b);
/// - `wrench_bias`: `−J_t C Jᵀ e_k`, k = 1..6 (the parameter is the bias β, recorded = applied + β);
/// - `frame_misalignment`: `−hat(d̂)` with d̂ the spring prediction (the parameter is φ,
///   recorded = exp(hat φ) d ≈ d + φ × d);
/// - `geometric_nonlinearity`: `d_exact(C) − J_t C Jᵀ W`, the exact deflected-equilibrium
///   response minus the linear one at the current compliances (parameter 1 = physical).
pub fn candidate_columns(
    builder: &RowBuilder<'_>,
    cand: &Candidate,
    row: &RowKinematics,
    lin: &Linearisation,
    tau_scale: &[f64],
    out: &mut Vec<[f64; 3]>,
) {
    match *cand {
        Candidate::JointTilt { joint, axis } => {
            out.push(spring_column(row, 3 * joint + axis.index()));
        }
        Candidate::LinkTranslation { joint, axis } => {
            out.push(link_translation_column(row, 3 * joint + axis.index()));
        }
        Candidate::JointTorsionNonlinear { joint } => {
            // Odd hinge functions sign(τ)·max(|τ| − t_k, 0) at t_k = TORSION_KNOTS · s_j: with
            // the linear spring they span piecewise-linear torque → deflection curves such as
            // the harmonic drive's K1/K2/K3 segments, and they are continuous at τ = 0, which
            // separates them from lost motion.
            // Under gravity the gear works about its preload τ_g: the measured (loaded −
            // unloaded) deflection is the curve's change from τ_g to τ_g + τ.
            let t = row.tau[3 * joint];
            let tg = row.tau_gravity[3 * joint];
            let a = col3(&row.jacobian, 3 * joint);
            let hinge = crate::gear::hinge;
            for knot in torsion_knots(tau_scale[joint]) {
                out.push(scale3(a, hinge(tg + t, knot) - hinge(tg, knot)));
            }
        }
        Candidate::JointBacklash { joint } => {
            // The sign of the applied torque is uncertain when |τ| is within the noise of the
            // recorded wrench: use its expectation E[sign τ | τ_rec] = erf(τ_rec/(√2 σ_τ)).
            // Under gravity the dead band is crossed only where the total torque τ_g + τ
            // changes sign: the lost motion is ½ b (sign(τ_g + τ) − sign(τ_g)), with τ_g known.
            let tg = row.tau_gravity[3 * joint];
            let t = tg + row.tau[3 * joint];
            let st = row.tau_sigma.get(joint).copied().unwrap_or(0.0);
            let sg = if st > 0.0 {
                erf(t / (std::f64::consts::SQRT_2 * st))
            } else if t == 0.0 {
                0.0
            } else {
                t.signum()
            };
            let preload = if tg == 0.0 { 0.0 } else { tg.signum() };
            out.push(scale3(col3(&row.jacobian, 3 * joint), 0.5 * (sg - preload)));
        }
        Candidate::WrenchBias => {
            let g = compliance_map3x6(row, &lin.compliance);
            out.extend((0..6).map(|k| [-g[(0, k)], -g[(1, k)], -g[(2, k)]]));
        }
        Candidate::FrameMisalignment => {
            let d = spring_prediction(row, &lin.compliance);
            // −hat(d) columns: −hat(d) e_k = e_k × d.
            let h = -Matrix3::new(0.0, -d[2], d[1], d[2], 0.0, -d[0], -d[1], d[0], 0.0);
            out.extend((0..3).map(|k| [h[(0, k)], h[(1, k)], h[(2, k)]]));
        }
        Candidate::GeometricNonlinearity => {
            if lin.compliance.iter().all(|c| *c == 0.0) {
                out.push([0.0; 3]);
            } else {
                let d = row
                    .deflected
                    .unwrap_or_else(|| builder.exact_displacement(row, &lin.compliance));
                // The load's linear response without gravity's coupling: the exact
                // equilibrium above is the weightless one, so this column is the load's
                // geometric non-linearity alone.
                let l = linear_prediction(row, &lin.compliance, &row.tau_load);
                out.push([d[0] - l[0], d[1] - l[1], d[2] - l[2]]);
            }
        }
        Candidate::MountTranslation => {
            let f = &row.wrench;
            out.extend((0..3).map(|k| {
                let mut c = [0.0; 3];
                c[k] = f[k];
                c
            }));
        }
        Candidate::MountRotation => {
            let (p, f, m) = (row.tip, &row.wrench, &row.wrench[3..]);
            // The load's moment about the base origin, m + p × f.
            let mb = [
                m[0] + p[1] * f[2] - p[2] * f[1],
                m[1] + p[2] * f[0] - p[0] * f[2],
                m[2] + p[0] * f[1] - p[1] * f[0],
            ];
            out.extend((0..3).map(|k| {
                // (e_k × p)·mb_k
                let e_cross_p = match k {
                    0 => [0.0, -p[2], p[1]],
                    1 => [p[2], 0.0, -p[0]],
                    _ => [-p[1], p[0], 0.0],
                };
                scale3(e_cross_p, mb[k])
            }));
        }
    }
}

/// Blocks of the lack-of-fit alternative: flexible, generic effects that no catalogue entry
/// names, used to test whether structure remains (they never become findings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Alternative {
    /// A pose-independent linear map of the wrench, `d = A w` (3×6 = 18 parameters): any
    /// compliance outside the arm that does not depend on the pose (mount, sensor mounting).
    LinearInWrench,
    /// A compliance in the tool frame, `d = R C Rᵀ f` with R the tip frame (9 parameters): a
    /// compliant tool, gripper or force-sensor flange.
    ToolFrame,
    /// Each joint's torsion compliance varying with that joint's angle to first harmonic,
    /// `c_j (1 + a_j sin q_j + b_j cos q_j)` (2n parameters, the torsion column times sin q_j
    /// and cos q_j): a gear whose stiffness changes with its position. Not in [`Self::ALL`]:
    /// it is a test of its own in the verdict ([`crate::diagnose`]'s `angle_compliance`), as
    /// the per-pose compliance is, so that its few columns are not diluted among the overall
    /// alternative's many.
    AngleCompliance,
}

impl Alternative {
    /// Every block of the overall lack-of-fit alternative.
    pub const ALL: [Alternative; 2] = [Alternative::LinearInWrench, Alternative::ToolFrame];

    /// Every block with columns in the problem's layout: [`Self::ALL`] and the blocks that are
    /// tests of their own.
    pub const IN_LAYOUT: [Alternative; 3] = [
        Alternative::LinearInWrench,
        Alternative::ToolFrame,
        Alternative::AngleCompliance,
    ];

    /// Number of columns on an arm of `n_joints` joints.
    pub fn n_columns(&self, n_joints: usize) -> usize {
        match self {
            Alternative::LinearInWrench => 18,
            Alternative::ToolFrame => 9,
            Alternative::AngleCompliance => 2 * n_joints,
        }
    }

    /// Name in the report.
    pub fn name(&self) -> &'static str {
        match self {
            Alternative::LinearInWrench => "linear_in_wrench",
            Alternative::ToolFrame => "tool_frame",
            Alternative::AngleCompliance => "angle_compliance",
        }
    }

    /// What remaining structure in this block means, in words.
    pub fn meaning(&self) -> &'static str {
        match self {
            Alternative::LinearInWrench => {
                "linear in the load and independent of the pose: a compliance outside the arm, such as the mount, the force sensor's mounting or the tool?"
            }
            Alternative::ToolFrame => {
                "linear in the force along the tool's own axes: a compliant tool, gripper or sensor flange?"
            }
            Alternative::AngleCompliance => {
                "a joint's torsion compliance changes with that joint's angle: a gear whose stiffness depends on its position (an eccentric or worn gear)?"
            }
        }
    }

    /// Raw columns of the block for one row.
    pub fn columns(&self, row: &RowKinematics, out: &mut Vec<[f64; 3]>) {
        let w = &row.wrench;
        match self {
            Alternative::AngleCompliance => {
                for (j, q) in row.q.iter().enumerate() {
                    let t = spring_column(row, 3 * j);
                    let (sin, cos) = q.sin_cos();
                    out.push(scale3(t, sin));
                    out.push(scale3(t, cos));
                }
            }
            Alternative::LinearInWrench => {
                for r in 0..3 {
                    for wk in w.iter() {
                        let mut c = [0.0; 3];
                        c[r] = *wk;
                        out.push(c);
                    }
                }
            }
            Alternative::ToolFrame => {
                let rt = &row.tip_rotation;
                for a in 0..3 {
                    for b in 0..3 {
                        // R e_a (R e_b · f)
                        let fb = rt[(0, b)] * w[0] + rt[(1, b)] * w[1] + rt[(2, b)] * w[2];
                        out.push([rt[(0, a)] * fb, rt[(1, a)] * fb, rt[(2, a)] * fb]);
                    }
                }
            }
        }
    }
}

/// The error function (musl's, through `libm`): evaluated for every joint of every row of a
/// pass, where the route through the regularised incomplete gamma function, erf(x) = P(½, x²),
/// cost about a tenth of the pass. A test checks the two agree.
pub fn erf(x: f64) -> f64 {
    libm::erf(x)
}

/// Per-joint torsion torque noise `√(J_zᵀ Σ_W J_z)` for a 6×3n Jacobian and per-axis wrench
/// standard deviations.
pub fn torque_sigma(jacobian: &DMatrix<f64>, wrench_sigma: &[f64; 6]) -> Vec<f64> {
    let mut out = vec![0.0; jacobian.ncols() / 3];
    torque_sigma_into(jacobian, wrench_sigma, &mut out);
    out
}

/// [`torque_sigma`] written into `out` (one value per joint).
pub fn torque_sigma_into(jacobian: &DMatrix<f64>, wrench_sigma: &[f64; 6], out: &mut [f64]) {
    for (j, o) in out.iter_mut().enumerate() {
        *o = (0..6)
            .map(|k| (jacobian[(k, 3 * j)] * wrench_sigma[k]).powi(2))
            .sum::<f64>()
            .sqrt();
    }
}
