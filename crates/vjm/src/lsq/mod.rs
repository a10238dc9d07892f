//! The least-squares core: a streaming triangular factor (TSQR) and a rank-revealing
//! solver on it. Independent of robots, so `diagnose` can reuse it with extra columns.

mod gram;
mod nnls;
mod solve;

pub use gram::factor_from_gram;
pub use solve::{
    dense_factor, solve_dense, solve_factor, LinearCombination, RankRevealingSolution,
    SolveOptions, ZERO_COLUMN_RTOL,
};
pub use stiffness_core::lsq::{TriangularAccumulator, TriangularFactor, BLOCK_ROWS};
