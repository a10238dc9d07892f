//! Gravity at one configuration after another without allocating: the torques τ_g and the
//! stiffness K_G of every spring of a model, and the load torque once gravity's stiffness has
//! acted on the deflection it causes. The per-row evaluator of identify and diagnose; the
//! allocating [`gravity_torques`](super::gravity_torques) and
//! [`gravity_stiffness`](super::gravity_stiffness) are this, once.

use nalgebra::{DMatrix, Vector3};

use super::deflected::RigidBodies;
use super::{BodySums, Gravity};
use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::kinematics::Workspace;
use crate::model::VirtualJointModel;
use crate::stiffness_model::PointMass;

/// Iteration cap of [`GravityWorkspace::effective_torques`]'s fixed point; beyond it (a
/// contraction ratio near 1: springs barely able to hold the arm up) the linear system is
/// solved directly.
pub const MAX_COUPLING_ITERATIONS: usize = 60;

/// Reusable scratch for τ_g(q) and K_G(q) of a model's springs (base frame, N·m and
/// N·m/rad, the conventions of the [module](super); a translational spring's generalised
/// force is in N and its entries of K_G in N/rad or N/m), one configuration at a time.
#[derive(Debug, Clone)]
pub struct GravityWorkspace {
    model: VirtualJointModel,
    gravity: Vector3<f64>,
    payload: Option<PointMass>,
    ws: Workspace,
    /// Per actuated joint, its body's mass (kg) at the last evaluation.
    body_mass: Vec<f64>,
    /// Per actuated joint, its body's centre of mass at the last evaluation, base frame, m.
    body_point: Vec<Vector3<f64>>,
    /// The payload's mass (kg) and centre (base frame, m) at the last evaluation.
    payload_point: Option<(f64, Vector3<f64>)>,
    sums: BodySums,
    levers: Vec<Vector3<f64>>,
    /// Mass beyond each spring (kg): a translation's lever.
    carried: Vec<f64>,
    torques: Vec<f64>,
    stiffness: DMatrix<f64>,
    theta: Vec<f64>,
    next: Vec<f64>,
    active: Vec<usize>,
    scratch: Vec<f64>,
    sag: Vec<f64>,
}

impl GravityWorkspace {
    /// Scratch for `model` on `chain` under `gravity` with an optional `payload` (a point mass
    /// in the tip frame). Errors when the chain has no mass model (a link without
    /// `<inertial>`) or the model does not fit the chain.
    pub fn new(
        chain: &SerialChain,
        model: &VirtualJointModel,
        gravity: &Gravity,
        payload: Option<&PointMass>,
    ) -> Result<Self, VjmError> {
        let masses = chain.mass_model()?;
        let ws = Workspace::new(chain, model)?;
        let m = model.n_params();
        Ok(Self {
            model: model.clone(),
            gravity: gravity.vector(),
            payload: payload.cloned(),
            ws,
            body_mass: masses.bodies().iter().map(|b| b.mass).collect(),
            body_point: vec![Vector3::zeros(); chain.n_joints()],
            payload_point: None,
            sums: BodySums::default(),
            levers: vec![Vector3::zeros(); m],
            carried: vec![0.0; m],
            torques: vec![0.0; m],
            stiffness: DMatrix::zeros(m, m),
            theta: vec![0.0; m],
            next: vec![0.0; m],
            active: Vec::with_capacity(m),
            scratch: Vec::with_capacity(m),
            sag: Vec::with_capacity(m),
        })
    }

    /// The springs' model.
    pub fn model(&self) -> &VirtualJointModel {
        &self.model
    }

    /// The gravity it evaluates (base frame, m/s²).
    pub fn gravity(&self) -> Gravity {
        Gravity {
            vector: self.gravity,
        }
    }

    /// The rigid chain's spring axes, centres and tip point at the last evaluation.
    pub(crate) fn kinematics(&self) -> &Workspace {
        &self.ws
    }

    /// The weights at the last evaluation's rigid pose (for the deflected torques).
    pub(crate) fn bodies(&self) -> RigidBodies<'_> {
        RigidBodies {
            mass: &self.body_mass,
            point: &self.body_point,
            payload: self.payload_point,
            gravity: self.gravity,
        }
    }

    /// Carries `payload` (a point mass in the tip frame) from the next evaluation on.
    pub(crate) fn set_payload(&mut self, payload: Option<&PointMass>) {
        self.payload = payload.copied();
    }

    /// The payload it carries (a point mass in the tip frame), if any.
    pub fn payload(&self) -> Option<&PointMass> {
        self.payload.as_ref()
    }

    /// Evaluates τ_g and K_G at joint positions `q` (rad, checked: n finite values); read them
    /// with [`Self::torques`] and [`Self::stiffness`].
    pub fn evaluate(&mut self, chain: &SerialChain, q: &[f64]) -> Result<(), VjmError> {
        chain.check_q(q, 0)?;
        let masses = chain.mass_model()?;
        self.ws.evaluate(chain, q);
        // Masses too are the chain's of this call (a chain `with_masses` other ones may come
        // with the same joints and springs).
        for (j, b) in masses.bodies().iter().enumerate() {
            let (r, o) = self.ws.joint_frame(j);
            self.body_mass[j] = b.mass;
            self.body_point[j] = o + r * b.com;
        }
        self.payload_point = self.payload.as_ref().map(|p| {
            let centre = Vector3::from(p.centre());
            (p.mass(), self.ws.p + self.ws.tip_rotation(chain) * centre)
        });
        self.sums
            .fill(&self.body_mass, &self.body_point, self.payload_point);
        let sums = &self.sums;
        let g = self.gravity;
        let springs = self.model.springs();
        for (k, s) in springs.iter().enumerate() {
            self.levers[k] = sums.lever(s.joint, &self.ws.c[k]);
            self.carried[k] = sums.mass(s.joint);
            self.torques[k] = sums.torque(s, &self.ws.w[k], &self.ws.c[k], &g);
        }
        let m = self.model.n_params();
        for k in 0..m {
            let (wk, rk) = (self.ws.w[k], self.levers[k]);
            let (wk_g, rk_g) = (wk.dot(&g), rk.dot(&g));
            let k_moves = springs[k].is_translation();
            for (i, spring_i) in springs.iter().enumerate().take(k + 1) {
                let wi = self.ws.w[i];
                // ∂τ_k/∂θ_i for spring i at or before k. A rotation i turns k's axis and the
                // bodies beyond k about w_i; a translation i moves them and k's point alike,
                // which changes no torque of a later spring; and a translation's own torque
                // M (w·g) does not change when it moves.
                let v = match (spring_i.is_translation(), k_moves) {
                    (false, false) => wi.dot(&rk) * wk_g - wi.dot(&wk) * rk_g,
                    (false, true) if i < k => self.carried[k] * wi.cross(&wk).dot(&g),
                    _ => 0.0,
                };
                self.stiffness[(i, k)] = v;
                self.stiffness[(k, i)] = v;
            }
        }
        Ok(())
    }

    /// τ_g of every spring at the last evaluation, N·m.
    pub fn torques(&self) -> &[f64] {
        &self.torques
    }

    /// K_G at the last evaluation (m×m, N·m/rad, symmetric).
    pub fn stiffness(&self) -> &DMatrix<f64> {
        &self.stiffness
    }

    /// The torque on each spring of a load whose own torque is `load` (N·m, m values) once
    /// the weight's stiffness has acted on the deflection it causes, at the last evaluation:
    /// `τ + K_G Δθ` with `Δθ = (K_θ − K_G)⁻¹ τ` for the springs of compliance `compliance`
    /// (rad/(N·m), m values; 0 = rigid). Written to `out`.
    ///
    /// This is what a measurement under gravity records as (loaded − unloaded): the springs
    /// deflect by `Δθ = C (τ + K_G Δθ)`, linear in C for the torque returned. The fixed point
    /// contracts with the ratio ‖C K_G‖ (≈ 1e-2 on an arm) and is capped at
    /// [`MAX_COUPLING_ITERATIONS`]; then `(I − C K_G) Δθ = C τ` is solved directly, and an
    /// error says the springs cannot hold the arm when that system is singular.
    pub fn effective_torques(
        &mut self,
        compliance: &[f64],
        load: &[f64],
        out: &mut [f64],
    ) -> Result<(), VjmError> {
        let m = self.model.n_params();
        for (what, len) in [
            ("compliance", compliance.len()),
            ("load torques", load.len()),
            ("output", out.len()),
        ] {
            if len != m {
                return Err(VjmError::ShapeMismatch {
                    what,
                    expected: m,
                    got: len,
                });
            }
        }
        // Only springs of non-zero compliance deflect: the coupling sums run over them alone
        // (7 of 21 for a traditional model), which is most of the cost per row.
        self.active.clear();
        self.active.extend((0..m).filter(|&k| compliance[k] != 0.0));
        for ((t, c), l) in self.theta.iter_mut().zip(compliance).zip(load) {
            *t = c * l;
        }
        let kg = &self.stiffness;
        let mut converged = false;
        for _ in 0..MAX_COUPLING_ITERATIONS {
            let mut change: f64 = 0.0;
            let mut scale: f64 = 1e-300;
            for &k in &self.active {
                let coupling: f64 = self
                    .active
                    .iter()
                    .map(|&i| kg[(k, i)] * self.theta[i])
                    .sum();
                let next = compliance[k] * (load[k] + coupling);
                change = change.max((next - self.theta[k]).abs());
                scale = scale.max(next.abs());
                self.next[k] = next;
            }
            for &k in &self.active {
                self.theta[k] = self.next[k];
            }
            if change <= 1e-15 * scale {
                converged = true;
                break;
            }
        }
        if !converged {
            let c = nalgebra::DVector::from_column_slice(compliance);
            let a = crate::predict::identity_minus_c_times(&c, kg);
            let b = nalgebra::DVector::from_iterator(
                m,
                compliance.iter().zip(load).map(|(c, l)| c * l),
            );
            let x = a.lu().solve(&b).ok_or_else(|| VjmError::Numerical {
                message: "the springs cannot hold the arm under its weight: K_θ − K_G is singular at this pose".into(),
            })?;
            self.theta.copy_from_slice(x.as_slice());
        }
        for (k, o) in out.iter_mut().enumerate() {
            let coupling: f64 = self
                .active
                .iter()
                .map(|&i| kg[(k, i)] * self.theta[i])
                .sum();
            *o = load[k] + coupling;
        }
        Ok(())
    }

    /// Moves a measurement's kinematics to where its reference was taken: the unloaded
    /// equilibrium under the weight at the last evaluation, the sag θ₀ = C τ₀ with
    /// τ₀ = τ_g + K_G θ₀ (springs of compliance `compliance`, rad/(N·m); 0 = rigid). `frame`
    /// holds the row's Jacobian (6×m column-major, this workspace's springs), tip point and
    /// tip rotation at θ = 0 and receives them at θ₀
    /// (`kinematics::deflect_in_place`, exact); `preload` (m)
    /// receives τ₀, the torque each spring carries there (N·m).
    pub fn sag(
        &mut self,
        compliance: &[f64],
        frame: RowFrame<'_>,
        preload: &mut [f64],
    ) -> Result<(), VjmError> {
        // τ_g is copied out: `effective_torques` borrows the workspace mutably.
        let mut tau_g = std::mem::take(&mut self.scratch);
        tau_g.clear();
        tau_g.extend_from_slice(&self.torques);
        let result = self.effective_torques(compliance, &tau_g, preload);
        self.scratch = tau_g;
        result?;
        self.sag.clear();
        self.sag
            .extend(compliance.iter().zip(preload.iter()).map(|(c, t)| c * t));
        crate::kinematics::deflect_in_place(
            frame.jacobian,
            frame.tip,
            frame.tip_rotation,
            &self.sag,
        );
        Ok(())
    }

    /// A load's torques on the springs of a row measured under the weight, at the last
    /// evaluation: [`sag`](Self::sag) moves `frame` to the sagged pose θ₀ (`preload` receives
    /// τ₀), `tau` receives the load's torque there, `J(θ₀)ᵀ W` for `wrench` (base frame, at the
    /// tip point), and `effective` that torque with gravity's coupling
    /// ([`effective_torques`](Self::effective_torques)). The row's deflection under the load
    /// is then `J(θ₀) C τ_eff`: what `identify` fits under gravity and `predict` returns.
    pub fn sagged_load(
        &mut self,
        compliance: &[f64],
        frame: RowFrame<'_>,
        wrench: &[f64],
        preload: &mut [f64],
        tau: &mut [f64],
        effective: &mut [f64],
    ) -> Result<(), VjmError> {
        let jacobian: &[f64] = {
            let RowFrame {
                jacobian,
                tip,
                tip_rotation,
            } = frame;
            self.sag(
                compliance,
                RowFrame {
                    jacobian: &mut *jacobian,
                    tip,
                    tip_rotation,
                },
                preload,
            )?;
            jacobian
        };
        for (k, t) in tau.iter_mut().enumerate() {
            let col = &jacobian[6 * k..6 * k + 6];
            *t = (0..6).map(|a| col[a] * wrench[a]).sum();
        }
        self.effective_torques(compliance, tau, effective)
    }
}

/// A measurement row's kinematics for [`GravityWorkspace::sag`]: the 6×m virtual-joint
/// Jacobian (column-major, base frame), the tip point and the tip rotation (base ← tip).
#[derive(Debug)]
pub struct RowFrame<'a> {
    /// 6×m Jacobian, column-major.
    pub jacobian: &'a mut [f64],
    /// Tip point, m.
    pub tip: &'a mut Vector3<f64>,
    /// Tip rotation.
    pub tip_rotation: &'a mut nalgebra::Matrix3<f64>,
}
