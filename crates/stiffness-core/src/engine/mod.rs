//! The diagnosis engine shared by the serial-arm (VJM) and the cable-joint (CSJM) models.
//!
//! A model supplies a [`Problem`]: its terms (groups of columns of one whitened design), a
//! pass over its rows that compresses the design at a linearisation point, and the
//! re-linearisation of bilinear terms. The engine does the rest, identically for both models:
//!
//! 1. [`compressed`]: the design `Z = [model | candidates | y]` is reduced to its R factors
//!    over the training and held-out rows in one streaming pass (TSQR), so memory and the
//!    cost of every decision are independent of the number of rows (a model may keep
//!    columns that only its verdict reads out of Z, as VJM does with its lack-of-fit blocks);
//! 2. [`fit`]: rank-revealing fits of any subset of terms, nested F scores, hold-out SSEs and
//!    cluster-robust Wald tests, all on the P×P factors;
//! 3. [`select`](select::select): forward selection with Benjamini–Hochberg, hold-out
//!    confirmation and alias tests;
//! 4. [`verdict`]: lack of fit against a flexible alternative (no noise level needed) and,
//!    when the noise is known, goodness of fit.
//!
//! The design is `docs/design/diagnose-engine.md`.

pub mod basis;
pub mod compressed;
mod exchange;
pub mod fit;
pub mod schema;
pub mod select;
pub mod verdict;
pub mod wild_cluster;

use std::sync::Arc;

pub use basis::{RANK_TOL, ZERO_COLUMN_RTOL};
pub use compressed::{Compressed, CompressedAccumulator, RowSet};
pub use fit::{Fit, Score};
pub use schema::{Alias, Finding, ModelSummary, NoDetail, Parameter};
pub use select::{
    select, AliasOf, DeferredClusterTest, SelectOptions, Selected, Selection, SelectionEvidence,
};
pub use verdict::{goodness_of_fit, nested_test, ChiSquareTest};

use crate::{Cancel, Cancelled};

/// The default seed of a diagnosis' train/test split, for every model: the same data and the
/// same seed give the same split, hence the same diagnosis.
pub const DEFAULT_SPLIT_SEED: u64 = 0;

/// What a model supplies to the engine.
pub trait Problem {
    /// A term of a model: a named group of columns of the compressed design.
    type Term: Copy + Eq + std::fmt::Debug;
    /// The point at which bilinear terms' columns (and the whitening) are evaluated.
    type Lin: Clone;

    /// The columns of `term` in the compressed design.
    fn columns(&self, term: Self::Term) -> std::ops::Range<usize>;
    /// The observation column `y` of the compressed design.
    fn observation_column(&self) -> usize;
    /// Whether `term`'s columns depend on the linearisation point.
    fn bilinear(&self, term: Self::Term) -> bool;
    /// One pass over the rows: the design compressed at `lin` (implementations may cache).
    fn compress(&self, lin: &Self::Lin) -> Result<Arc<Compressed>, Cancelled>;
    /// The training design's columns `cols` and its observation column at `lin`, as vectors
    /// whose inner products are those of the whitened columns: all that a fit's iteration
    /// towards its linearisation point solves with. The default takes them from
    /// [`Problem::compress`]; a problem whose whole design is costly to compress can make only
    /// these columns (one pass over the training rows, a few columns wide).
    fn model_columns(
        &self,
        lin: &Self::Lin,
        cols: &[usize],
    ) -> Result<(Vec<Vec<f64>>, Vec<f64>), Cancelled> {
        let comp = self.compress(lin)?;
        Ok((
            comp.columns(RowSet::Train, cols),
            comp.column(RowSet::Train, self.observation_column()),
        ))
    }
    /// The linearisation point of a fit of `terms` with coefficients `coef`.
    fn relinearise(&self, terms: &[Self::Term], coef: &[f64]) -> Self::Lin;
    /// Per cluster (VJM: pose), the score sum `s_g = Σ_{i∈g} x_i r_i` over the training
    /// observations of `fit`'s whitened columns `x_i` and residuals `r_i` (one pass).
    fn cluster_sums(&self, fit: &Fit<Self::Term, Self::Lin>) -> Result<Vec<Vec<f64>>, Cancelled>;
    /// Terms that must be in the model for `cand` to be accepted: a candidate whose F test
    /// given them has p above the alias level is not a finding (the data cannot tell it from
    /// those terms). VJM: a mount compliance must stand against every joint spring, since a
    /// few springs missing from the model can mimic it. Default: none.
    fn guard(&self, cand: Self::Term) -> Vec<Self::Term> {
        let _ = cand;
        Vec::new()
    }
    /// Groups of candidates that may explain a finding `finding` only together (none of them
    /// alone does): VJM, the two tilts of a neighbouring joint, which together can rotate the
    /// links beyond as one tilt about a line between the two joints would. A group whose
    /// members are testable and of which one is significant is an alias of the finding when,
    /// with the whole group in the model, the finding's F test has p above the alias level
    /// ([`select::AliasOf::group`]). Default: none.
    fn alias_groups(&self, finding: Self::Term) -> Vec<Vec<Self::Term>> {
        let _ = finding;
        Vec::new()
    }
    /// The token every loop of the engine polls.
    fn cancel(&self) -> &Cancel;
}
