//! Non-linear gears: a joint's torsion spring whose deflection is a piecewise-linear curve of
//! the total torque it carries, the curve `diagnose` fits as `joint_torsion_nonlinear`.
//!
//! The torsion spring of joint j deflects under a total joint torque T (N·m: the weight's
//! preload plus the load's torque, positive in the spring's rotation sense) by
//!
//! ```text
//! θ(T) = c·T + Σ_k a_k h_k(T) + ½ b·sign(T),     h_k(T) = sign(T)·max(|T| − t_k, 0)
//! ```
//!
//! with c the spring's linear compliance (rad/(N·m), the model's parameter), knots t_k ≥ 0
//! (N·m), coefficients a_k (rad/(N·m): the change of the tangent compliance beyond knot k;
//! `a_k h_k(T)` is in rad) and the lost motion b ≥ 0 (rad, the width of the gear's dead band;
//! sign(0) = 0). The hinges are odd and continuous at T = 0, so a gear without lost motion is
//! one curve through the origin; the lost motion makes θ jump by b where the torque changes
//! sign, the diagnosis' `joint_backlash` (its column with `sign`, the mean deflection of a known
//! torque). A [`GearCurve`] holds the knots, the coefficients and the lost motion (a curve may
//! have lost motion and no knots: one joint, one curve); its [`excess`](GearCurve::excess) is
//! the part `Σ_k a_k h_k(T) + ½ b·sign(T)` beyond the linear spring.
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

/// sign(t) with sign(0) = 0 (and sign(−0) = 0, sign(NaN) = NaN).
pub fn signum0(t: f64) -> f64 {
    if t == 0.0 {
        0.0
    } else {
        t.signum()
    }
}

/// The torsion curve of one joint's gear: see the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct GearCurve {
    joint: usize,
    knots: Vec<f64>,
    coefficients: Vec<f64>,
    lost_motion: f64,
}

impl GearCurve {
    /// The curve of `joint` (0-based) with `knots` (N·m, finite, ≥ 0) and one coefficient per
    /// knot (rad/(N·m), finite), without lost motion. An error names the joint and the value.
    pub fn new(joint: usize, knots: Vec<f64>, coefficients: Vec<f64>) -> Result<Self, VjmError> {
        Self::with_lost_motion(joint, knots, coefficients, 0.0)
    }

    /// The curve of `joint` (0-based) with `knots` (N·m, finite, ≥ 0), one coefficient per
    /// knot (rad/(N·m), finite) and the lost motion `lost_motion` (rad, finite, ≥ 0). The knots
    /// may be empty when the lost motion is > 0 (a gear with backlash and a linear spring). An
    /// error names the joint and the value.
    pub fn with_lost_motion(
        joint: usize,
        knots: Vec<f64>,
        coefficients: Vec<f64>,
        lost_motion: f64,
    ) -> Result<Self, VjmError> {
        let bad = |message: String| {
            Err(VjmError::InvalidModel {
                message: format!("the gear curve of joint {}: {message}", joint + 1),
            })
        };
        if !(lost_motion.is_finite() && lost_motion >= 0.0) {
            return bad(format!(
                "the lost motion is {lost_motion} rad, it must be finite and ≥ 0"
            ));
        }
        if knots.len() != coefficients.len() || (knots.is_empty() && lost_motion == 0.0) {
            return bad(format!(
                "needs one coefficient per knot and at least one knot or a lost motion > 0, got \
                 {} knots, {} coefficients and a lost motion of {lost_motion} rad",
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
            // +0 for a −0 given: the curve, its file and its hash do not depend on the sign.
            lost_motion: lost_motion + 0.0,
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

    /// The lost motion b, rad (0 for a gear without backlash).
    pub fn lost_motion(&self) -> f64 {
        self.lost_motion
    }

    /// This curve with the lost motion `lost_motion` (rad, finite, ≥ 0) instead of its own;
    /// an error names the joint and the value.
    pub fn and_lost_motion(self, lost_motion: f64) -> Result<Self, VjmError> {
        Self::with_lost_motion(self.joint, self.knots, self.coefficients, lost_motion)
    }

    /// `Σ_k a_k h_k(t) + ½ b·sign(t)` (sign(0) = 0): the deflection (rad) beyond the linear
    /// spring's `c·t` at a total torque `t` (N·m). Without lost motion it is the hinges' sum,
    /// bit for bit.
    pub fn excess(&self, t: f64) -> f64 {
        self.excess_with_sign(t, signum0(t))
    }

    /// [`excess`](Self::excess) with `sign` (−1, 0 or 1) in place of sign(t) in the lost
    /// motion's term (the equilibrium's settled sign).
    pub(crate) fn excess_with_sign(&self, t: f64, sign: f64) -> f64 {
        let hinges: f64 = self
            .knots
            .iter()
            .zip(&self.coefficients)
            .map(|(&knot, &a)| a * hinge(t, knot))
            .sum();
        if self.lost_motion == 0.0 || sign == 0.0 {
            hinges
        } else {
            hinges + 0.5 * self.lost_motion * sign
        }
    }

    /// True when the curve bends nothing: every coefficient and the lost motion are 0 (its
    /// spring then deflects as a linear one, bit for bit).
    pub(crate) fn is_linear(&self) -> bool {
        self.lost_motion == 0.0 && self.coefficients.iter().all(|a| *a == 0.0)
    }

    /// The deflection of the spring of linear compliance `c` (rad/(N·m)) under a total torque
    /// `t` (N·m): `c·t + Σ_k a_k h_k(t) + ½ b·sign(t)`, rad.
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
