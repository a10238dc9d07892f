//! Streaming triangular factor: the R of a tall matrix accumulated block by block (TSQR).
//!
//! Rows are buffered into a block of [`BLOCK_ROWS`] rows; a full block B is folded into the
//! current upper-triangular R by Householder reflections of the stacked matrix `[R; B]`
//! that exploit R's triangular shape (each reflector touches one row of R and the block).
//! The reflectors are made a panel of columns at a time and applied to the remaining columns
//! together in compact-WY form (`I − U T Uᵀ`, LAPACK's dlarft), so that most of the work is
//! two matrix products per panel that faer runs with the machine's widest SIMD: about twice
//! the speed of applying them one by one at 86 columns (`benches/lsq_fold.rs`).
//! This is the QR of the whole matrix computed in pieces, so it has the backward stability
//! of Householder QR (unlike normal equations, which square the condition number), and the
//! memory is p² + BLOCK_ROWS·p values whatever the number of rows. Two factors of disjoint
//! row sets merge by folding one's R into the other ([`TriangularAccumulator::merge`]),
//! which is how per-thread factors are combined.

use super::ShapeMismatch;

/// Rows buffered before a fold: the inner dimension of the panel products, large enough for
/// faer's matrix product to run at speed (512 rows × 59 columns is 240 KiB, in L2). Measured
/// with `benches/lsq_fold.rs` against 256 and 1024 with the column-major block: at 22, 49
/// and 59 columns, 512 rows ran 19.3, 5.63 and 4.19 M rows/s; 256 rows 17.5, 6.13 and 3.92;
/// 1024 rows 16.6, 5.91 and 4.52 for twice the memory.
pub const BLOCK_ROWS: usize = 512;
/// Leading dimension of the column-major block: a column's stride. Not a power of two, so that
/// the p values a push scatters do not all fall in one set of the L1 cache (at 512 × 8 bytes
/// they would: the push then ran 40 % slower).
const LD: usize = BLOCK_ROWS + 8;
/// Columns whose reflectors are applied to the rest together (the compact-WY panel width):
/// the reflectors inside a panel are applied one by one, so a wide panel moves work back to
/// the slow path; 8 was fastest of 4, 8, 16 and 32 at 22, 49 and 86 columns, and again of 4,
/// 8, 12 and 16 once the fold was dispatched (16 puts a panel of 512 rows beyond L1).
const PANEL: usize = 8;

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
    /// BLOCK_ROWS×p, column-major: the rows waiting to be folded. A push scatters a row
    /// across the columns; a fold then reads every column contiguously and keeps each panel's
    /// reflectors in place of its columns (no copy of the panel; storing rows contiguously and
    /// copying each panel out cost more).
    block: Vec<f64>,
    filled: usize,
    rows: usize,
    /// Workspace of a fold, column-major: a panel's T (PANEL×PANEL) and W (PANEL×p).
    t: Vec<f64>,
    w: Vec<f64>,
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
            block: vec![0.0; LD * ncols],
            filled: 0,
            rows: 0,
            t: vec![0.0; PANEL * PANEL],
            w: vec![0.0; PANEL * ncols],
        }
    }

    /// An accumulator that continues from a finished factor (e.g. one received from another
    /// process): merging into it, or pushing rows, goes on exactly as if the factor's rows had
    /// been pushed here.
    pub fn from_factor(factor: TriangularFactor) -> Self {
        // The workspaces are those of a new accumulator; only R and the row count carry over.
        Self {
            r: factor.r,
            rows: factor.rows,
            ..Self::new(factor.p)
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
    /// it; debug builds assert it).
    #[inline]
    pub fn push_row_unchecked(&mut self, row: &[f64]) {
        debug_assert_eq!(row.len(), self.p, "accumulator row");
        for (dst, x) in self.block[self.filled..].iter_mut().step_by(LD).zip(row) {
            *dst = *x;
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
        let p = self.p;
        let m = p - 1;
        let mut row = self.block[self.filled..].iter_mut().step_by(LD);
        for (dst, (ak, bk)) in row.by_ref().zip(a.zip(b)).take(m) {
            *dst = scale * ak * bk;
        }
        self.block[m * LD + self.filled] = scale * rhs;
        self.filled += 1;
        self.rows += 1;
        if self.filled == BLOCK_ROWS {
            self.fold();
        }
    }

    /// Folds the buffered rows into R (Householder QR of `[R; block]`), a panel of
    /// [`PANEL`] columns at a time: the panel's reflectors are made in place of its block
    /// columns and applied within the panel one by one, then applied together to the trailing
    /// columns as `I − U T Uᵀ` (compact WY): two matrix products that faer runs with the
    /// machine's widest SIMD.
    fn fold(&mut self) {
        /// The fold compiled for the machine's widest instruction set (pulp dispatches once
        /// per fold): the reflectors inside a panel are dot products and updates of block
        /// columns, written in the instruction set's vectors (`dot`, `axpy`).
        struct Dispatched<'a>(&'a mut TriangularAccumulator);
        impl pulp::WithSimd for Dispatched<'_> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, simd: S) {
                self.0.fold_panels(simd);
            }
        }
        if self.filled > 0 {
            pulp::Arch::new().dispatch(Dispatched(self));
        }
    }

    /// The body of [`Self::fold`], inlined into its dispatched instances.
    #[inline(always)]
    fn fold_panels<S: pulp::Simd>(&mut self, simd: S) {
        let b = self.filled;
        if b == 0 {
            return;
        }
        let p = self.p;
        let mut taus = [0.0; PANEL];
        let mut j0 = 0;
        while j0 < p {
            let j1 = (j0 + PANEL).min(p);
            let nb = j1 - j0;
            for (c, tau) in taus.iter_mut().enumerate().take(nb) {
                *tau = self.reflect(simd, j0, c, nb, b);
            }
            if j1 < p {
                self.apply_panel(simd, j0, j1, b, &taus[..nb]);
            }
            j0 = j1;
        }
        self.filled = 0;
    }

    /// Makes the reflector of the panel's column c (LAPACK dlarfg on `[R_jj; x]`, j = j0 + c,
    /// x the block's column j), stores `v` in place of x and `β` in `R_jj`, applies it to the
    /// panel's columns `c+1..nb`, and returns τ (0 when the block column is already zero: the
    /// reflector is the identity).
    #[inline(always)]
    fn reflect<S: pulp::Simd>(&mut self, simd: S, j0: usize, c: usize, nb: usize, b: usize) -> f64 {
        let p = self.p;
        let j = j0 + c;
        let (left, right) = self.block.split_at_mut((j + 1) * LD);
        let v = &mut left[j * LD..j * LD + b];
        let sigma = dot(simd, v, v);
        if sigma == 0.0 {
            return 0.0;
        }
        let alpha = self.r[j * p + j];
        let norm = (alpha * alpha + sigma).sqrt();
        let beta = if alpha >= 0.0 { -norm } else { norm };
        // H = I − τ [1; v][1; v]ᵀ with v = x / (α − β), τ = (β − α)/β.
        let tau = (beta - alpha) / beta;
        let inv = 1.0 / (alpha - beta);
        for x in v.iter_mut() {
            *x *= inv;
        }
        self.r[j * p + j] = beta;
        for k in (c + 1)..nb {
            let xk = &mut right[(k - c - 1) * LD..(k - c - 1) * LD + b];
            let w = tau * (self.r[j * p + j0 + k] + dot(simd, v, xk));
            self.r[j * p + j0 + k] -= w;
            axpy(simd, -w, v, xk);
        }
        tau
    }

    /// Applies `Hᵀ = H_{j1−1} ⋯ H_{j0}` of the panel `j0..j1` to the trailing columns
    /// `j1..p` of `[R; block]`. With `u_i = [e_{j0+i}; v_i]`, the product is `I − U T Uᵀ`
    /// (LAPACK dlarft, forward and columnwise: `T_ii = τ_i`,
    /// `T[..i, i] = −τ_i T[..i, ..i] Uᵀu_i`, and `Uᵀu_i` is `V[:, ..i]ᵀ v_i` because the
    /// unit parts of u lie on different rows of R). Then `W = R[j0..j1, j1..] + Vᵀ X`,
    /// `W ← Tᵀ W`, `R[j0..j1, j1..] −= W` and `X −= V W`.
    #[inline(always)]
    fn apply_panel<S: pulp::Simd>(
        &mut self,
        simd: S,
        j0: usize,
        j1: usize,
        b: usize,
        taus: &[f64],
    ) {
        use faer::linalg::matmul::matmul;
        use faer::{Accum, MatMut, MatRef, Par};
        let p = self.p;
        let nb = j1 - j0;
        let m = p - j1;
        // The panel's reflectors are the block's columns j0..j1; the trailing columns X are
        // j1..p.
        let (vs, xs) = self.block.split_at_mut(j1 * LD);
        let vs = &vs[j0 * LD..];
        let vcol = |i: usize| &vs[i * LD..i * LD + b];
        // T, nb×nb upper triangular, column-major in `t`.
        let t = &mut self.t;
        let mut z = [0.0; PANEL];
        for i in 0..nb {
            for (a, za) in z.iter_mut().enumerate().take(i) {
                *za = dot(simd, vcol(a), vcol(i));
            }
            for a in 0..i {
                let s: f64 = (a..i).map(|c| t[a + c * PANEL] * z[c]).sum();
                t[a + i * PANEL] = -taus[i] * s;
            }
            t[i + i * PANEL] = taus[i];
        }
        // W (nb×m, column-major, leading dimension PANEL) = R[j0..j1, j1..] + Vᵀ X.
        let w = &mut self.w;
        for c in 0..m {
            for i in 0..nb {
                w[i + c * PANEL] = self.r[(j0 + i) * p + j1 + c];
            }
        }
        let v = MatRef::from_column_major_slice_with_stride(vs, b, nb, LD);
        {
            let x = MatRef::from_column_major_slice_with_stride(xs, b, m, LD);
            let wm = MatMut::from_column_major_slice_with_stride_mut(w, nb, m, PANEL);
            matmul(wm, Accum::Add, v.transpose(), x, 1.0, Par::Seq);
        }
        // W ← Tᵀ W, row i from rows a ≤ i: bottom up, in place.
        for c in 0..m {
            let col = &mut w[c * PANEL..c * PANEL + nb];
            for i in (0..nb).rev() {
                col[i] = (0..=i).map(|a| t[a + i * PANEL] * col[a]).sum();
            }
        }
        for c in 0..m {
            for i in 0..nb {
                self.r[(j0 + i) * p + j1 + c] -= w[i + c * PANEL];
            }
        }
        let x = MatMut::from_column_major_slice_with_stride_mut(xs, b, m, LD);
        let wm = MatRef::from_column_major_slice_with_stride(w, nb, m, PANEL);
        matmul(x, Accum::Add, v, wm, -1.0, Par::Seq);
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

/// `Σ a_i b_i` in the dispatched instruction set's vectors, four accumulators (fused
/// multiply-adds on independent chains; left to itself, the compiler kept the sum two lanes
/// wide). `a` and `b` have the same length.
#[inline(always)]
fn dot<S: pulp::Simd>(s: S, a: &[f64], b: &[f64]) -> f64 {
    let (ah, at) = S::as_simd_f64s(a);
    let (bh, bt) = S::as_simd_f64s(b);
    let mut acc = [s.splat_f64s(0.0); 4];
    let (a4, a1) = ah.split_at(ah.len() / 4 * 4);
    let (b4, b1) = bh.split_at(a4.len());
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        for u in 0..4 {
            acc[u] = s.mul_add_e_f64s(x[u], y[u], acc[u]);
        }
    }
    for (x, y) in a1.iter().zip(b1) {
        acc[0] = s.mul_add_e_f64s(*x, *y, acc[0]);
    }
    let sum = s.add_f64s(s.add_f64s(acc[0], acc[1]), s.add_f64s(acc[2], acc[3]));
    s.reduce_sum_f64s(sum) + at.iter().zip(bt).map(|(x, y)| x * y).sum::<f64>()
}

/// `y ← y + α x` in the dispatched instruction set's vectors. `x` and `y` have the same
/// length.
#[inline(always)]
fn axpy<S: pulp::Simd>(s: S, alpha: f64, x: &[f64], y: &mut [f64]) {
    let (xh, xt) = S::as_simd_f64s(x);
    let (yh, yt) = S::as_mut_simd_f64s(y);
    let a = s.splat_f64s(alpha);
    for (yi, xi) in yh.iter_mut().zip(xh) {
        *yi = s.mul_add_e_f64s(a, *xi, *yi);
    }
    for (yi, xi) in yt.iter_mut().zip(xt) {
        *yi += alpha * xi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pulp::{Simd, WithSimd};

    /// Two folds (a block of 511 rows onto R = 0, then 300 rows onto that R) run with one
    /// instruction set throughout.
    struct TwoFolds<'a>(&'a [Vec<f64>]);
    impl WithSimd for TwoFolds<'_> {
        type Output = Vec<f64>;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Vec<f64> {
            let p = self.0[0].len();
            let mut acc = TriangularAccumulator::new(p);
            for part in [&self.0[..511], &self.0[511..]] {
                for row in part {
                    acc.push_row_unchecked(row);
                }
                acc.fold_panels(s);
            }
            acc.r
        }
    }

    /// The fold on pulp's scalar type and on every instruction set this machine has gives the
    /// R of the dispatched fold, to rounding (811 seeded rows of 59 columns, so that panels of
    /// 8 leave a partial one and the block a partial tail).
    #[test]
    fn the_fold_is_the_same_on_every_instruction_set() {
        let p = 59;
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let rows: Vec<Vec<f64>> = (0..811)
            .map(|_| {
                (0..p)
                    .map(|_| {
                        state = state
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    })
                    .collect()
            })
            .collect();
        let mut dispatched = TriangularAccumulator::new(p);
        for row in &rows {
            dispatched.push_row_unchecked(row);
        }
        let want = dispatched.finish();
        let scale = want.r().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut got = vec![("scalar", TwoFolds(&rows).with_simd(pulp::Scalar::new()))];
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            if let Some(v3) = pulp::x86::V3::try_new() {
                got.push(("avx2", Simd::vectorize(v3, TwoFolds(&rows))));
            }
            if let Some(v4) = pulp::x86::V4::try_new() {
                got.push(("avx512", Simd::vectorize(v4, TwoFolds(&rows))));
            }
        }
        for (name, r) in got {
            // R is unique up to the signs of its rows: compare |R|.
            let worst = r
                .iter()
                .zip(want.r())
                .fold(0.0f64, |m, (a, b)| m.max((a.abs() - b.abs()).abs()));
            assert!(worst <= 1e-12 * scale, "{name}: {worst:e} of {scale:e}");
        }
    }
}
