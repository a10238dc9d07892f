//! The streaming least-squares factor shared by the identification and the diagnosis: the R of
//! a tall matrix accumulated block by block (TSQR), mergeable across threads, partitions and
//! machines; what an estimate's data determine ([`WeakDirections`]); the one rank policy
//! of every solve, with its named presets ([`RankPolicy`]); and the rank-revealing SVD of a
//! small design under that policy ([`ScaledSvd`]).

mod accumulator;
mod rank;
mod scaled_svd;
mod weak;

pub use accumulator::{TriangularAccumulator, TriangularFactor, BLOCK_ROWS};
pub use rank::RankPolicy;
pub use scaled_svd::ScaledSvd;
pub use weak::WeakDirections;

/// A slice or factor has the wrong length.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("shape mismatch in {what}: expected {expected} values, got {got}")]
pub struct ShapeMismatch {
    /// Which input or output buffer.
    pub what: &'static str,
    /// Expected length.
    pub expected: usize,
    /// Actual length.
    pub got: usize,
}
