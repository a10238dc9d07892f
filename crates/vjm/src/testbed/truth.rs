//! The testbed's true model: linear virtual springs plus any of the effects the diagnosis looks
//! for, and the exact (noise-free) response of the robot to a wrench.

use nalgebra::{DVector, Vector3};
use serde::Serialize;

use super::effects::{backlash_deflection, rotate, HarmonicDriveSpring};
use super::kinematics::{deflected_pose, deflected_tip_frame};
use super::outside::{mount_motion, moved_by_mount, tool_axial_displacement};
use crate::chain::SerialChain;
use crate::model::SpringAxis;

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

/// Nominal torsional compliances of a Panda-class cobot, rad/(N·m), base → tip: stiffness
/// 10 kN·m/rad at the shoulder down to 2 kN·m/rad at the wrist.
pub const NOMINAL_TORSION: [f64; 7] = [1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4];

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
                let k = match axis {
                    SpringAxis::Z => 0,
                    SpringAxis::X => 1,
                    SpringAxis::Y => 2,
                };
                c[3 * joint + k] += compliance;
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
    pub fn displacement(
        &self,
        chain: &SerialChain,
        q: &[f64],
        wrench: &[f64; 6],
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (mut d, tip) = self.arm_displacement(chain, q, wrench);
        let f = Vector3::new(wrench[0], wrench[1], wrench[2]);
        for e in &self.effects {
            if let Effect::ToolAxialCompliance { compliance } = e {
                let frame = deflected_tip_frame(chain, q, &vec![0.0; self.compliance.len()]);
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
        (d, tip)
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
        let mut theta = self.spring_response(&tau);
        if !self.geometric() {
            let jt = pose0.jacobian.rows(0, 3);
            let d = jt * DVector::from_column_slice(&theta);
            return (Vector3::new(d[0], d[1], d[2]), pose0.tip);
        }
        // |C·K_C| is of order |W|·reach·c ≈ 1e-2, so the iteration contracts fast.
        for _ in 0..100 {
            let pose = deflected_pose(chain, q, &theta);
            let tau: Vec<f64> = (pose.jacobian.transpose() * &w).iter().cloned().collect();
            let next = self.spring_response(&tau);
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
        let tip = super::kinematics::deflected_tip(chain, q, &theta);
        (tip - pose0.tip, pose0.tip)
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
