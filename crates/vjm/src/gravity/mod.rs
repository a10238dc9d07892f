//! Gravity: the weight of the bodies a chain carries, as generalized forces on the virtual
//! springs and as their stiffness (the Hessian of the gravitational potential).
//!
//! Conventions (docs/gravity.md):
//! - [`Gravity`] is the acceleration of free fall in **base-frame** components, m/s²; the
//!   default is 9.80665 m/s² along −z of the base (a floor-mounted arm whose base z points up).
//! - The gravitational potential is `U_g(θ) = −Σ_b m_b gᵀ x_b(θ)`, with `x_b` the base-frame
//!   centre of mass of body b at the virtual-joint deflection θ (joint angles q fixed).
//! - [`gravity_torques`]: `τ_g = −∂U_g/∂θ` at θ = 0, the torque the weights apply to each
//!   spring, positive in the spring's rotation sense (N·m). For spring k at joint j,
//!   `τ_k = w_k · (R_k × g)` with `R_k = Σ_{b ≥ j} m_b (x_b − c_k)`.
//! - [`gravity_stiffness`]: `K_G = ∂τ_g/∂θ = −∂²U_g/∂θ²` at θ = 0 (N·m/rad), symmetric, the
//!   same sign convention as [`complementary_stiffness`](crate::complementary_stiffness):
//!   the tangent stiffness of the virtual joints under gravity and a tip wrench W is
//!   `K_θ − K_G(q) − K_C(q, W)`.
//!
//! A payload is a [`PointMass`] in the tip frame; it is
//! one more body on the last joint.

mod chord;
pub(crate) mod deflected;
mod equilibrium;
pub(crate) mod mass;
mod workspace;

pub use equilibrium::{
    deflection_under_gravity, deflection_under_gravity_with_gears, gravity_sag,
    gravity_sag_with_gears, static_equilibrium, static_equilibrium_with_gears, Equilibrium,
    Loading, LOST_MOTION_TORQUE_BAND, MAX_EQUILIBRIUM_ITERATIONS, MAX_LOST_MOTION_SIGN_CHANGES,
};
pub(crate) use equilibrium::{equilibrium_from, gravity_sag_from, Compliances, EquilibriumScratch};
pub use mass::{Body, MassModel};
pub use workspace::{GravityWorkspace, RowFrame, MAX_COUPLING_ITERATIONS};

use nalgebra::{DMatrix, Point3, Vector3};

use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::kinematics::deflected_state;
use crate::model::VirtualJointModel;
use crate::stiffness_model::{PointMass, GRAVITY};

/// The acceleration of free fall in base-frame components, m/s².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gravity {
    vector: Vector3<f64>,
}

/// Written as its base-frame vector `[gx, gy, gz]`, m/s² (a campaign's spec, a plan's noise
/// model).
impl serde::Serialize for Gravity {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        [self.vector.x, self.vector.y, self.vector.z].serialize(s)
    }
}

impl Default for Gravity {
    /// [`GRAVITY`] (9.80665 m/s²) along −z of the base.
    fn default() -> Self {
        Self {
            vector: Vector3::new(0.0, 0.0, -GRAVITY),
        }
    }
}

impl Gravity {
    /// Gravity `[gx, gy, gz]` in base-frame components, m/s² (finite; e.g. `[0, 0, 9.80665]`
    /// for a ceiling-mounted arm, `[-9.80665, 0, 0]` for one on a wall whose base x points up).
    pub fn new(vector: [f64; 3]) -> Result<Self, VjmError> {
        if let Some(i) = vector.iter().position(|g| !g.is_finite()) {
            return Err(VjmError::InvalidOption {
                name: "gravity",
                message: format!(
                    "component {} = {:e} m/s² is not finite",
                    ["gx", "gy", "gz"][i],
                    vector[i]
                ),
            });
        }
        Ok(Self {
            vector: Vector3::from(vector),
        })
    }

    /// The vector, m/s², base frame.
    pub fn vector(&self) -> Vector3<f64> {
        self.vector
    }
}

/// Per actuated joint j, the mass and first moment (base frame) of everything joint j carries:
/// its body and every body after it, with the payload on the last joint.
#[derive(Debug, Clone, Default)]
pub(crate) struct BodySums {
    mass: Vec<f64>,
    moment: Vec<Vector3<f64>>,
}

impl BodySums {
    /// From the bodies' frames (`frames[j]`: joint j's child frame in the base frame) and the
    /// tip pose, undeflected or deflected alike (the slow path's, in tests).
    #[cfg(test)]
    pub(crate) fn new(
        masses: &MassModel,
        frames: &[nalgebra::Isometry3<f64>],
        tip: &nalgebra::Isometry3<f64>,
        payload: Option<&PointMass>,
    ) -> Self {
        let (mass, point): (Vec<f64>, Vec<Vector3<f64>>) = masses
            .bodies()
            .iter()
            .zip(frames)
            .map(|(b, f)| (b.mass, (f * Point3::from(b.com)).coords))
            .unzip();
        let payload = payload.map(|p| (p.mass(), (tip * Point3::from(p.centre())).coords));
        let mut sums = Self::default();
        sums.fill(&mass, &point, payload);
        sums
    }

    /// From each joint's body mass (kg) and centre of mass (base frame, m) and the payload's,
    /// reusing the buffers.
    pub(crate) fn fill(
        &mut self,
        mass: &[f64],
        point: &[Vector3<f64>],
        payload: Option<(f64, Vector3<f64>)>,
    ) {
        let n = mass.len();
        self.mass.clear();
        self.mass.resize(n + 1, 0.0);
        self.moment.clear();
        self.moment.resize(n + 1, Vector3::zeros());
        if let Some((pm, pp)) = payload {
            self.mass[n] = pm;
            self.moment[n] = pp * pm;
        }
        for j in (0..n).rev() {
            self.mass[j] = self.mass[j + 1] + mass[j];
            self.moment[j] = self.moment[j + 1] + point[j] * mass[j];
        }
    }

    /// `R = Σ_{b ≥ j} m_b (x_b − c)` (kg·m): the weights' lever about the point `c` for a
    /// spring at joint j.
    pub(crate) fn lever(&self, joint: usize, c: &Vector3<f64>) -> Vector3<f64> {
        self.moment[joint] - c * self.mass[joint]
    }

    /// `M = Σ_{b ≥ j} m_b` (kg): the mass a translational spring at joint j carries.
    pub(crate) fn mass(&self, joint: usize) -> f64 {
        self.mass[joint]
    }

    /// `−∂U/∂θ` of spring `spring` with axis `w` through `c` (base frame), N·m or N: a
    /// rotation's `w · (R × g)`, a translation's `M (w · g)` (it lifts the mass beyond it).
    pub(crate) fn torque(
        &self,
        spring: &crate::model::Spring,
        w: &Vector3<f64>,
        c: &Vector3<f64>,
        g: &Vector3<f64>,
    ) -> f64 {
        if spring.is_translation() {
            self.mass(spring.joint) * w.dot(g)
        } else {
            w.dot(&self.lever(spring.joint, c).cross(g))
        }
    }
}

/// The torques of gravity on the virtual springs at joint positions `q` (rad) and θ = 0:
/// `τ_g = −∂U_g/∂θ`, one per spring of `model`, N·m, positive in the spring's rotation sense
/// (see the [module docs](self)). The bodies are the chain's [`mass_model`](SerialChain::mass_model);
/// `payload` adds a point mass in the tip frame.
///
/// ```
/// use vjm::{gravity::{gravity_torques, Body, Gravity, MassModel}, SerialChain, VirtualJointModel};
/// use nalgebra::{Isometry3, Vector3};
/// // One horizontal link of 2 kg with its centre 0.5 m out along x, about a joint with axis y.
/// let chain = SerialChain::from_joints("base", "tip",
///     vec![("j1".into(), Isometry3::identity(), Vector3::y(), (-3.0, 3.0))], Isometry3::identity())
///     .unwrap()
///     .with_masses(MassModel::new(vec![Body { mass: 2.0, com: Vector3::new(0.5, 0.0, 0.0) }]).unwrap())
///     .unwrap();
/// let tau = gravity_torques(&chain, &VirtualJointModel::traditional(1), &[0.0], &Gravity::default(), None).unwrap();
/// // The weight 2·9.80665 N at 0.5 m pulls the link down: a positive rotation about +y.
/// assert!((tau[0] - 2.0 * 9.80665 * 0.5).abs() < 1e-12);
/// ```
pub fn gravity_torques(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<Vec<f64>, VjmError> {
    let mut ws = GravityWorkspace::new(chain, model, gravity, payload)?;
    ws.evaluate(chain, q)?;
    Ok(ws.torques().to_vec())
}

/// The stiffness of gravity `K_G = ∂τ_g/∂θ` (m×m, N·m/rad, symmetric) at joint positions `q`
/// and θ = 0 (see the [module docs](self) for the sign).
///
/// For springs i earlier than k in the model's order (upstream, or earlier at the same joint)
/// `K_G[i,k] = K_G[k,i] = (w_i·R_k)(w_k·g) − (w_i·w_k)(R_k·g)`; the diagonal is the same with
/// i = k. Checked against finite differences of the potential along
/// [`forward_kinematics_deflected`](crate::forward_kinematics_deflected)'s frames.
pub fn gravity_stiffness(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<DMatrix<f64>, VjmError> {
    let mut ws = GravityWorkspace::new(chain, model, gravity, payload)?;
    ws.evaluate(chain, q)?;
    Ok(ws.stiffness().clone())
}

/// The gravitational potential `U_g(θ) = −Σ_b m_b gᵀ x_b(θ)` (J) at joint positions `q` and
/// virtual-joint deflections `theta`, evaluated on the deflected chain (the slow, independent
/// code path of [`forward_kinematics_deflected`](crate::forward_kinematics_deflected)); its
/// derivatives are [`gravity_torques`] (with the opposite sign) and [`gravity_stiffness`].
pub fn gravity_potential_deflected(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<f64, VjmError> {
    let masses = chain.mass_model()?;
    let state = deflected_state(chain, model, q, theta)?;
    let g = gravity.vector();
    let mut u = 0.0;
    for (b, frame) in masses.bodies().iter().zip(&state.joint_frames) {
        u -= b.mass * g.dot(&(frame * Point3::from(b.com)).coords);
    }
    if let Some(p) = payload {
        u -= p.mass() * g.dot(&(state.tip * Point3::from(p.centre())).coords);
    }
    Ok(u)
}
