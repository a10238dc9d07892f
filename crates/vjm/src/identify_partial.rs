//! Partial identification statistics: the streaming factor of one part of a campaign, so that
//! parts identified separately (other threads, processes or machines) merge into the
//! identification of the whole.
//!
//! A part's statistic is the triangular factor R of its whitened rows `[A b]` (TSQR, see
//! [`crate::lsq::TriangularAccumulator`]); merging two parts folds one R into the other, which
//! is the QR of the stacked rows computed in pieces. So merging is associative up to rounding,
//! and [`IdentificationPartial::finish`] gives the single-pass [`SolveMethod::Qr`]
//! identification of all the rows (to rounding: ~1e-15 relative on well-conditioned designs).

use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::identify::{accumulate, identify_from_factor, Identification, IdentifyOptions};
use crate::lsq::{TriangularAccumulator, TriangularFactor};
use crate::measurements::Measurements;
use crate::model::VirtualJointModel;

/// The identification statistics of some of a campaign's measurements (see the module docs).
///
/// ```
/// use vjm::{IdentificationPartial, IdentifyOptions, SerialChain, VirtualJointModel};
/// # fn data(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
/// #     let chain = SerialChain::bundled();
/// #     let model = VirtualJointModel::traditional(7);
/// #     let c = [1e-4, 1e-4, 1.5e-4, 1.5e-4, 3e-4, 4e-4, 5e-4];
/// #     let (mut q, mut w, mut d) = (vec![], vec![], vec![]);
/// #     for i in 0..n {
/// #         let qi: Vec<f64> = (0..7).map(|j| ((i * 7 + j * 3) % 11) as f64 * 0.1 - 0.5).collect();
/// #         let wi = [10.0 + i as f64, -5.0, 20.0, 1.0, (i % 3) as f64, -1.0];
/// #         let di = vjm::predict_deflection(&chain, &model, &c, &qi, &wi, false).unwrap();
/// #         q.extend(qi); w.extend(wi); d.extend(&di[..3]);
/// #     }
/// #     (q, w, d)
/// # }
/// let chain = SerialChain::bundled();
/// let model = VirtualJointModel::traditional(7);
/// let opts = IdentifyOptions::default();
/// let (q, w, d) = data(60);
/// // Two parts of 30 measurements, merged, then solved.
/// let a = IdentificationPartial::accumulate(&chain, &model, vjm::Measurements::new(&q[..210], &w[..180], &d[..90]), &opts).unwrap();
/// let b = IdentificationPartial::accumulate(&chain, &model, vjm::Measurements::new(&q[210..], &w[180..], &d[90..]), &opts).unwrap();
/// let id = a.merge(&b).unwrap().finish(&chain).unwrap();
/// assert_eq!(id.n_equations, 180);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct IdentificationPartial {
    model: VirtualJointModel,
    opts: IdentifyOptions,
    /// [`crate::kinematics_sha256`] of the chain the rows were computed on.
    kinematics: String,
    factor: TriangularFactor,
    measurements: usize,
}

impl IdentificationPartial {
    /// The statistics of no measurement: the neutral element of [`merge`](Self::merge).
    pub fn empty(
        chain: &SerialChain,
        model: &VirtualJointModel,
        opts: &IdentifyOptions,
    ) -> Result<Self, VjmError> {
        model.check_chain(chain)?;
        Ok(Self {
            model: model.clone(),
            opts: *opts,
            kinematics: crate::kinematics_sha256(chain),
            factor: TriangularAccumulator::new(model.n_params() + 1).finish(),
            measurements: 0,
        })
    }

    /// The statistics of the measurements given (same inputs, units and checks as
    /// [`crate::identify`]; `opts.method` is not used: parts always reduce by QR).
    pub fn accumulate(
        chain: &SerialChain,
        model: &VirtualJointModel,
        data: Measurements<'_>,
        opts: &IdentifyOptions,
    ) -> Result<Self, VjmError> {
        let factor = accumulate(chain, model, data, opts)?;
        Ok(Self {
            model: model.clone(),
            opts: *opts,
            kinematics: crate::kinematics_sha256(chain),
            factor,
            measurements: data.q().len() / chain.n_joints(),
        })
    }

    /// Rebuilds a partial from its parts (as returned by [`factor`](Self::factor) and
    /// [`measurements`](Self::measurements)), e.g. after it was sent to another process.
    /// `r` is the (m+1)×(m+1) upper-triangular factor, row-major; `equations` the number of
    /// whitened rows it summarises.
    pub fn from_parts(
        chain: &SerialChain,
        model: &VirtualJointModel,
        opts: &IdentifyOptions,
        r: Vec<f64>,
        equations: usize,
        measurements: usize,
    ) -> Result<Self, VjmError> {
        model.check_chain(chain)?;
        let factor = TriangularFactor::from_upper(model.n_params() + 1, r, equations)?;
        if let Some(bad) = factor.r().iter().position(|v| !v.is_finite()) {
            let p = factor.ncols();
            return Err(VjmError::NonFinite {
                what: "partial identification factor",
                row: bad / p,
                column: bad % p,
                value: factor.r()[bad],
            });
        }
        Ok(Self {
            model: model.clone(),
            opts: *opts,
            kinematics: crate::kinematics_sha256(chain),
            factor,
            measurements,
        })
    }

    /// The statistics of both parts' measurements (the parts must be disjoint). Associative:
    /// `a.merge(b).merge(c)` and `a.merge(b.merge(c))` agree to rounding.
    pub fn merge(&self, other: &Self) -> Result<Self, VjmError> {
        self.check_compatible(other)?;
        let mut acc = TriangularAccumulator::from_factor(self.factor.clone());
        acc.merge(TriangularAccumulator::from_factor(other.factor.clone()))?;
        Ok(Self {
            factor: acc.finish(),
            measurements: self.measurements + other.measurements,
            ..self.clone()
        })
    }

    /// The identification of all the measurements merged in, on `chain` (the robot the parts
    /// were computed on; checked).
    pub fn finish(&self, chain: &SerialChain) -> Result<Identification, VjmError> {
        let kinematics = crate::kinematics_sha256(chain);
        if kinematics != self.kinematics {
            return Err(VjmError::IncompatiblePartials {
                what: "robot kinematics",
                left: short(&self.kinematics),
                right: short(&kinematics),
            });
        }
        identify_from_factor(chain, &self.model, &self.factor, &self.opts)
    }

    /// The model whose springs are identified.
    pub fn model(&self) -> &VirtualJointModel {
        &self.model
    }

    /// The options the rows were whitened with (and the solve will use).
    pub fn options(&self) -> &IdentifyOptions {
        &self.opts
    }

    /// The accumulated factor: R, (m+1)×(m+1), and the number of whitened rows.
    pub fn factor(&self) -> &TriangularFactor {
        &self.factor
    }

    /// Number of measurements (rows of the inputs) merged in.
    pub fn measurements(&self) -> usize {
        self.measurements
    }

    fn check_compatible(&self, other: &Self) -> Result<(), VjmError> {
        if self.kinematics != other.kinematics {
            return Err(VjmError::IncompatiblePartials {
                what: "robot kinematics",
                left: short(&self.kinematics),
                right: short(&other.kinematics),
            });
        }
        // The springs, not the model's name: "traditional" and its seven labels are one model.
        if self.model.springs() != other.model.springs() {
            return Err(VjmError::IncompatiblePartials {
                what: "model",
                left: self.model.labels().join(","),
                right: other.model.labels().join(","),
            });
        }
        // The solve method is not part of the statistics (parts always reduce by QR).
        let mut theirs = other.opts;
        theirs.method = self.opts.method;
        if self.opts != theirs {
            return Err(VjmError::IncompatiblePartials {
                what: "options",
                left: describe(&self.opts),
                right: describe(&other.opts),
            });
        }
        Ok(())
    }
}

/// The first 12 hex digits of a hash, for messages.
fn short(hash: &str) -> String {
    format!("kinematics {}…", &hash[..hash.len().min(12)])
}

fn describe(o: &IdentifyOptions) -> String {
    format!(
        "noise_sigma {:?}, noise_scale_known {}, rotations {}, nonnegative {}",
        o.noise_sigma, o.noise_scale_known, o.use_rotations, o.nonnegative
    )
}
