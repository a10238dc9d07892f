//! The rank policy of every least-squares solve in the workspace, with named presets.
//!
//! Every rank decision is made on the **column-scaled** design (each column divided by its
//! norm, so that the decision does not depend on the parameters' units) by three numbers:
//!
//! - a column whose norm is at most [`zero_column_rtol`](RankPolicy::zero_column_rtol) of the
//!   largest column of its design is not in the data (a torsion about an axis through the tip
//!   point comes out of the kinematics as 1e-17 of rounding; scaling would blow it up to unit
//!   norm and call it identifiable);
//! - singular values below [`rank_rtol`](RankPolicy::rank_rtol)`·σ_max` are zero;
//! - entries of the orthonormal null space (identifiability, aliasing), and the part of a
//!   column outside a basis relative to its own norm (testability), below
//!   [`null_tol`](RankPolicy::null_tol) are zero.
//!
//! Two presets, one per use, differ only in `rank_rtol`: the identification resolves what the
//! data determine down to 1e-9 (a streaming QR resolves singular values that far, and a
//! parameter its data barely determine is still reported, with its large standard error),
//! the diagnosis decides with 1e-7 (a candidate nearly in the model's span is not testable,
//! rather than a finding made of rounding).
//!
//! ```
//! use stiffness_core::lsq::RankPolicy;
//! let p = RankPolicy::DIAGNOSIS;
//! assert!(p.rank_rtol > RankPolicy::IDENTIFICATION.rank_rtol);
//! assert_eq!(p.zero_column_rtol, RankPolicy::IDENTIFICATION.zero_column_rtol);
//! ```

/// The three tolerances of a rank decision (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RankPolicy {
    /// Singular values of the column-scaled design below `rank_rtol · σ_max` are zero.
    pub rank_rtol: f64,
    /// Null-space entries and a column's part outside a basis (relative to its norm) below
    /// this are zero.
    pub null_tol: f64,
    /// Columns whose norm is at most this fraction of the largest column norm are not in the
    /// data. The one units-dependent decision: with columns of wildly different units set 0.
    pub zero_column_rtol: f64,
}

impl RankPolicy {
    /// The identification's (`vjm::lsq::SolveOptions::default`, `vjm::identify`).
    pub const IDENTIFICATION: RankPolicy = RankPolicy {
        rank_rtol: 1e-9,
        null_tol: 1e-7,
        zero_column_rtol: 1e-12,
    };

    /// The diagnosis engine's (fits, scores, nested and wild-cluster tests, the CSJM
    /// covariance).
    pub const DIAGNOSIS: RankPolicy = RankPolicy {
        rank_rtol: 1e-7,
        null_tol: 1e-7,
        zero_column_rtol: 1e-12,
    };
}
