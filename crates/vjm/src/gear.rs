//! Non-linear gears: a joint's torsion spring whose deflection is a piecewise-linear curve of
//! the total torque it carries, the curve `diagnose` fits as `joint_torsion_nonlinear`.
//!
//! The torsion spring of joint j deflects under a total joint torque T (N·m: the weight's
//! preload plus the load's torque, positive in the spring's rotation sense) by
//!
//! ```text
//! θ(T) = c·T + Σ_k a_k h_k(T),     h_k(T) = sign(T)·max(|T| − t_k, 0)
//! ```
//!
//! with c the spring's linear compliance (rad/(N·m), the model's parameter), knots t_k ≥ 0
//! (N·m) and coefficients a_k (rad/(N·m): the change of the tangent compliance beyond knot k;
//! `a_k h_k(T)` is in rad). The hinges are odd and continuous at T = 0, so a gear without lost
//! motion is one curve through the origin. A [`GearCurve`] holds the knots and the
//! coefficients; its [`excess`](GearCurve::excess) is the part `Σ_k a_k h_k(T)` beyond the
//! linear spring.
//!
//! Under a load the spring deflects by `θ(τ_g + τ) − θ(τ_g)` (τ_g the preload of the weight);
//! the sag under the weight alone is `θ(τ_g)` from the rigid, unloaded arm
//! (`docs/gravity.md`, *Non-linear gears in the model*).

use crate::error::VjmError;
use crate::model::{Spring, SpringAxis, VirtualJointModel};

/// The hinge `h(t) = sign(t)·max(|t| − knot, 0)` (N·m) of a knot ≥ 0 (N·m): the one hinge
/// function of the diagnosis' `joint_torsion_nonlinear` column and of a [`GearCurve`].
pub fn hinge(t: f64, knot: f64) -> f64 {
    (t.abs() - knot).max(0.0).copysign(t)
}

/// The torsion curve of one joint's gear: see the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct GearCurve {
    joint: usize,
    knots: Vec<f64>,
    coefficients: Vec<f64>,
}

impl GearCurve {
    /// The curve of `joint` (0-based) with `knots` (N·m, finite, ≥ 0) and one coefficient per
    /// knot (rad/(N·m), finite). An error names the joint and the value.
    pub fn new(joint: usize, knots: Vec<f64>, coefficients: Vec<f64>) -> Result<Self, VjmError> {
        let bad = |message: String| {
            Err(VjmError::InvalidModel {
                message: format!("the gear curve of joint {}: {message}", joint + 1),
            })
        };
        if knots.is_empty() || knots.len() != coefficients.len() {
            return bad(format!(
                "needs one coefficient per knot and at least one knot, got {} knots and {} \
                 coefficients",
                knots.len(),
                coefficients.len()
            ));
        }
        if let Some(k) = knots.iter().position(|t| !(t.is_finite() && *t >= 0.0)) {
            return bad(format!(
                "knot {k} is {}, it must be finite and ≥ 0 N·m",
                knots[k]
            ));
        }
        if let Some(k) = coefficients.iter().position(|a| !a.is_finite()) {
            return bad(format!(
                "coefficient {k} is {}, it must be finite",
                coefficients[k]
            ));
        }
        Ok(GearCurve {
            joint,
            knots,
            coefficients,
        })
    }

    /// The joint, 0-based.
    pub fn joint(&self) -> usize {
        self.joint
    }
    /// The knots t_k, N·m.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }
    /// The coefficients a_k, rad/(N·m) (tangent compliance change beyond each knot).
    pub fn coefficients(&self) -> &[f64] {
        &self.coefficients
    }

    /// `Σ_k a_k h_k(t)`: the deflection (rad) beyond the linear spring's `c·t` at a total
    /// torque `t` (N·m).
    pub fn excess(&self, t: f64) -> f64 {
        self.knots
            .iter()
            .zip(&self.coefficients)
            .map(|(&knot, &a)| a * hinge(t, knot))
            .sum()
    }

    /// The deflection of the spring of linear compliance `c` (rad/(N·m)) under a total torque
    /// `t` (N·m): `c·t + Σ_k a_k h_k(t)`, rad.
    pub fn deflection(&self, c: f64, t: f64) -> f64 {
        c * t + self.excess(t)
    }
}

/// Gear curves placed on a model's springs: which spring each curve bends.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CurvedSprings<'a> {
    curves: &'a [GearCurve],
    springs: &'a [usize],
}

impl<'a> CurvedSprings<'a> {
    /// `curves` on the springs `springs` (from [`torsion_springs`], one per curve).
    pub(crate) fn new(curves: &'a [GearCurve], springs: &'a [usize]) -> Self {
        debug_assert_eq!(curves.len(), springs.len());
        CurvedSprings { curves, springs }
    }

    /// `(spring index, curve)` of every curve.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (usize, &'a GearCurve)> + 'a {
        self.springs.iter().copied().zip(self.curves.iter())
    }

    /// The curves, in the order given.
    pub(crate) fn curves(&self) -> &'a [GearCurve] {
        self.curves
    }

    /// The curve of spring `k`, if it has one.
    pub(crate) fn of(&self, k: usize) -> Option<&'a GearCurve> {
        self.iter().find(|(s, _)| *s == k).map(|(_, c)| c)
    }

    /// Adds each curved spring's [`excess`](GearCurve::excess) at its torque `torque[k]`
    /// (N·m) to `theta[k]` (rad). An excess of exactly 0 adds nothing (a curve of zero
    /// coefficients leaves `theta` as no curve does, bit for bit, a −0 included).
    pub(crate) fn add_excess(&self, torque: &[f64], theta: &mut [f64]) {
        for (k, curve) in self.iter() {
            let e = curve.excess(torque[k]);
            if e != 0.0 {
                theta[k] += e;
            }
        }
    }
}

/// The index in `model` of each curve's torsion spring (`J<joint>z`); an error names a joint
/// the model has no torsion spring at, or a joint curved twice.
pub fn torsion_springs(
    model: &VirtualJointModel,
    curves: &[GearCurve],
) -> Result<Vec<usize>, VjmError> {
    let mut out: Vec<usize> = Vec::with_capacity(curves.len());
    for curve in curves {
        let spring = Spring::rotation(curve.joint, SpringAxis::Z);
        let k = model
            .springs()
            .iter()
            .position(|s| *s == spring)
            .ok_or_else(|| VjmError::InvalidModel {
                message: format!(
                    "the gear curve of joint {} needs its torsion spring J{}z, which the model \
                     `{}` does not have",
                    curve.joint + 1,
                    curve.joint + 1,
                    model.name()
                ),
            })?;
        if out.contains(&k) {
            return Err(VjmError::InvalidModel {
                message: format!("joint {} has two gear curves", curve.joint + 1),
            });
        }
        out.push(k);
    }
    Ok(out)
}
