//! The testbed's true model: linear virtual springs plus any of the effects the diagnosis looks
//! for, and the exact (noise-free) response of the robot to a wrench.

use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

use super::effects::{backlash_deflection, rotate, HarmonicDriveSpring};
use super::kinematics::{deflected_pose, deflected_tip, deflected_tip_frame};
use super::outside::{mount_motion, moved_by_mount, tool_axial_displacement};
use super::TestbedError;
use crate::chain::SerialChain;
use crate::gravity::{Gravity, GravityWorkspace};
use crate::model::{SpringAxis, VirtualJointModel};

/// One effect carried by a [`TrueModel`]. Joints are 0-based (base → tip) in Rust, as in
/// [`crate::model::Spring`], and 1-based in the serialised form (`truth.json`), like every file
/// and output of the project.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "effect", rename_all = "snake_case")]
#[non_exhaustive]
pub enum Effect {
    /// A tilting spring of compliance `compliance` (rad/(N·m)) at `joint` about `axis`
    /// (`X` or `Y`, see docs/conventions.md); added to the spring's linear compliance.
    JointTilt {
        /// 0-based joint (written 1-based).
        #[serde(serialize_with = "one_based")]
        joint: usize,
        /// `X` or `Y`.
        axis: SpringAxis,
        /// Compliance, rad/(N·m).
        compliance: f64,
    },
    /// The joint's torsional spring follows a harmonic-drive curve instead of its linear
    /// compliance.
    #[serde(rename = "joint_torsion_nonlinear")]
    TorsionNonlinear {
        /// 0-based joint (written 1-based).
        #[serde(serialize_with = "one_based")]
        joint: usize,
        /// The torque → deflection curve.
        spring: HarmonicDriveSpring,
    },
    /// A translational spring in the link after `joint` (the full VJM's 6-D link spring has
    /// three rotations, the joint's torsion and tilts, and three translations): the link, and
    /// everything it carries, moves by `compliance·(a·f)·a` along its unit axis a under the
    /// force f it transmits, which for a load at the tip is the applied force. The axis is the
    /// joint's spring axis ([`SpringAxis`]: `Z` the joint axis, `X`, `Y` the tilt axes), so the
    /// frame is the joint's child frame, as deflected. Compliance in m/N.
    LinkTranslation {
        /// 0-based joint (written 1-based): the link after it.
        #[serde(serialize_with = "one_based")]
        joint: usize,
        /// `Z`, `X` or `Y`.
        axis: SpringAxis,
        /// Compliance, m/N.
        compliance: f64,
    },
    /// Lost motion: the joint moves an extra `½·lost_motion·sign(τ)` (rad) under load.
    #[serde(rename = "joint_backlash")]
    Backlash {
        /// 0-based joint (written 1-based).
        #[serde(serialize_with = "one_based")]
        joint: usize,
        /// Full dead-band width b, rad.
        lost_motion: f64,
    },
    /// The recorded wrench is the applied one plus `bias` (base frame, N and N·m).
    WrenchBias {
        /// `[fx, fy, fz, mx, my, mz]` offset.
        bias: [f64; 6],
    },
    /// The tracker's frame M is rotated from the base: recorded displacements are
    /// `exp(hat(φ))·d` with `rotation` = φ (rad).
    FrameMisalignment {
        /// Rotation vector φ, rad.
        rotation: [f64; 3],
    },
    /// Equilibrium in the deflected configuration (the load-dependent Jacobian, K_C) and the
    /// exact tip motion, instead of the linear `J C Jᵀ W`.
    GeometricNonlinearity,
    /// Not in the diagnosis catalogue (used to check `unexplained`): the torsion compliance of
    /// `joint` depends on its own angle, `c·(1 + amplitude·sin q_joint)` with c the joint's
    /// linear torsion compliance (a gear whose mesh stiffness varies around its turn). The
    /// extra deflection `amplitude·sin(q)·c·τ` adds to whatever else the joint does (a
    /// harmonic-drive curve or a backlash at the same joint is not scaled). `amplitude` in
    /// (−1, 1), so that the compliance stays positive.
    #[serde(rename = "joint_torsion_angle_dependent")]
    TorsionAngleDependent {
        /// 0-based joint (written 1-based).
        #[serde(serialize_with = "one_based")]
        joint: usize,
        /// Relative amplitude of the compliance's variation, in (−1, 1).
        amplitude: f64,
    },
    /// Not in the diagnosis catalogue (used to check `unexplained`): every pose's displacements
    /// carry an independent offset with per-axis standard deviation `sigma` (m), like a base
    /// that settles differently at each configuration.
    PoseDrift {
        /// Per-axis standard deviation, m.
        sigma: f64,
    },
    /// Not in the diagnosis catalogue: a compliant mount. The whole arm translates by
    /// `translation·f` and rotates by `rotation·(m + p × f)` about the base origin (the
    /// reaction of the applied wrench `[f; m]` at the tip point p); see
    /// [`super::outside::mount_motion`].
    MountCompliance {
        /// Translational compliance c_t = 1/k, m/N.
        translation: f64,
        /// Rotational compliance c_r = 1/k_rot, rad/(N·m).
        rotation: f64,
    },
    /// Not in the diagnosis catalogue: a tool compliant along its own axis (the tip frame's z
    /// axis in the unloaded configuration): the tool tip moves by `compliance·(f·z)·z` on top
    /// of the arm's deflection; see [`super::outside::tool_axial_displacement`].
    ToolAxialCompliance {
        /// Axial compliance 1/k_tool, m/N.
        compliance: f64,
    },
    /// Not in the diagnosis catalogue: the force sensor's cross-axis sensitivity (a
    /// calibration error). The recorded force is the applied one plus `coupling` times the
    /// applied force cycled through the axes: `f_rec = f + c·(f_z, f_x, f_y)`; the moments are
    /// recorded exactly.
    SensorCrosstalk {
        /// Cross-axis sensitivity c (1 = 100 %).
        coupling: f64,
    },
}

/// Writes a 0-based joint index as the 1-based number files and outputs use.
fn one_based<S: serde::Serializer>(joint: &usize, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u64(*joint as u64 + 1)
}

/// A true robot for the testbed: linear compliances of all 3n virtual springs (joint-major,
/// `[z, x, y]` per joint, rad/(N·m)) and effects on top.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrueModel {
    /// Linear compliance of every spring, rad/(N·m), 3n values.
    pub compliance: Vec<f64>,
    /// Effects on top of the linear springs.
    pub effects: Vec<Effect>,
}

/// Iteration cap of the fixed points under gravity ([`TrueModel::rest_under_gravity`],
/// [`TrueModel::displacement_under_gravity`]); they contract with ‖C K_G‖ + ‖C K_C‖ ≈ 1e-2 on an
/// arm and settle in a handful of iterations, so reaching the cap means springs too soft to hold
/// the arm up (or a backlash whose torque keeps changing sign): an error, not a value.
pub const MAX_GRAVITY_ITERATIONS: usize = 100;

/// Gravity torques and stiffness entries below this fraction of their largest are rounding
/// noise (a spring whose axis is parallel to gravity carries no weight: joint 1 of a
/// floor-mounted arm) and are set to 0, so that a backlash there keeps its unloaded reference in
/// the middle of the band, as without gravity, instead of taking the sign of the noise.
const GRAVITY_ROUNDOFF: f64 = 1e-12;

/// The true arm at rest under its own weight at one configuration (no applied wrench): what a
/// measurement under gravity calls "unloaded". Made by [`TrueModel::rest_under_gravity`], once
/// per configuration, and reused for every wrench applied there.
#[derive(Debug, Clone)]
pub struct RestUnderGravity {
    q: Vec<f64>,
    /// τ_g(q) on the 3n springs, N·m (rounding noise set to 0).
    torques: Vec<f64>,
    /// K_G(q), 3n×3n, N·m/rad (rounding noise set to 0).
    stiffness: DMatrix<f64>,
    /// θ₀ = response(τ_g + K_G θ₀), rad.
    theta: Vec<f64>,
    /// The tip point at θ₀, base frame, m.
    tip: Vector3<f64>,
}

impl RestUnderGravity {
    /// The joint angles it was computed at, rad.
    pub fn q(&self) -> &[f64] {
        &self.q
    }
    /// Gravity's torque τ_g on each of the 3n springs at θ = 0 (joint-major `[z, x, y]`), N·m.
    pub fn gravity_torques(&self) -> &[f64] {
        &self.torques
    }
    /// The spring deflections at rest under the weight, θ₀, rad (3n).
    pub fn theta(&self) -> &[f64] {
        &self.theta
    }
    /// The unloaded tip point (sagged under the weight), base frame, m.
    pub fn tip(&self) -> Vector3<f64> {
        self.tip
    }
    /// The springs' torque at deflection θ: τ_g + K_G θ plus `load`.
    fn torque(&self, theta: &[f64], load: &[f64]) -> Vec<f64> {
        let th = DVector::from_column_slice(theta);
        let coupling = &self.stiffness * th;
        self.torques
            .iter()
            .zip(coupling.iter())
            .zip(load)
            .map(|((g, k), l)| g + k + l)
            .collect()
    }
}

pub use crate::model::NOMINAL_TORSION;

impl TrueModel {
    /// Torsional springs only (the traditional VJM is exactly right): `torsion[j]` is joint j's
    /// compliance, rad/(N·m).
    pub fn torsion_only(torsion: &[f64]) -> Self {
        let mut compliance = vec![0.0; 3 * torsion.len()];
        for (j, c) in torsion.iter().enumerate() {
            compliance[3 * j] = *c;
        }
        TrueModel {
            compliance,
            effects: Vec::new(),
        }
    }

    /// [`NOMINAL_TORSION`] for the first `n_joints` joints (cycled beyond 7).
    pub fn nominal(n_joints: usize) -> Self {
        let t: Vec<f64> = (0..n_joints).map(|j| NOMINAL_TORSION[j % 7]).collect();
        Self::torsion_only(&t)
    }

    /// The same model with one more effect.
    pub fn with_effect(mut self, effect: Effect) -> Self {
        self.effects.push(effect);
        self
    }

    /// Number of actuated joints.
    pub fn n_joints(&self) -> usize {
        self.compliance.len() / 3
    }

    /// Whether the model carries geometric non-linearity.
    pub fn geometric(&self) -> bool {
        self.effects
            .iter()
            .any(|e| matches!(e, Effect::GeometricNonlinearity))
    }

    /// Spring deflections (rad, 3n) under spring torques `tau` (N·m, 3n): linear springs, tilts,
    /// harmonic-drive curves and backlash.
    pub fn spring_response(&self, tau: &[f64]) -> Vec<f64> {
        let mut c = self.compliance.clone();
        for e in &self.effects {
            if let Effect::JointTilt {
                joint,
                axis,
                compliance,
            } = e
            {
                c[3 * joint + axis.index()] += compliance;
            }
        }
        let mut theta: Vec<f64> = c.iter().zip(tau).map(|(c, t)| c * t).collect();
        for e in &self.effects {
            match e {
                Effect::TorsionNonlinear { joint, spring } => {
                    theta[3 * joint] = spring.deflection(tau[3 * joint]);
                }
                Effect::Backlash { joint, lost_motion } => {
                    theta[3 * joint] += backlash_deflection(tau[3 * joint], *lost_motion);
                }
                _ => {}
            }
        }
        theta
    }

    /// [`TrueModel::spring_response`] at the configuration `q` (rad): with
    /// [`Effect::TorsionAngleDependent`] the joint's torsion deflects by a further
    /// `amplitude·sin(q_joint)·c·τ`.
    pub fn spring_response_at(&self, q: &[f64], tau: &[f64]) -> Vec<f64> {
        let mut theta = self.spring_response(tau);
        for e in &self.effects {
            if let Effect::TorsionAngleDependent { joint, amplitude } = e {
                let s = 3 * joint;
                theta[s] += amplitude * q[*joint].sin() * self.compliance[s] * tau[s];
            }
        }
        theta
    }

    /// Whether the model carries [`Effect::LinkTranslation`]s.
    fn has_link_translations(&self) -> bool {
        self.effects
            .iter()
            .any(|e| matches!(e, Effect::LinkTranslation { .. }))
    }

    /// The tip's displacement by the links' translational springs (m, base frame) under the
    /// applied force of `wrench`: Σ c·(a·f)·a over the [`Effect::LinkTranslation`]s, each axis a
    /// the angular part of its spring's column of `jacobian` (6×3n, the chain as deflected).
    /// A translation carries the link and everything beyond it rigidly; the springs' torques
    /// are those of the untranslated chain (the translation changes a lever arm by c·|f|, a
    /// second-order term like the geometric non-linearity's).
    fn link_translations(&self, jacobian: &DMatrix<f64>, wrench: &[f64; 6]) -> Vector3<f64> {
        let f = Vector3::new(wrench[0], wrench[1], wrench[2]);
        let mut d = Vector3::zeros();
        for e in &self.effects {
            if let Effect::LinkTranslation {
                joint,
                axis,
                compliance,
            } = e
            {
                let s = 3 * joint + axis.index();
                let a = Vector3::new(jacobian[(3, s)], jacobian[(4, s)], jacobian[(5, s)]);
                d += a * (compliance * a.dot(&f));
            }
        }
        d
    }

    /// The true tip displacement (m, base frame) at `q` under the applied wrench `wrench`
    /// (base frame, at the tip point), before any measurement effect or noise, and the unloaded
    /// tip point. With [`Effect::GeometricNonlinearity`] the equilibrium
    /// `θ = response(J(q, θ)ᵀ W)` is solved by fixed-point iteration in the deflected
    /// configuration and the displacement is the exact tip motion; otherwise `d = J_t θ` with
    /// `θ = response(J(q)ᵀ W)`.
    ///
    /// The out-of-catalogue effects act on top, exactly: a [`Effect::ToolAxialCompliance`]
    /// adds `c·(f·z)·z` (z from the unloaded tip frame), then a [`Effect::MountCompliance`]
    /// moves the loaded tip point rigidly with the mount, `d = t + exp(hat φ)(p₀ + d_arm) − p₀`.
    ///
    /// Link translations ([`Effect::LinkTranslation`]) add `c·(a·f)·a`, a taken on the chain
    /// as deflected (under gravity: at rest under the weight, where the reference was taken;
    /// the weight the link carries loads it alike unloaded and loaded, so only f remains).
    ///
    /// The arm is weightless here: "unloaded" is θ = 0, the rigid forward kinematics. Under
    /// gravity "unloaded" is the arm at rest under its own weight, and the springs respond to
    /// the total torque: see [`TrueModel::rest_under_gravity`] and
    /// [`TrueModel::displacement_under_gravity`].
    pub fn displacement(
        &self,
        chain: &SerialChain,
        q: &[f64],
        wrench: &[f64; 6],
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (d, tip) = self.arm_displacement(chain, q, wrench);
        let unloaded = vec![0.0; self.compliance.len()];
        (
            self.outside_effects(chain, q, wrench, d, tip, &unloaded),
            tip,
        )
    }

    /// The arm at rest under its own weight at `q` (rad): the unloaded state of a measurement
    /// under `gravity`. The bodies are the chain's [`mass_model`](SerialChain::mass_model)
    /// (an error naming a link without `<inertial>`); gravity's torque τ_g(q) and stiffness
    /// K_G(q) on the 3n springs come from [`GravityWorkspace`] (the potential's gradient and
    /// Hessian at θ = 0), and the springs respond to the total torque:
    /// `θ₀ = response(τ_g + K_G θ₀)` ([`TrueModel::spring_response`], so tilts, harmonic-drive
    /// curves and backlash are evaluated where gravity preloads them), solved by fixed-point
    /// iteration capped at [`MAX_GRAVITY_ITERATIONS`] (an error when it does not settle).
    /// A spring gravity does not load (τ_g = 0, e.g. a vertical axis) keeps a backlash's
    /// reference in the middle of its band, as without gravity.
    pub fn rest_under_gravity(
        &self,
        chain: &SerialChain,
        q: &[f64],
        gravity: &Gravity,
    ) -> Result<RestUnderGravity, TestbedError> {
        // The truth must fit the chain (sizes, effects' joints) before anything indexes it.
        super::campaign::check_truth(chain, self)?;
        let n = chain.n_joints();
        let m = self.compliance.len();
        // The extended model's springs are joint-major `[Z, X, Y]` about `spring_axes`' `[a, u,
        // v]` with no offsets, composed in that order at each joint: exactly the truth's
        // compliance order and the testbed's deflected chain (kinematics.rs; the Jacobians are
        // compared in tests/it/testbed.rs), so τ_g[k] and K_G[i, k] belong to compliance k.
        let model = VirtualJointModel::extended(n);
        let gravity_error = |e: crate::VjmError| TestbedError::Gravity {
            message: e.to_string(),
        };
        let mut ws = GravityWorkspace::new(chain, &model, gravity, None).map_err(gravity_error)?;
        ws.evaluate(chain, q).map_err(gravity_error)?;
        let mut torques = ws.torques().to_vec();
        let mut stiffness = ws.stiffness().clone();
        let t_max = torques.iter().fold(0.0f64, |a, t| a.max(t.abs()));
        torques
            .iter_mut()
            .filter(|t| t.abs() <= GRAVITY_ROUNDOFF * t_max)
            .for_each(|t| *t = 0.0);
        let k_max = stiffness.amax();
        stiffness
            .iter_mut()
            .filter(|k| k.abs() <= GRAVITY_ROUNDOFF * k_max)
            .for_each(|k| *k = 0.0);
        let mut rest = RestUnderGravity {
            q: q.to_vec(),
            torques,
            stiffness,
            theta: vec![0.0; m],
            tip: Vector3::zeros(),
        };
        let none = vec![0.0; m];
        rest.theta = self.settle(vec![0.0; m], q, "unloaded", |th| rest.torque(th, &none))?;
        rest.tip = deflected_tip(chain, q, &rest.theta);
        Ok(rest)
    }

    /// The true tip displacement (m, base frame) under the applied `wrench` (base frame, at the
    /// tip point) measured under gravity: the tip under load minus the tip at `rest` (from
    /// [`TrueModel::rest_under_gravity`] at the same `q`), both under the arm's own weight,
    /// before any measurement effect or noise; and the unloaded (sagged) tip point.
    ///
    /// The loaded springs settle at `θ₁ = response(τ_g + K_G θ₁ + Jᵀ W)`, the total torque
    /// (capped fixed point, an error when it does not settle), and `d = J_t (θ₁ − θ₀)` with J
    /// (and the load's torque `Jᵀ W`) at the sagged configuration θ₀, where the reference was
    /// taken. With [`Effect::GeometricNonlinearity`] the load torque
    /// uses the deflected Jacobian `J(q, θ₁)ᵀ W` and `d` is the exact difference of the
    /// deflected tips at θ₁ and θ₀. The out-of-catalogue effects act as in
    /// [`TrueModel::displacement`], the tool axis and the mount's lever taken at rest.
    pub fn displacement_under_gravity(
        &self,
        chain: &SerialChain,
        q: &[f64],
        wrench: &[f64; 6],
        rest: &RestUnderGravity,
    ) -> Result<(Vector3<f64>, Vector3<f64>), TestbedError> {
        if rest.q != q || rest.theta.len() != self.compliance.len() {
            return Err(TestbedError::InvalidSpec {
                field: "rest",
                message: "the rest under gravity was computed at another configuration or for \
                          another chain"
                    .into(),
            });
        }
        let w = DVector::from_column_slice(wrench);
        let d = if self.geometric() {
            let theta = self.settle(rest.theta.clone(), q, "loaded", |th| {
                let pose = deflected_pose(chain, q, th);
                let load: Vec<f64> = (pose.jacobian.transpose() * &w).iter().cloned().collect();
                rest.torque(th, &load)
            })?;
            let mut d = deflected_tip(chain, q, &theta) - rest.tip;
            if self.has_link_translations() {
                d += self.link_translations(&deflected_pose(chain, q, &theta).jacobian, wrench);
            }
            d
        } else {
            // Linear in the load about the sagged pose, where the reference was taken: the
            // sag turns the Jacobian by as much as K_G changes the springs' torques (both first
            // order in the weight), so the load acts through J(q, θ₀).
            let sagged = deflected_pose(chain, q, &rest.theta);
            let load: Vec<f64> = (sagged.jacobian.transpose() * &w).iter().cloned().collect();
            let theta =
                self.settle(rest.theta.clone(), q, "loaded", |th| rest.torque(th, &load))?;
            let delta: Vec<f64> = theta.iter().zip(&rest.theta).map(|(a, b)| a - b).collect();
            let d = sagged.jacobian.rows(0, 3) * DVector::from_column_slice(&delta);
            Vector3::new(d[0], d[1], d[2]) + self.link_translations(&sagged.jacobian, wrench)
        };
        let d = self.outside_effects(chain, q, wrench, d, rest.tip, &rest.theta);
        Ok((d, rest.tip))
    }

    /// The fixed point `θ = response(torque(θ))` from `start`, capped at
    /// [`MAX_GRAVITY_ITERATIONS`] with the convergence test of the weightless geometric loop;
    /// `what` (`"unloaded"`/`"loaded"`) and `q` name it in the error.
    fn settle(
        &self,
        start: Vec<f64>,
        q: &[f64],
        what: &str,
        mut torque: impl FnMut(&[f64]) -> Vec<f64>,
    ) -> Result<Vec<f64>, TestbedError> {
        let mut theta = start;
        for _ in 0..MAX_GRAVITY_ITERATIONS {
            let next = self.spring_response_at(q, &torque(&theta));
            let change = next
                .iter()
                .zip(&theta)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let scale = next.iter().map(|a| a.abs()).fold(1e-300, f64::max);
            theta = next;
            if !change.is_finite() {
                break;
            }
            if change <= 1e-14 * scale {
                return Ok(theta);
            }
        }
        let q: Vec<String> = q
            .iter()
            .map(|v| stiffness_core::num::Short(*v).to_string())
            .collect();
        Err(TestbedError::Gravity {
            message: format!(
                "the {what} equilibrium under the arm's weight did not settle in \
                 {MAX_GRAVITY_ITERATIONS} iterations at q = [{}] rad (springs too soft to hold \
                 the arm, or a backlash whose torque keeps changing sign)",
                q.join(", ")
            ),
        })
    }

    /// The out-of-catalogue effects on top of the arm's displacement `d` (see
    /// [`TrueModel::displacement`]); `tip` and `theta_rest` are the unloaded tip point and
    /// spring deflections (the tool axis is the unloaded tip frame's z).
    fn outside_effects(
        &self,
        chain: &SerialChain,
        q: &[f64],
        wrench: &[f64; 6],
        mut d: Vector3<f64>,
        tip: Vector3<f64>,
        theta_rest: &[f64],
    ) -> Vector3<f64> {
        let f = Vector3::new(wrench[0], wrench[1], wrench[2]);
        for e in &self.effects {
            if let Effect::ToolAxialCompliance { compliance } = e {
                let frame = deflected_tip_frame(chain, q, theta_rest);
                let z = frame.rotation * Vector3::z();
                d += tool_axial_displacement(*compliance, &z, &f);
            }
        }
        for e in &self.effects {
            if let Effect::MountCompliance {
                translation,
                rotation,
            } = e
            {
                let (t, phi) = mount_motion(*translation, *rotation, wrench, &tip);
                d = moved_by_mount(&t, &phi, &(tip + d)) - tip;
            }
        }
        d
    }

    /// The arm's own response (springs, tilts, harmonic drives, backlash, K_C), before the
    /// out-of-catalogue effects; see [`TrueModel::displacement`].
    fn arm_displacement(
        &self,
        chain: &SerialChain,
        q: &[f64],
        wrench: &[f64; 6],
    ) -> (Vector3<f64>, Vector3<f64>) {
        let m = self.compliance.len();
        let w = DVector::from_column_slice(wrench);
        let pose0 = deflected_pose(chain, q, &vec![0.0; m]);
        let tau: Vec<f64> = (pose0.jacobian.transpose() * &w).iter().cloned().collect();
        let mut theta = self.spring_response_at(q, &tau);
        if !self.geometric() {
            let jt = pose0.jacobian.rows(0, 3);
            let d = jt * DVector::from_column_slice(&theta);
            let d =
                Vector3::new(d[0], d[1], d[2]) + self.link_translations(&pose0.jacobian, wrench);
            return (d, pose0.tip);
        }
        // |C·K_C| is of order |W|·reach·c ≈ 1e-2, so the iteration contracts fast.
        for _ in 0..100 {
            let pose = deflected_pose(chain, q, &theta);
            let tau: Vec<f64> = (pose.jacobian.transpose() * &w).iter().cloned().collect();
            let next = self.spring_response_at(q, &tau);
            let change = next
                .iter()
                .zip(&theta)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let scale = next.iter().map(|a| a.abs()).fold(1e-300, f64::max);
            theta = next;
            if change <= 1e-14 * scale {
                break;
            }
        }
        let tip = deflected_tip(chain, q, &theta);
        let mut d = tip - pose0.tip;
        if self.has_link_translations() {
            d += self.link_translations(&deflected_pose(chain, q, &theta).jacobian, wrench);
        }
        (d, pose0.tip)
    }

    /// Applies the measurement-side effects to a true displacement and applied wrench:
    /// returns the displacement as the tracker reports it (frame misalignment) and the wrench as
    /// the sensor records it (bias). Noise and pose drift are added by the campaign.
    pub fn measured(&self, d: Vector3<f64>, wrench: [f64; 6]) -> ([f64; 3], [f64; 6]) {
        let mut dm = [d.x, d.y, d.z];
        let mut wm = wrench;
        for e in &self.effects {
            match e {
                Effect::FrameMisalignment { rotation } => dm = rotate(*rotation, dm),
                Effect::WrenchBias { bias } => {
                    for k in 0..6 {
                        wm[k] += bias[k];
                    }
                }
                Effect::SensorCrosstalk { coupling } => {
                    wm[0] += coupling * wrench[2];
                    wm[1] += coupling * wrench[0];
                    wm[2] += coupling * wrench[1];
                }
                _ => {}
            }
        }
        (dm, wm)
    }

    /// Per-axis standard deviation of the pose drift, m (0 without [`Effect::PoseDrift`]).
    pub fn pose_drift(&self) -> f64 {
        self.effects
            .iter()
            .map(|e| match e {
                Effect::PoseDrift { sigma } => *sigma,
                _ => 0.0,
            })
            .fold(0.0, f64::max)
    }
}
