//! The static equilibrium of the virtual springs under the arm's weight and a tip load, on
//! the deflected chain (no linearisation): what a measurement under gravity records.
//!
//! The springs deflect by θ with `θ = C τ(θ)`, where C is the diagonal compliance (rad/(N·m)),
//! and `τ(θ)` is the torque on each spring at the deflected state. That torque is gravity's
//! (`w_k · (R_k × g)` with the deflected axes, centres and bodies) plus the wrench's
//! (`w_k · ((p − c_k) × F + M)`). The wrench is fixed in the base frame and applied at the
//! deflected tip point. A compliance of 0 is a rigid spring.
//!
//! Solved by chord iterations `θ ← θ + (I − C T₀)⁻¹ (C τ(θ) − θ)`, where T₀ = K_G + K_C is the
//! torque's tangent at θ = 0. They converge linearly, the step shrinking each time by a ratio
//! r that is ≈ 1e-5 for an arm's springs under its weight, and stop when the step, or the
//! geometric bound `step · r / (1 − r)` on the steps still to come, is below 1e-13 of the
//! largest deflection (three steps for a Panda); they are capped. The rigid kinematics, the
//! bodies and the tangent at θ = 0 come from a [`GravityWorkspace`]; every iterate's torques
//! from those moved to the deflection ([`DeflectedLoads`](super::deflected::DeflectedLoads),
//! O(m), no allocation). Test: `the_equilibrium_solves_theta_equals_c_tau_of_theta`
//! (θ = C τ(θ) to 1e-12, the torques from the deflected chain composed frame by frame).

use nalgebra::{DMatrix, Isometry3, Translation3};

use crate::chain::SerialChain;
use crate::contraction::Contraction;
use crate::error::VjmError;
use crate::gear::{torsion_springs, CurvedSprings, GearCurve};
use crate::kinematics::{check_wrench, complementary_stiffness_at, Workspace};
use crate::model::VirtualJointModel;
use crate::predict::check_spring_vector;
use crate::stiffness_model::PointMass;

use super::chord::ChordLu;
use super::deflected::{deflected_tip_rotation, DeflectedLoads};
use super::{Gravity, GravityWorkspace};

/// Iteration cap of [`static_equilibrium`].
pub const MAX_EQUILIBRIUM_ITERATIONS: usize = 100;

/// The band around zero torque, relative to the largest spring torque of the iterate, within
/// which a curved spring with lost motion sits in its dead band ([`static_equilibrium_with_gears`]).
pub const LOST_MOTION_TORQUE_BAND: f64 = 1e-9;

/// How many times the settled sign of a curved spring's torque may change during
/// [`static_equilibrium_with_gears`] before the joint is reported as not settling in its dead
/// band.
pub const MAX_LOST_MOTION_SIGN_CHANGES: usize = 4;

/// What loads the arm: its weight (with a payload) and a tip wrench, each optional.
#[derive(Debug, Clone, Copy, Default)]
pub struct Loading<'a> {
    /// Gravity in the base frame; `None` for a weightless arm.
    pub gravity: Option<Gravity>,
    /// A point mass in the tip frame (weighs only where `gravity` is set).
    pub payload: Option<&'a PointMass>,
    /// `[fx, fy, fz, mx, my, mz]` (N, N·m), base frame, at the (deflected) tip point.
    pub wrench: Option<[f64; 6]>,
}

/// A static equilibrium of the springs: deflections and the tip pose there.
#[derive(Debug, Clone)]
pub struct Equilibrium {
    /// Spring deflections θ, rad, in the model's order.
    pub theta: Vec<f64>,
    /// The tip pose at equilibrium, base frame.
    pub tip: Isometry3<f64>,
    /// Chord iterations taken.
    pub iterations: usize,
}

/// The torque on every spring at the deflected state `theta`, and the tip there, composed frame
/// by frame along the deflected chain: the slow, independent code path the fast one
/// ([`DeflectedLoads`]) and the equilibrium are checked against.
#[cfg(test)]
pub(crate) fn torques(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
    loading: &Loading<'_>,
) -> Result<(Vec<f64>, Isometry3<f64>), VjmError> {
    let state = crate::kinematics::deflected_state(chain, model, q, theta)?;
    let mut out = vec![0.0; model.n_params()];
    if let Some(g) = loading.gravity {
        let bodies = super::BodySums::new(
            chain.mass_model()?,
            &state.joint_frames,
            &state.tip,
            loading.payload,
        );
        let g = g.vector();
        for (k, s) in model.springs().iter().enumerate() {
            let (w, c) = state.springs[k];
            out[k] += bodies.torque(s, &w, &c, &g);
        }
    }
    if let Some(wr) = loading.wrench {
        let f = nalgebra::Vector3::new(wr[0], wr[1], wr[2]);
        let mo = nalgebra::Vector3::new(wr[3], wr[4], wr[5]);
        let p = state.tip.translation.vector;
        for (k, ((w, c), s)) in state.springs.iter().zip(model.springs()).enumerate() {
            // J_kᵀF with the spring's column (a translation's is [w; 0]).
            let (lin, ang) = crate::kinematics::column(w, c, &p, s.is_translation());
            out[k] += lin.dot(&f) + ang.dot(&mo);
        }
    }
    Ok((out, state.tip))
}

/// The static equilibrium of the springs of `model` with compliances `compliance` (rad/(N·m),
/// finite, one per spring) at joint positions `q` under `loading` (see the module docs).
/// An error when the iterations do not settle within [`MAX_EQUILIBRIUM_ITERATIONS`] (a load
/// beyond the arm's buckling, or compliances far from an arm's).
///
/// A negative entry is accepted: an identified model with aliased springs stores the
/// minimum-norm member of its family, whose entries may be negative although every combination
/// the data determine is physical. The fixed point θ = C·τ(θ) is the same equation for any
/// member, and the members agree on the tip to first order in the load; the iteration still
/// refuses a member whose equilibrium does not settle.
pub fn static_equilibrium(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q: &[f64],
    loading: &Loading<'_>,
) -> Result<Equilibrium, VjmError> {
    static_equilibrium_with_gears(chain, model, compliance, &[], q, loading)
}

/// [`static_equilibrium`] with non-linear gears: the torsion spring of each curve's joint
/// deflects by its curve of the torque it carries, `θ_k = c_k τ_k(θ) + Σ a h(τ_k(θ))`
/// ([`GearCurve`]), the other springs by `c_k τ_k(θ)`. The chord iterations keep the linear
/// tangent; the curve's share of the compliance times the load's stiffness sets their ratio.
/// Without curves it is [`static_equilibrium`], bit for bit.
///
/// Lost motion ([`GearCurve::lost_motion`]) makes θ(T) jump by b at T = 0. Each iteration
/// settles the sign s of every such spring's torque at the iterate and treats `½ b s` as a
/// fixed term, so the iterations converge as without it once the signs stay put (the weight's
/// preload usually fixes them from the first step). A torque within
/// [`LOST_MOTION_TORQUE_BAND`] × the iterate's largest spring torque of 0 counts as s = 0: the
/// gear carries no torque and sits anywhere in its dead band, and the equilibrium reports the
/// band's mid-point (`θ = c·T + Σ a h(T)`). A sign that changes more than
/// [`MAX_LOST_MOTION_SIGN_CHANGES`] times (the gear's own slack reverses its torque: the
/// joint rests inside its dead band at a torque the chord iterations do not find) is an error
/// naming the joint, as is any iterate that does not settle within the cap.
pub fn static_equilibrium_with_gears(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    gears: &[GearCurve],
    q: &[f64],
    loading: &Loading<'_>,
) -> Result<Equilibrium, VjmError> {
    let rest = match loading.gravity {
        Some(g) => {
            let mut ws = GravityWorkspace::new(chain, model, &g, loading.payload)?;
            ws.evaluate(chain, q)?;
            Some(ws)
        }
        None => None,
    };
    let springs = Compliances {
        linear: compliance,
        gears,
    };
    let mut scratch = EquilibriumScratch::default();
    let settled = equilibrium_from(
        chain,
        model,
        &springs,
        q,
        loading,
        rest.as_ref(),
        &mut scratch,
    )?;
    Ok(Equilibrium {
        theta: std::mem::take(&mut scratch.theta),
        tip: settled.tip,
        iterations: settled.iterations,
    })
}

/// How the springs of a model deflect: linearly with compliance `linear` (rad/(N·m), one per
/// spring; 0 = rigid), and the torsion springs of `gears`' joints by their curves.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Compliances<'a> {
    /// One per spring, rad/(N·m) (m/N for a translation).
    pub(crate) linear: &'a [f64],
    /// Non-linear gears ([`GearCurve`]), at most one per joint.
    pub(crate) gears: &'a [GearCurve],
}

/// Reusable buffers of [`equilibrium_from`]: one per thread of a batch, so that a row's
/// equilibrium allocates nothing once they are sized. `theta` holds the last equilibrium's
/// deflections.
#[derive(Debug, Clone, Default)]
pub(crate) struct EquilibriumScratch {
    /// The deflections θ of the last equilibrium, rad (m for a translation).
    pub(crate) theta: Vec<f64>,
    tau: Vec<f64>,
    residual: Vec<f64>,
    tangent: DMatrix<f64>,
    kc: DMatrix<f64>,
    loads: DeflectedLoads,
    chord: ChordLu,
    signs: Vec<Option<f64>>,
    changes: Vec<usize>,
}

/// Where an equilibrium put the tip (its deflections stay in the [`EquilibriumScratch`]).
pub(crate) struct Settled {
    /// The tip pose at equilibrium, base frame.
    pub(crate) tip: Isometry3<f64>,
    /// `[dx, dy, dz, rx, ry, rz]` (m, rad), base frame: the tip at equilibrium less the rigid
    /// tip (the rotation as the rotation vector of `R_eq · R_rigidᵀ`); exactly 0 when no spring
    /// deflects.
    pub(crate) from_rigid: [f64; 6],
    /// Chord iterations taken.
    pub(crate) iterations: usize,
}

/// [`static_equilibrium_with_gears`] given `rest`: a [`GravityWorkspace`] for the loading's
/// gravity and payload and this `model`, evaluated at `q` (`None` exactly when the loading has
/// no gravity), so that a batch that evaluates one per row anyway builds none here.
///
/// Every iterate's torques come from the rigid kinematics of `rest` (or of a workspace built
/// here without gravity) moved to the deflection by [`DeflectedLoads`] (O(m), no second pass
/// through the chain).
pub(crate) fn equilibrium_from(
    chain: &SerialChain,
    model: &VirtualJointModel,
    springs: &Compliances<'_>,
    q: &[f64],
    loading: &Loading<'_>,
    rest: Option<&GravityWorkspace>,
    scratch: &mut EquilibriumScratch,
) -> Result<Settled, VjmError> {
    // The weight (and its payload) comes from `rest` alone.
    debug_assert_eq!(rest.is_some(), loading.gravity.is_some());
    debug_assert!(rest
        .is_none_or(|r| r.gravity() == loading.gravity.unwrap_or_default()
            && r.payload() == loading.payload));
    let (compliance, gears) = (springs.linear, springs.gears);
    check_spring_vector(model, compliance)?;
    let torsions = torsion_springs(model, gears)?;
    let curved = CurvedSprings::new(gears, &torsions);
    let m = model.n_params();
    // The rigid kinematics at q: the weight's workspace's, or a weightless arm's own.
    let own;
    let ws = match rest {
        Some(r) => r.kinematics(),
        None => {
            chain.check_q(q, 0)?;
            let mut w = Workspace::new(chain, model)?;
            w.evaluate(chain, q);
            own = w;
            &own
        }
    };
    let bodies = rest.map(GravityWorkspace::bodies);
    let wrench = match loading.wrench {
        Some(w) => {
            check_wrench(&w, 0)?;
            Some(w)
        }
        None => None,
    };
    let EquilibriumScratch {
        theta,
        tau,
        residual,
        tangent,
        kc,
        loads,
        chord,
        signs,
        changes,
    } = scratch;
    factor_tangent(ws, rest, wrench.as_ref(), compliance, tangent, kc, chord)?;
    for v in [&mut *theta, &mut *tau, &mut *residual] {
        v.clear();
        v.resize(m, 0.0);
    }
    signs.clear();
    signs.resize(gears.len(), None);
    changes.clear();
    changes.resize(gears.len(), 0);
    let lost = curved.curves().iter().any(|g| g.lost_motion() != 0.0);
    // `signs`: the settled sign of each curve's torque, `changes`: how often it changed (lost
    // motion only).
    // The ratio of two steps bounds the error left (below).
    let mut steps = Contraction::new();
    for iteration in 1..=MAX_EQUILIBRIUM_ITERATIONS {
        loads.torques(ws, theta, bodies.as_ref(), wrench.as_ref(), tau);
        let r = &mut *residual;
        for k in 0..m {
            r[k] = compliance[k] * tau[k] - theta[k];
        }
        if lost {
            add_lost_motion_excess(&curved, tau, r, signs, changes)?;
        } else {
            curved.add_excess(tau, r);
        }
        chord.solve(r);
        let step = &*r;
        let size = step.iter().fold(0.0f64, |a, s| a.max(s.abs()));
        for k in 0..m {
            theta[k] += step[k];
        }
        if !theta.iter().all(|t| t.is_finite()) || theta.iter().any(|t| t.abs() > 0.5) {
            break; // diverging: more than 0.5 rad of spring deflection is no small deflection
        }
        let scale = theta.iter().fold(1e-300f64, |acc, t| acc.max(t.abs()));
        // Stop once the steps still to come (or this one) are below 1e-13 of the deflection.
        // The ratio is ≈ 1e-5 for an arm's springs, so this saves the last, rounding-sized
        // step; with lost motion the signs must have settled first.
        let left = steps.remaining(size, !lost || iteration > 2);
        if left <= 1e-13 * scale || size < 1e-300 {
            return Ok(settled_tip(chain, ws, loads, theta, tau, iteration));
        }
    }
    Err(VjmError::Numerical {
        message: format!(
            "the static equilibrium did not settle in {MAX_EQUILIBRIUM_ITERATIONS} iterations \
             (deflections beyond 0.5 rad or a load beyond the arm's buckling)"
        ),
    })
}

/// Writes the tangent of the spring torques at θ = 0 (gravity's stiffness from `rest` and the
/// wrench's K_C, using `kc` as scratch) into `tangent` and factors the chord matrix from it.
fn factor_tangent(
    ws: &Workspace,
    rest: Option<&GravityWorkspace>,
    wrench: Option<&[f64; 6]>,
    compliance: &[f64],
    tangent: &mut DMatrix<f64>,
    kc: &mut DMatrix<f64>,
    chord: &mut ChordLu,
) -> Result<(), VjmError> {
    let m = compliance.len();
    if tangent.shape() != (m, m) {
        *tangent = DMatrix::zeros(m, m);
    }
    match rest {
        Some(r) => tangent.copy_from(r.stiffness()),
        None => tangent.fill(0.0),
    }
    if let Some(w) = wrench {
        if kc.shape() != (m, m) {
            *kc = DMatrix::zeros(m, m);
        }
        complementary_stiffness_at(ws, w, kc.as_mut_slice());
        *tangent += &*kc;
    }
    if chord.factor(compliance, tangent) {
        Ok(())
    } else {
        Err(VjmError::Numerical {
            message: "the tangent of the static equilibrium is singular (a load at the arm's \
                      buckling limit?)"
                .to_string(),
        })
    }
}

/// Adds each gear curve's excess over its linear spring to the residual `r`, with the torque's
/// sign taken inside a band of the largest torque as 0 (the dead band of the lost motion).
/// `signs` holds each curve's last sign and `changes` how often it changed: a sign that keeps
/// changing is a joint resting inside its dead band, an error.
fn add_lost_motion_excess(
    curved: &CurvedSprings<'_>,
    tau: &[f64],
    r: &mut [f64],
    signs: &mut [Option<f64>],
    changes: &mut [usize],
) -> Result<(), VjmError> {
    let band = LOST_MOTION_TORQUE_BAND * tau.iter().fold(0.0f64, |a, t| a.max(t.abs()));
    for (i, (k, curve)) in curved.iter().enumerate() {
        let t = tau[k];
        let s = if curve.lost_motion() == 0.0 || t.abs() <= band {
            0.0
        } else {
            t.signum()
        };
        if signs[i].is_some_and(|p| p != s) {
            changes[i] += 1;
            if changes[i] > MAX_LOST_MOTION_SIGN_CHANGES {
                return Err(VjmError::Numerical {
                    message: format!(
                        "the static equilibrium did not settle: the torque of joint \
                         {}'s gear ({t:.3e} N·m) changes sign within its lost motion \
                         of {} rad (the joint rests inside its dead band)",
                        curve.joint() + 1,
                        curve.lost_motion()
                    ),
                });
            }
        }
        signs[i] = Some(s);
        let e = curve.excess_with_sign(t, s);
        if e != 0.0 {
            r[k] += e;
        }
    }
    Ok(())
}

/// The settled tip at the spring deflections `theta`: the sweep's deflected point, turned by the
/// springs' rotations (`tau` is scratch).
fn settled_tip(
    chain: &SerialChain,
    ws: &Workspace,
    loads: &mut DeflectedLoads,
    theta: &[f64],
    tau: &mut [f64],
    iterations: usize,
) -> Settled {
    let point = loads.torques(ws, theta, None, None, tau);
    let turn = DeflectedLoads::turn(ws, theta);
    let d = point - ws.p;
    let r = turn.scaled_axis();
    let rotation = deflected_tip_rotation(&turn, &ws.tip_rotation(chain));
    Settled {
        tip: Isometry3::from_parts(Translation3::from(point), rotation),
        from_rigid: [d.x, d.y, d.z, r.x, r.y, r.z],
        iterations,
    }
}

/// The tip's displacement from `from` to `to`: `[dx, dy, dz, rx, ry, rz]` (m, rad), base frame,
/// the rotation as the rotation vector of `R_to · R_fromᵀ`.
pub(crate) fn tip_difference(from: &Isometry3<f64>, to: &Isometry3<f64>) -> [f64; 6] {
    let d = to.translation.vector - from.translation.vector;
    let r = (to.rotation * from.rotation.inverse()).scaled_axis();
    [d.x, d.y, d.z, r.x, r.y, r.z]
}

/// The tip's static sag under the arm's own weight (and `payload`) relative to the rigid
/// forward kinematics at `q`: `[dx, dy, dz, rx, ry, rz]` (m, rad), base frame.
pub fn gravity_sag(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q: &[f64],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<[f64; 6], VjmError> {
    gravity_sag_with_gears(chain, model, compliance, &[], q, gravity, payload)
}

/// [`gravity_sag`] with non-linear gears ([`static_equilibrium_with_gears`]): each curved
/// spring sags by its curve at the torque it carries, θ(τ_g).
pub fn gravity_sag_with_gears(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    gears: &[GearCurve],
    q: &[f64],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<[f64; 6], VjmError> {
    let mut ws = GravityWorkspace::new(chain, model, gravity, payload)?;
    ws.evaluate(chain, q)?;
    let springs = Compliances {
        linear: compliance,
        gears,
    };
    gravity_sag_from(
        chain,
        model,
        &springs,
        q,
        &ws,
        &mut EquilibriumScratch::default(),
    )
}

/// [`gravity_sag_with_gears`] given `rest`, a [`GravityWorkspace`] of this `model` (with the
/// gravity and payload of the sag) evaluated at `q`, and reusable buffers.
pub(crate) fn gravity_sag_from(
    chain: &SerialChain,
    model: &VirtualJointModel,
    springs: &Compliances<'_>,
    q: &[f64],
    rest: &GravityWorkspace,
    scratch: &mut EquilibriumScratch,
) -> Result<[f64; 6], VjmError> {
    let loading = Loading {
        gravity: Some(rest.gravity()),
        payload: rest.payload(),
        wrench: None,
    };
    let settled = equilibrium_from(chain, model, springs, q, &loading, Some(rest), scratch)?;
    Ok(settled.from_rigid)
}

/// What a measurement under gravity records: the tip under `wrench` minus the tip unloaded,
/// both at the static equilibrium under the arm's weight (and `payload`):
/// `[dx, dy, dz, rx, ry, rz]` (m, rad), base frame.
pub fn deflection_under_gravity(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q: &[f64],
    wrench: &[f64; 6],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<[f64; 6], VjmError> {
    let loading = Loading {
        gravity: Some(*gravity),
        payload,
        wrench: Some(*wrench),
    };
    deflection_under_gravity_with_gears(chain, model, compliance, &[], q, &loading)
}

/// [`deflection_under_gravity`] with non-linear gears ([`static_equilibrium_with_gears`]):
/// each curved spring deflects by θ(τ_g + τ) − θ(τ_g). The tip under `loading` minus the tip
/// under the same loading without its wrench (no wrench: no deflection).
pub fn deflection_under_gravity_with_gears(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    gears: &[GearCurve],
    q: &[f64],
    loading: &Loading<'_>,
) -> Result<[f64; 6], VjmError> {
    let unloaded = Loading {
        wrench: None,
        ..*loading
    };
    let rest = static_equilibrium_with_gears(chain, model, compliance, gears, q, &unloaded)?;
    let loaded = static_equilibrium_with_gears(chain, model, compliance, gears, q, loading)?;
    Ok(tip_difference(&rest.tip, &loaded.tip))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixed point itself, not the iterations' own measure of progress: θ = C τ(θ) to
    /// 1e-12 of the deflection, whatever the loading (the weight alone starts from the
    /// workspace's torques; the error bound on the step ratio stops the iterations early).
    #[test]
    fn the_equilibrium_solves_theta_equals_c_tau_of_theta() {
        let chain = SerialChain::bundled();
        let payload = PointMass::new(2.0, [0.0, 0.05, 0.1]).unwrap();
        let gravity = Gravity::new([0.3, -0.2, -9.80665]).unwrap();
        let base = [1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4];
        for model in [
            VirtualJointModel::traditional(7),
            VirtualJointModel::extended(7),
            VirtualJointModel::full(7),
        ] {
            let c: Vec<f64> = model
                .springs()
                .iter()
                .map(|s| match (s.is_translation(), s.axis.index()) {
                    (true, _) => 1e-7,
                    (false, 0) => base[s.joint],
                    (false, _) => 0.3 * base[s.joint],
                })
                .collect();
            for (i, loading) in [
                Loading {
                    gravity: Some(gravity),
                    ..Default::default()
                },
                Loading {
                    gravity: Some(gravity),
                    payload: Some(&payload),
                    wrench: None,
                },
                Loading {
                    gravity: Some(gravity),
                    payload: None,
                    wrench: Some([20.0, -15.0, 30.0, 1.0, -2.0, 0.5]),
                },
            ]
            .iter()
            .enumerate()
            {
                for r in 0..5 {
                    let q: Vec<f64> = (0..7).map(|j| ((7 * r + j) as f64 * 0.618).sin()).collect();
                    let eq = static_equilibrium(&chain, &model, &c, &q, loading).unwrap();
                    let (tau, tip) = torques(&chain, &model, &q, &eq.theta, loading).unwrap();
                    let scale = eq.theta.iter().fold(0.0f64, |a, t| a.max(t.abs()));
                    assert!(scale > 1e-6, "a real deflection ({scale})");
                    for k in 0..model.n_params() {
                        let residual = (c[k] * tau[k] - eq.theta[k]).abs();
                        assert!(
                            residual <= 1e-12 * scale,
                            "{} springs, loading {i}, row {r}, spring {k}: θ − Cτ = {residual:e} \
                             of {scale:e}",
                            model.n_params()
                        );
                    }
                    assert!((tip.translation.vector - eq.tip.translation.vector).norm() < 1e-15);
                }
            }
        }
    }
}
