//! Streaming triangular factor: the R of a tall matrix accumulated block by block (TSQR).
//!
//! Rows are buffered into a block of [`BLOCK_ROWS`] rows; a full block B is folded into the
//! current upper-triangular R by Householder reflections of the stacked matrix `[R; B]`
//! that exploit R's triangular shape (each reflector touches one row of R and the block).
//! This is the QR of the whole matrix computed in pieces, so it has the backward stability
//! of Householder QR (unlike normal equations, which square the condition number), and the
//! memory is p² + BLOCK_ROWS·p values whatever the number of rows. Two factors of disjoint
//! row sets merge by folding one's R into the other ([`TriangularAccumulator::merge`]),
//! which is how per-thread factors are combined.

use super::ShapeMismatch;

/// Rows buffered before a fold. 64 rows × 22 columns is 11 KiB: the block stays in L1.
pub const BLOCK_ROWS: usize = 64;

/// Accumulates the triangular factor R (p×p, p = columns including any right-hand side)
/// of a matrix given row by row, with memory independent of the number of rows.
///
/// ```
/// use stiffness_core::lsq::TriangularAccumulator;
/// let mut acc = TriangularAccumulator::new(2);
/// for i in 0..100 {
///     let x = i as f64;
///     acc.push_row(&[1.0, x]).unwrap();
/// }
/// let f = acc.finish();
/// // RᵀR = AᵀA: the (0, 0) entry is the number of rows.
/// assert!((f.r()[0] * f.r()[0] - 100.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone)]
pub struct TriangularAccumulator {
    p: usize,
    /// p×p upper triangle, row-major (entries below the diagonal stay 0).
    r: Vec<f64>,
    /// BLOCK_ROWS×p, column-major: the rows waiting to be folded.
    block: Vec<f64>,
    filled: usize,
    rows: usize,
}

/// The result of [`TriangularAccumulator::finish`]: R with RᵀR = AᵀA, and the row count.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangularFactor {
    p: usize,
    r: Vec<f64>,
    rows: usize,
}

impl TriangularFactor {
    /// Builds a factor from a p×p upper-triangular row-major R (entries below the diagonal
    /// are ignored) that summarises `rows` rows.
    pub fn from_upper(p: usize, r: Vec<f64>, rows: usize) -> Result<Self, ShapeMismatch> {
        if r.len() != p * p {
            return Err(ShapeMismatch {
                what: "triangular factor (p·p)",
                expected: p * p,
                got: r.len(),
            });
        }
        let mut r = r;
        for i in 0..p {
            for j in 0..i {
                r[i * p + j] = 0.0;
            }
        }
        Ok(Self { p, r, rows })
    }
    /// Number of columns p.
    pub fn ncols(&self) -> usize {
        self.p
    }
    /// R, p×p row-major upper triangular.
    pub fn r(&self) -> &[f64] {
        &self.r
    }
    /// Number of rows folded in.
    pub fn nrows(&self) -> usize {
        self.rows
    }
}

impl TriangularAccumulator {
    /// An empty accumulator for rows of `ncols` values.
    pub fn new(ncols: usize) -> Self {
        Self {
            p: ncols,
            r: vec![0.0; ncols * ncols],
            block: vec![0.0; BLOCK_ROWS * ncols],
            filled: 0,
            rows: 0,
        }
    }

    /// An accumulator that continues from a finished factor (e.g. one received from another
    /// process): merging into it, or pushing rows, goes on exactly as if the factor's rows had
    /// been pushed here.
    pub fn from_factor(factor: TriangularFactor) -> Self {
        let p = factor.p;
        Self {
            p,
            r: factor.r,
            block: vec![0.0; BLOCK_ROWS * p],
            filled: 0,
            rows: factor.rows,
        }
    }

    /// Number of columns p.
    pub fn ncols(&self) -> usize {
        self.p
    }

    /// Number of rows pushed so far.
    pub fn nrows(&self) -> usize {
        self.rows
    }

    /// Appends one row of p values.
    pub fn push_row(&mut self, row: &[f64]) -> Result<(), ShapeMismatch> {
        if row.len() != self.p {
            return Err(ShapeMismatch {
                what: "accumulator row",
                expected: self.p,
                got: row.len(),
            });
        }
        self.push_row_unchecked(row);
        Ok(())
    }

    /// Appends one row of exactly p values without a length check (the caller guarantees
    /// it; a short row panics on indexing).
    #[inline]
    pub fn push_row_unchecked(&mut self, row: &[f64]) {
        for (k, &v) in row.iter().enumerate() {
            self.block[k * BLOCK_ROWS + self.filled] = v;
        }
        self.filled += 1;
        self.rows += 1;
        if self.filled == BLOCK_ROWS {
            self.fold();
        }
    }

    /// Appends a row given as a scaled product `scale · a[k] · b[k]` for k < p − 1 and
    /// `scale · rhs` last: the regressor's row shape, written without a temporary.
    #[inline]
    pub fn push_product_row(
        &mut self,
        scale: f64,
        a: impl Iterator<Item = f64>,
        b: &[f64],
        rhs: f64,
    ) {
        let i = self.filled;
        let m = self.p - 1;
        for (k, (ak, bk)) in a.zip(b).enumerate().take(m) {
            self.block[k * BLOCK_ROWS + i] = scale * ak * bk;
        }
        self.block[m * BLOCK_ROWS + i] = scale * rhs;
        self.filled += 1;
        self.rows += 1;
        if self.filled == BLOCK_ROWS {
            self.fold();
        }
    }

    /// Folds the buffered rows into R (Householder QR of `[R; block]`).
    fn fold(&mut self) {
        let b = self.filled;
        if b == 0 {
            return;
        }
        let p = self.p;
        for j in 0..p {
            let (left, right) = self.block.split_at_mut((j + 1) * BLOCK_ROWS);
            let v = &mut left[j * BLOCK_ROWS..j * BLOCK_ROWS + b];
            let sigma = dot(v, v);
            if sigma == 0.0 {
                continue;
            }
            let alpha = self.r[j * p + j];
            let norm = (alpha * alpha + sigma).sqrt();
            let beta = if alpha >= 0.0 { -norm } else { norm };
            // LAPACK dlarfg: H = I − τ [1; v][1; v]ᵀ with v = x / (α − β), τ = (β − α)/β.
            let tau = (beta - alpha) / beta;
            let inv = 1.0 / (alpha - beta);
            for x in v.iter_mut() {
                *x *= inv;
            }
            self.r[j * p + j] = beta;
            for k in (j + 1)..p {
                let xk = &mut right[(k - j - 1) * BLOCK_ROWS..(k - j - 1) * BLOCK_ROWS + b];
                let w = tau * (self.r[j * p + k] + dot(v, xk));
                self.r[j * p + k] -= w;
                for (vi, xi) in v.iter().zip(xk.iter_mut()) {
                    *xi -= w * vi;
                }
            }
        }
        self.filled = 0;
    }

    /// Merges the factor of another, disjoint set of rows (e.g. another thread's).
    pub fn merge(&mut self, mut other: TriangularAccumulator) -> Result<(), ShapeMismatch> {
        if other.p != self.p {
            return Err(ShapeMismatch {
                what: "merged accumulator columns",
                expected: self.p,
                got: other.p,
            });
        }
        other.fold();
        let rows = self.rows + other.rows;
        let p = self.p;
        for i in 0..p {
            self.push_row_unchecked(&other.r[i * p..(i + 1) * p]);
        }
        self.rows = rows;
        Ok(())
    }

    /// Folds what is buffered and returns R.
    pub fn finish(mut self) -> TriangularFactor {
        self.fold();
        TriangularFactor {
            p: self.p,
            r: self.r,
            rows: self.rows,
        }
    }
}

/// Dot product with four independent accumulators, so the compiler can keep SIMD lanes
/// busy (a single running sum is a serial dependency chain it may not reorder).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            acc[l] += x[l] * y[l];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
