//! The loads' torques on the springs and the tip pose at a deflection θ, from the chain's rigid
//! kinematics at q: no second pass through the chain, no allocation once built, O(m) per
//! evaluation. The static equilibrium's inner step.
//!
//! The deflected chain is the rigid one moved by the springs' motions `E_k` about their
//! **rigid** base-frame axes a_k through their rigid centres c_k, composed base → tip (the
//! product of exponentials): a point carried beyond spring K moves to `E_1 ∘ ⋯ ∘ E_K (x)`, with
//! `E_k(y) = c_k + R_k (y − c_k)` for a rotation by θ_k and `E_k(y) = y + θ_k a_k` for a
//! translation. Spring k's deflected axis is then `G_{k−1} a_k` (`G_k = R_1 ⋯ R_k`), and the
//! torques need no deflected frame at all:
//!
//! - the weights on a rotation: `w'·(ℓ' × g) = a_k · (ℓ_k × G_{k−1}ᵀ g)`, where
//!   `ℓ_k = R_k Σ_b m_b (E_{k+1} ∘ ⋯ (x_b) − c_k)` sums the bodies beyond k moved by the
//!   springs after it (a sweep from the tip, the moment moving as one: each `E_k` is affine);
//! - the wrench on a rotation: `a_k · (ρ_k × G_{k−1}ᵀ f) + a_k · G_{k−1}ᵀ m`, with ρ_k the tip
//!   point moved the same way, less c_k;
//! - on a translation, `M_k a_k · G_{k−1}ᵀ g` (M_k the mass beyond it) and `a_k · G_{k−1}ᵀ f`;
//!
//! and `G_{k−1}ᵀ g`, `G_{k−1}ᵀ f`, `G_{k−1}ᵀ m` come from a sweep from the base. The tip moves
//! to `E_1 ∘ ⋯ ∘ E_m (p)` and turns by G_m. The slow, independent code path is
//! [`deflected_state`](crate::kinematics::deflected_state) (composed frame by frame):
//! `deflected_torques_and_tip_equal_the_deflected_chains` pins the two together.

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

use crate::kinematics::{rotation_minus_identity, sin_and_versine, Workspace};

/// The weights a chain carries at its rigid pose, base frame: per actuated joint the mass of
/// its body (kg) and its centre of mass (m), and the payload's.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RigidBodies<'a> {
    /// Per actuated joint, kg.
    pub(crate) mass: &'a [f64],
    /// Per actuated joint, the body's centre of mass at the rigid pose, base frame, m.
    pub(crate) point: &'a [Vector3<f64>],
    /// The payload's mass (kg) and its centre at the rigid pose (base frame, m).
    pub(crate) payload: Option<(f64, Vector3<f64>)>,
    /// Gravity, base frame, m/s².
    pub(crate) gravity: Vector3<f64>,
}

/// Scratch of [`DeflectedLoads::torques`]: per spring, its turn and the levers of the sweep
/// from the tip.
#[derive(Debug, Clone, Default)]
pub(crate) struct DeflectedLoads {
    /// `(sin θ_k, 1 − cos θ_k)` of each rotation (unused for a translation).
    turn: Vec<(f64, f64)>,
    /// ℓ_k: the weights' lever about c_k, turned by R_k (kg·m).
    lever: Vec<Vector3<f64>>,
    /// ρ_k: the tip point less c_k, turned by R_k (m).
    reach: Vec<Vector3<f64>>,
    /// M_k: the mass beyond spring k (kg).
    carried: Vec<f64>,
}

impl DeflectedLoads {
    /// Writes to `out` (m values) the torque of `bodies`' weight (when given) plus that of
    /// `wrench` (`[fx, fy, fz, mx, my, mz]`, N and N·m, base frame, at the deflected tip point;
    /// when given) on every spring of `ws` — a workspace evaluated at the rigid pose — at the
    /// deflection `theta` (rad or m, one per spring), and returns the deflected tip point (base
    /// frame, m).
    pub(crate) fn torques(
        &mut self,
        ws: &Workspace,
        theta: &[f64],
        bodies: Option<&RigidBodies<'_>>,
        wrench: Option<&[f64; 6]>,
        out: &mut [f64],
    ) -> Vector3<f64> {
        let m = theta.len();
        debug_assert_eq!(out.len(), m);
        debug_assert_eq!(ws.n_params(), m);
        self.turn.resize(m, (0.0, 0.0));
        self.lever.resize(m, Vector3::zeros());
        self.reach.resize(m, Vector3::zeros());
        self.carried.resize(m, 0.0);
        // Sweep from the tip: the moment L = Σ m_b z_b and mass M of the bodies beyond, and
        // the tip point P, each moved by the springs after the current one.
        let (mut moment, mut mass) = (Vector3::zeros(), 0.0);
        if let Some((pm, pp)) = bodies.and_then(|b| b.payload) {
            moment += pp * pm;
            mass += pm;
        }
        let mut tip = ws.p;
        let mut next_body = bodies.map_or(0, |b| b.mass.len());
        for k in (0..m).rev() {
            if let Some(b) = bodies {
                // The bodies whose last spring is k: joints from k's up to the next spring's.
                while next_body > ws.spring_joint[k] {
                    next_body -= 1;
                    moment += b.point[next_body] * b.mass[next_body];
                    mass += b.mass[next_body];
                }
            }
            self.carried[k] = mass;
            let (a, t) = (ws.w[k], theta[k]);
            if ws.translation[k] {
                if t != 0.0 {
                    moment += a * (t * mass);
                    tip += a * t;
                }
                continue;
            }
            let c = ws.c[k];
            let mut lever = moment - c * mass;
            let mut reach = tip - c;
            if t != 0.0 {
                let (s, v) = sin_and_versine(t);
                self.turn[k] = (s, v);
                lever += rotation_minus_identity(&a, s, v, &lever);
                reach += rotation_minus_identity(&a, s, v, &reach);
                // Only a turned spring moves them: `(x − c) + c` need not be x in floating
                // point, and an undeflected chain's tip must be the rigid one exactly.
                moment = lever + c * mass;
                tip = reach + c;
            }
            self.lever[k] = lever;
            self.reach[k] = reach;
        }
        // Sweep from the base: gravity and the wrench in the frame G_{k−1}ᵀ.
        let mut g = bodies.map(|b| b.gravity);
        let mut fm = wrench.map(|w| {
            (
                Vector3::new(w[0], w[1], w[2]),
                Vector3::new(w[3], w[4], w[5]),
            )
        });
        for k in 0..m {
            let a = ws.w[k];
            let mut tau = 0.0;
            if ws.translation[k] {
                if let Some(g) = &g {
                    tau += self.carried[k] * a.dot(g);
                }
                if let Some((f, _)) = &fm {
                    tau += a.dot(f);
                }
                out[k] = tau;
                continue;
            }
            if let Some(g) = &g {
                tau += a.dot(&self.lever[k].cross(g));
            }
            if let Some((f, mo)) = &fm {
                tau += a.dot(&self.reach[k].cross(f)) + a.dot(mo);
            }
            out[k] = tau;
            if theta[k] != 0.0 {
                // Rᵀ = I − sin θ [a]× + (1 − cos θ) [a]×².
                let (s, v) = self.turn[k];
                if let Some(g) = &mut g {
                    *g += rotation_minus_identity(&a, -s, v, g);
                }
                if let Some((f, mo)) = &mut fm {
                    *f += rotation_minus_identity(&a, -s, v, f);
                    *mo += rotation_minus_identity(&a, -s, v, mo);
                }
            }
        }
        tip
    }

    /// The rotation G_m = R_1 ⋯ R_m the springs of `ws` (evaluated at the rigid pose) turn the
    /// tip by at the deflection `theta`, base frame (the deflected tip rotation is G_m times
    /// the rigid one).
    pub(crate) fn turn(ws: &Workspace, theta: &[f64]) -> UnitQuaternion<f64> {
        let mut q = Quaternion::identity();
        for (k, &t) in theta.iter().enumerate() {
            if ws.translation[k] || t == 0.0 {
                continue;
            }
            // (cos θ/2, sin θ/2 · a), the cosine as 1 − versine to keep its digits.
            let (s, v) = sin_and_versine(0.5 * t);
            let a = ws.w[k] * s;
            q *= Quaternion::new(1.0 - v, a.x, a.y, a.z);
        }
        UnitQuaternion::new_normalize(q)
    }
}

/// The deflected tip rotation (base ← tip): `turn` times the rigid `tip_rotation`.
pub(crate) fn deflected_tip_rotation(
    turn: &UnitQuaternion<f64>,
    tip_rotation: &Matrix3<f64>,
) -> UnitQuaternion<f64> {
    // Closed form (Shepperd), not nalgebra's iterative `from_matrix`.
    turn * UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*tip_rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gravity::{equilibrium::torques, Gravity, GravityWorkspace, Loading};
    use crate::kinematics::deflected_state;
    use crate::stiffness_model::PointMass;
    use crate::{SerialChain, VirtualJointModel};

    /// The sweeps against the deflected chain composed frame by frame, at deflections from
    /// 1e-6 to 0.3 rad (where `sin_and_versine` leaves its series), for every kind of spring,
    /// with spring offsets, a payload, an oblique gravity and a wrench.
    #[test]
    fn deflected_torques_and_tip_equal_the_deflected_chains() {
        let chain = SerialChain::bundled();
        let payload = PointMass::new(1.5, [0.02, -0.03, 0.12]).unwrap();
        let gravity = Gravity::new([1.2, -0.7, -9.7]).unwrap();
        let wrench = [25.0, -10.0, 40.0, 1.5, -0.8, 2.0];
        let offsets: Vec<Vector3<f64>> = (0..7)
            .map(|j| Vector3::new(0.01 * j as f64, -0.02, 0.03 * (j % 3) as f64))
            .collect();
        for model in [
            VirtualJointModel::traditional(7),
            VirtualJointModel::extended(7),
            VirtualJointModel::full(7),
            VirtualJointModel::full(7).with_offsets(offsets).unwrap(),
            // Springs on some joints only: the bodies before the first spring never move.
            VirtualJointModel::from_springs(
                7,
                vec![
                    crate::Spring::rotation(2, crate::SpringAxis::X),
                    crate::Spring::rotation(4, crate::SpringAxis::Z),
                ],
            )
            .unwrap(),
        ] {
            let m = model.n_params();
            let mut g = GravityWorkspace::new(&chain, &model, &gravity, Some(&payload)).unwrap();
            let mut loads = DeflectedLoads::default();
            let mut fast = vec![0.0; m];
            for (r, size) in [1e-6, 1e-4, 3e-2, 0.3].into_iter().enumerate() {
                let q: Vec<f64> = (0..7).map(|j| ((7 * r + j) as f64 * 0.77).sin()).collect();
                let theta: Vec<f64> = (0..m)
                    .map(|k| size * ((k * 13 + r) as f64 * 0.41).cos())
                    .collect();
                g.evaluate(&chain, &q).unwrap();
                let loading = Loading {
                    gravity: Some(gravity),
                    payload: Some(&payload),
                    wrench: Some(wrench),
                };
                let (slow, _) = torques(&chain, &model, &q, &theta, &loading).unwrap();
                let bodies = g.bodies();
                let ws = g.kinematics();
                let point = loads.torques(ws, &theta, Some(&bodies), Some(&wrench), &mut fast);
                let scale = slow.iter().fold(0.0f64, |a, t| a.max(t.abs()));
                for k in 0..m {
                    assert!(
                        (fast[k] - slow[k]).abs() <= 1e-12 * scale,
                        "{} springs, θ ~ {size}: spring {k} torque {} vs {}",
                        m,
                        fast[k],
                        slow[k]
                    );
                }
                let state = deflected_state(&chain, &model, &q, &theta).unwrap();
                assert!((point - state.tip.translation.vector).norm() < 1e-14);
                let rotation = deflected_tip_rotation(
                    &DeflectedLoads::turn(ws, &theta),
                    &ws.tip_rotation(&chain),
                );
                assert!(
                    rotation.angle_to(&state.tip.rotation) < 1e-14,
                    "{m} springs, θ ~ {size}"
                );
                // Gravity alone and the wrench alone add up to both.
                let mut apart = vec![0.0; m];
                loads.torques(ws, &theta, Some(&bodies), None, &mut fast);
                loads.torques(ws, &theta, None, Some(&wrench), &mut apart);
                for k in 0..m {
                    assert!((fast[k] + apart[k] - slow[k]).abs() <= 1e-12 * scale);
                }
            }
        }
    }

    /// An undeflected chain's tip is the rigid one bit for bit: a rigid model (all compliances
    /// 0) and a weightless sag are exactly zero, with spring offsets and a payload.
    #[test]
    fn an_undeflected_chain_sags_by_exactly_zero() {
        let chain = SerialChain::bundled();
        let payload = PointMass::new(1.5, [0.02, -0.03, 0.12]).unwrap();
        let offsets: Vec<Vector3<f64>> = (0..7)
            .map(|j| Vector3::new(0.013 * j as f64, -0.021, 0.037 * (j % 3) as f64))
            .collect();
        let model = VirtualJointModel::full(7).with_offsets(offsets).unwrap();
        let m = model.n_params();
        for r in 0..20 {
            let q: Vec<f64> = (0..7)
                .map(|j| ((7 * r + j) as f64 * 0.91).sin() * 2.0)
                .collect();
            let rigid = crate::gravity::gravity_sag(
                &chain,
                &model,
                &vec![0.0; m],
                &q,
                &Gravity::default(),
                Some(&payload),
            )
            .unwrap();
            assert_eq!(rigid, [0.0; 6], "rigid model, row {r}");
            let weightless = crate::gravity::gravity_sag(
                &chain,
                &model,
                &vec![1e-4; m],
                &q,
                &Gravity::new([0.0; 3]).unwrap(),
                None,
            )
            .unwrap();
            assert_eq!(weightless, [0.0; 6], "weightless, row {r}");
        }
    }

    /// A workspace evaluated on a chain with other link masses (same joints) gives that chain's
    /// torques, as a fresh one does: the masses are read at each evaluation.
    #[test]
    fn a_reused_workspace_takes_the_masses_of_the_chain_it_is_given() {
        let chain = SerialChain::bundled();
        let heavier = chain
            .clone()
            .with_masses(
                crate::gravity::MassModel::new(
                    chain
                        .mass_model()
                        .unwrap()
                        .bodies()
                        .iter()
                        .map(|b| crate::gravity::Body {
                            mass: 2.0 * b.mass + 0.5,
                            com: b.com,
                        })
                        .collect(),
                )
                .unwrap(),
            )
            .unwrap();
        let model = VirtualJointModel::extended(7);
        let g = Gravity::default();
        let q = [0.3, -0.4, 0.2, -1.9, 0.1, 1.5, 0.7];
        let mut reused = GravityWorkspace::new(&chain, &model, &g, None).unwrap();
        reused.evaluate(&chain, &q).unwrap();
        reused.evaluate(&heavier, &q).unwrap();
        let mut fresh = GravityWorkspace::new(&heavier, &model, &g, None).unwrap();
        fresh.evaluate(&heavier, &q).unwrap();
        assert_eq!(reused.torques(), fresh.torques());
        let (mut a, mut b) = (vec![0.0; 21], vec![0.0; 21]);
        let theta = vec![1e-3; 21];
        let mut loads = DeflectedLoads::default();
        loads.torques(
            reused.kinematics(),
            &theta,
            Some(&reused.bodies()),
            None,
            &mut a,
        );
        loads.torques(
            fresh.kinematics(),
            &theta,
            Some(&fresh.bodies()),
            None,
            &mut b,
        );
        assert_eq!(a, b);
    }
}
