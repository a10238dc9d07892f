//! Independent rows computed on every core, with results that do not depend on the number of
//! threads: the rows are cut into fixed-size blocks (never into one block per thread), each
//! block is computed serially with its own workspace, straight into its part of the output.
//!
//! ```
//! use stiffness_core::row_blocks::fill_row_blocks;
//! let mut squares = vec![0.0; 10];
//! fill_row_blocks(&mut squares, 3, |rows, out| {
//!     for (i, o) in rows.zip(out) {
//!         *o = (i * i) as f64;
//!     }
//!     Ok::<_, String>(())
//! })?;
//! assert_eq!(squares, [0.0, 1.0, 4.0, 9.0, 16.0, 25.0, 36.0, 49.0, 64.0, 81.0]);
//! # Ok::<(), String>(())
//! ```

use std::ops::Range;

use rayon::prelude::*;

/// Rows per block of the row-wise predictions (`predict`, `predict_sag`): large enough that a
/// block's workspaces and scheduling cost nothing next to its rows, small enough to balance
/// two to a few dozen cores on 10⁴–10⁶ rows.
pub const PREDICTION_BLOCK_ROWS: usize = 1024;

/// Fills `out` (one item per row) by `f(rows, out_block)` over blocks of `block` rows (the last
/// one shorter) on rayon's pool. No memory beyond `out` and the blocks' own workspaces. On
/// errors, the one of the earliest block is returned: with `f` stopping at its first bad row,
/// that is the error of the first bad row, the serial run's.
///
/// # Panics
/// If `block` is 0.
pub fn fill_row_blocks<T, E, F>(out: &mut [T], block: usize, f: F) -> Result<(), E>
where
    T: Send,
    E: Send,
    F: Fn(Range<usize>, &mut [T]) -> Result<(), E> + Sync,
{
    assert!(block > 0, "fill_row_blocks: a block needs at least one row");
    let outcomes: Vec<Result<(), E>> = out
        .par_chunks_mut(block)
        .enumerate()
        .map(|(b, chunk)| f(b * block..b * block + chunk.len(), chunk))
        .collect();
    outcomes.into_iter().collect()
}

/// [`fill_row_blocks`] with two outputs per row: `out` (one item per row) and `wide`
/// (`width` items per row, row-major), e.g. a report and a vector per row.
///
/// # Panics
/// If `block` or `width` is 0, or `wide` does not have `width` items per row of `out`.
pub fn fill_row_blocks_pair<T, U, E, F>(
    out: &mut [T],
    wide: &mut [U],
    width: usize,
    block: usize,
    f: F,
) -> Result<(), E>
where
    T: Send,
    U: Send,
    E: Send,
    F: Fn(Range<usize>, &mut [T], &mut [U]) -> Result<(), E> + Sync,
{
    assert!(
        block > 0 && width > 0,
        "fill_row_blocks_pair: empty block or row"
    );
    assert_eq!(
        wide.len(),
        width * out.len(),
        "fill_row_blocks_pair: width items per row"
    );
    let outcomes: Vec<Result<(), E>> = out
        .par_chunks_mut(block)
        .zip(wide.par_chunks_mut(block * width))
        .enumerate()
        .map(|(b, (chunk, wide))| f(b * block..b * block + chunk.len(), chunk, wide))
        .collect();
    outcomes.into_iter().collect()
}
