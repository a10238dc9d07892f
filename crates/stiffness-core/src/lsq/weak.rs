//! What the data determine: the weak directions of a least-squares estimate ([`WeakDirections`]).

use nalgebra::DMatrix;

use crate::decompose::{symmetric_eigen, NotConverged};

/// Eigenvalues of C_y below this fraction of the largest are the fit's null space (the estimate
/// has no component there): kept, they change nothing.
const NULL_EIGENVALUE: f64 = 1e-13;

/// What the data determine: the weak directions of a least-squares estimate and the estimate
/// without them.
///
/// A rank-revealing fit keeps every direction of the parameters whose singular value clears the
/// rank tolerance, however poorly the noise determines it. Along a direction the data barely see
/// the estimate is noise: ±0.15 rad/(N·m) on an arm whose compliances are 1e-4 (a 40-pose
/// campaign on an xArm7 with the 21-spring model). A linear prediction aᵀx along such a direction
/// is honest — its standard deviation says how little is known — but anything non-linear in x
/// (the static equilibrium under the arm's weight, the load's geometric stiffness K_C, a
/// Gauss–Newton compensation) amplifies the noise into nonsense or divergence. Those uses take
/// [`WeakDirections::determined`]: the estimate with its weak directions removed.
///
/// The directions are the principal axes of the covariance in the fit's column-scaled metric
/// (y = S·x, C_y = S·C·S = σ²(A_sᵀA_s)⁺): along axis v_i the estimate is t_i·√λ_i. An axis is
/// **weak** when
/// - its standard error exceeds its magnitude, |t_i| < 1 (the data cannot tell it from 0), or
/// - its standard error, in parameter units (√λ_i·‖S⁻¹v_i‖∞), exceeds `implausible` (the data
///   cannot tell it from any plausible value).
///
/// Removing a weak axis moves every prediction by less than about one of its standard errors
/// (first rule) or removes what no plausible model has (second rule).
#[derive(Debug, Clone, PartialEq)]
pub struct WeakDirections {
    /// Column scale S (‖A e_k‖), m values.
    scale: Vec<f64>,
    /// Unit weak axes v_i in the scaled coordinates y = S·x, each m values.
    axes: Vec<Vec<f64>>,
}

impl WeakDirections {
    /// The weak directions of estimate `x` (m values) with covariance `covariance` (m×m,
    /// row-major, parameter units) from a fit whose column scale is `scale` (m positive
    /// values): see [`WeakDirections`]. `implausible`: the largest standard
    /// error, in parameter units, a direction may have and still be used (`f64::INFINITY` for
    /// the first rule alone). Without a covariance (all zero, no noise scale) nothing is weak.
    ///
    /// ```
    /// use stiffness_core::lsq::WeakDirections;
    /// // Two parameters: the first well determined (1 ± 0.01), the second noise (0.2 ± 0.5).
    /// let x = [1.0, 0.2];
    /// let cov = [1e-4, 0.0, 0.0, 0.25];
    /// let weak = WeakDirections::of(&x, &cov, &[1.0, 1.0], f64::INFINITY)?;
    /// assert_eq!(weak.len(), 1);
    /// let d = weak.determined(&x);
    /// assert!((d[0] - 1.0).abs() < 1e-12 && d[1].abs() < 1e-12);
    /// # Ok::<(), stiffness_core::decompose::NotConverged>(())
    /// ```
    pub fn of(
        x: &[f64],
        covariance: &[f64],
        scale: &[f64],
        implausible: f64,
    ) -> Result<Self, NotConverged> {
        let m = x.len();
        let mut out = WeakDirections {
            scale: scale.to_vec(),
            axes: Vec::new(),
        };
        let usable = covariance.len() == m * m
            && scale.len() == m
            && scale.iter().all(|s| s.is_finite() && *s > 0.0)
            && covariance.iter().any(|c| *c != 0.0);
        if !usable {
            return Ok(out);
        }
        let c_y = DMatrix::from_fn(m, m, |i, j| scale[i] * covariance[i * m + j] * scale[j]);
        let eig = symmetric_eigen(c_y, "the covariance's principal axes")?;
        let largest = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
        for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
            if lambda <= NULL_EIGENVALUE * largest {
                continue;
            }
            let v = eig.eigenvectors.column(i);
            let along: f64 = (0..m).map(|k| v[k] * scale[k] * x[k]).sum();
            let stderr = lambda.sqrt();
            let in_units = (0..m).map(|k| (v[k] / scale[k]).abs()).fold(0.0, f64::max) * stderr;
            if along.abs() < stderr || in_units > implausible {
                out.axes.push(v.iter().cloned().collect());
            }
        }
        Ok(out)
    }

    /// Number of weak directions.
    pub fn len(&self) -> usize {
        self.axes.len()
    }

    /// Whether no direction is weak.
    pub fn is_empty(&self) -> bool {
        self.axes.is_empty()
    }

    /// `x` without its components along the weak directions (parameter units):
    /// S⁻¹(I − Σ v_i v_iᵀ)S·x. A linear projection, the same for every `x`, so that a fixed-point
    /// iteration on it (the identification under gravity) cannot flip a decision between steps.
    pub fn determined(&self, x: &[f64]) -> Vec<f64> {
        let mut y: Vec<f64> = x.iter().zip(&self.scale).map(|(a, s)| a * s).collect();
        for v in &self.axes {
            let along: f64 = v.iter().zip(&y).map(|(a, b)| a * b).sum();
            for (yk, vk) in y.iter_mut().zip(v) {
                *yk -= along * vk;
            }
        }
        y.iter().zip(&self.scale).map(|(a, s)| a / s).collect()
    }
}
