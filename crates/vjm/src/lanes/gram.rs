//! Lane-wise regressor rows folded straight into the Gram matrix `[A b]ᵀ[A b]`, and the
//! lane-wise batched Jacobian.
//!
//! For measurement i, spring k on joint j with base-frame axis w_k, lever `ℓ_j = p − c_j`
//! and wrench `(f, m)`: the generalised force on the spring is
//! `J_kᵀF = (w_k × ℓ_j)·f + w_k·m = w_k·(ℓ_j × f + m)`, so one `u_j = ℓ_j × f + m` per joint
//! serves its three springs; the regressor entries are `(w_k × ℓ_j)[r]·J_kᵀF` (translation
//! rows) and `w_k[r]·J_kᵀF` (rotation rows), whitened by 1/σ_r (see `crate::regressor`). A
//! translational spring (column `[w_k; 0]`) has `J_kᵀF = w_k·f` and entries `w_k[r]·J_kᵀF` in
//! the translation rows, 0 in the rotation rows.

use pulp::{Simd, WithSimd};

use super::kinematics::{ChainLanes, FramesLanes};
use super::vector::{cross3, dot3, gather, MAX_LANES};
use super::V;
use crate::kinematics::JacobianLayout;

/// One identification problem's inputs, row-major as `crate::identify` takes them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GramProblem<'a> {
    pub(crate) chain: &'a ChainLanes,
    /// N×n joint angles, rad.
    pub(crate) q: &'a [f64],
    /// N×6 wrenches at the tip point, base frame (N, N·m).
    pub(crate) wrench: &'a [f64],
    /// N×3 tip displacements, base frame (m).
    pub(crate) displacement: &'a [f64],
    /// N×3 small tip rotations, base frame (rad), used when `rows == 6`.
    pub(crate) rotation: Option<&'a [f64]>,
    /// Rows per measurement: 3 (translation) or 6 (translation and rotation).
    pub(crate) rows: usize,
    /// 1/σ per row.
    pub(crate) inv_sigma: [f64; 6],
}

/// The (m+1)×(m+1) Gram matrix, row-major, of the whitened `[A b]` rows of measurements
/// `start..end`.
pub(crate) fn gram_range(problem: &GramProblem<'_>, start: usize, end: usize) -> Vec<f64> {
    struct Task<'a, 'b>(&'b GramProblem<'a>, usize, usize);
    impl WithSimd for Task<'_, '_> {
        type Output = Vec<f64>;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Vec<f64> {
            let Task(pb, start, end) = self;
            if pb.rows == 6 {
                gram_lanes::<S, 6>(s, pb, start, end)
            } else {
                gram_lanes::<S, 3>(s, pb, start, end)
            }
        }
    }
    pulp::Arch::new().dispatch(Task(problem, start, end))
}

#[inline(always)]
fn gram_lanes<S: Simd, const R: usize>(
    s: S,
    pb: &GramProblem<'_>,
    start: usize,
    end: usize,
) -> Vec<f64> {
    let lanes = V::<S>::LANES;
    let chain = pb.chain;
    let nj = chain.n_joints();
    let m = chain.n_springs();
    let p = m + 1;
    // Packed upper triangle of the Gram matrix, row by row, one vector of lane sums each.
    let mut acc = vec![s.splat_f64s(0.0); p * (p + 1) / 2];
    // Regressor block of `lanes` measurements: a[k][r] is row r, parameter k (column m is b).
    let mut a = vec![[V::zero(s); R]; p];
    let mut frames = FramesLanes::new(s, nj);
    let mut qv = vec![V::zero(s); nj];
    let mut lever = vec![[V::zero(s); 3]; nj];
    let mut u = vec![[V::zero(s); 3]; nj];
    let mut isig = [V::zero(s); R];
    for (r, v) in isig.iter_mut().enumerate() {
        *v = V::splat(s, pb.inv_sigma[r]);
    }
    let mut i = start;
    while i < end {
        let count = (end - i).min(lanes);
        for (j, qj) in qv.iter_mut().enumerate() {
            *qj = gather(s, pb.q, nj, j, i, count);
        }
        let mut force = [V::zero(s); 3];
        let mut moment = [V::zero(s); 3];
        for d in 0..3 {
            force[d] = gather(s, pb.wrench, 6, d, i, count);
            moment[d] = gather(s, pb.wrench, 6, 3 + d, i, count);
        }
        chain.evaluate(s, &qv, &mut frames);
        for ((lj, uj), c) in lever.iter_mut().zip(u.iter_mut()).zip(&frames.centre) {
            for d in 0..3 {
                lj[d] = frames.tip[d] - c[d];
            }
            let lf = cross3(lj, &force);
            for d in 0..3 {
                uj[d] = lf[d] + moment[d];
            }
        }
        for (k, col) in a[..m].iter_mut().enumerate() {
            let j = chain.spring_joint(k);
            let w = chain.spring_axis(s, &frames, k);
            if chain.is_translation(k) {
                // Column [w; 0]: the generalised force is w·f and it moves the tip along w.
                let g = dot3(&w, &force);
                for r in 0..3 {
                    col[r] = w[r] * (g * isig[r]);
                }
                for v in &mut col[3..R] {
                    *v = V::zero(s);
                }
                continue;
            }
            let g = dot3(&w, &u[j]);
            let lin = cross3(&w, &lever[j]);
            for r in 0..3 {
                col[r] = lin[r] * (g * isig[r]);
            }
            for r in 3..R {
                col[r] = w[r - 3] * (g * isig[r]);
            }
        }
        let rhs = &mut a[m];
        for r in 0..3 {
            rhs[r] = gather(s, pb.displacement, 3, r, i, count) * isig[r];
        }
        if let Some(rot) = pb.rotation {
            for r in 3..R {
                rhs[r] = gather(s, rot, 3, r - 3, i, count) * isig[r];
            }
        }
        // acc[(j, k ≥ j)] += Σ_r a[j][r]·a[k][r], walking the packed rows without indexing.
        let mut rest: &mut [S::f64s] = &mut acc;
        for j in 0..p {
            let (row, tail) = std::mem::take(&mut rest).split_at_mut(p - j);
            let aj = a[j];
            for (sum, ak) in row.iter_mut().zip(&a[j..]) {
                let mut t = *sum;
                for r in 0..R {
                    t = aj[r].fma_into(ak[r], t);
                }
                *sum = t;
            }
            rest = tail;
        }
        i += count;
    }
    let mut gram = vec![0.0; p * p];
    let mut idx = 0;
    for j in 0..p {
        for k in j..p {
            let v = s.reduce_sum_f64s(acc[idx]);
            gram[j * p + k] = v;
            gram[k * p + j] = v;
            idx += 1;
        }
    }
    gram
}

/// Jacobians of the configurations in `q` (N×n row-major, rad) into `out`: N blocks of 6·m
/// values, each a 6×m Jacobian laid out as `layout` says (`[w × (p − c); w]` per spring,
/// base frame).
pub(crate) fn jacobian_batch(
    chain: &ChainLanes,
    q: &[f64],
    out: &mut [f64],
    layout: JacobianLayout,
) {
    dispatch_jacobian(chain, q, out, layout, None)
}

/// [`jacobian_batch`] (column-major blocks) that also writes each configuration's tip point
/// (`tip`, N×3, m, base frame) and the rotation of the last joint's child frame (`rot`, N×9,
/// row-major, base ← child): what a diagnosis row needs besides the Jacobian, from the same
/// evaluation.
pub(crate) fn jacobian_tip_batch(
    chain: &ChainLanes,
    q: &[f64],
    out: &mut [f64],
    tip: &mut [f64],
    rot: &mut [f64],
) {
    dispatch_jacobian(chain, q, out, JacobianLayout::ColumnMajor, Some((tip, rot)))
}

/// [`jacobian_lanes`] in the instruction set the batched Jacobians run best on.
fn dispatch_jacobian(
    chain: &ChainLanes,
    q: &[f64],
    out: &mut [f64],
    layout: JacobianLayout,
    frames_out: Option<(&mut [f64], &mut [f64])>,
) {
    struct Task<'a>(
        &'a ChainLanes,
        &'a [f64],
        &'a mut [f64],
        JacobianLayout,
        Option<(&'a mut [f64], &'a mut [f64])>,
    );
    impl WithSimd for Task<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) {
            let Task(chain, q, out, layout, frames_out) = self;
            jacobian_lanes(s, chain, q, out, layout, frames_out)
        }
    }
    // AVX2 even where AVX-512 is available: the output is written lane by lane (126 values per
    // configuration), and 16-lane blocks only add gather and scatter work (measured: see
    // docs/benchmarks.md).
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    if let Some(v3) = pulp::x86::V3::try_new() {
        return Simd::vectorize(v3, Task(chain, q, out, layout, frames_out));
    }
    pulp::Arch::new().dispatch(Task(chain, q, out, layout, frames_out))
}

#[inline(always)]
fn jacobian_lanes<S: Simd>(
    s: S,
    chain: &ChainLanes,
    q: &[f64],
    out: &mut [f64],
    layout: JacobianLayout,
    mut frames_out: Option<(&mut [f64], &mut [f64])>,
) {
    // Where row r of column k goes within a configuration's block of 6·m values.
    let (row_stride, col_stride) = match layout {
        JacobianLayout::ColumnMajor => (1, 6),
        JacobianLayout::RowMajor => (chain.n_springs(), 1),
    };
    let lanes = V::<S>::LANES;
    let nj = chain.n_joints();
    let m = chain.n_springs();
    let rows = q.len() / nj;
    let mut frames = FramesLanes::new(s, nj);
    let mut qv = vec![V::zero(s); nj];
    let mut lever = vec![[V::zero(s); 3]; nj];
    let mut buf = [[0.0; MAX_LANES]; 6];
    let mut i = 0;
    while i < rows {
        let count = (rows - i).min(lanes);
        for (j, qj) in qv.iter_mut().enumerate() {
            *qj = gather(s, q, nj, j, i, count);
        }
        chain.evaluate(s, &qv, &mut frames);
        if let Some((tip, rot)) = &mut frames_out {
            let mut lanes_buf = [0.0; MAX_LANES];
            for d in 0..3 {
                frames.tip[d].store(&mut lanes_buf);
                for l in 0..count {
                    tip[(i + l) * 3 + d] = lanes_buf[l];
                }
            }
            for e in 0..9 {
                frames.rot[nj - 1][e].store(&mut lanes_buf);
                for l in 0..count {
                    rot[(i + l) * 9 + e] = lanes_buf[l];
                }
            }
        }
        for (lj, c) in lever.iter_mut().zip(&frames.centre) {
            for d in 0..3 {
                lj[d] = frames.tip[d] - c[d];
            }
        }
        for k in 0..m {
            let w = chain.spring_axis(s, &frames, k);
            // A translation's column is [w; 0] (see `crate::kinematics::column`).
            let (lin, ang) = if chain.is_translation(k) {
                (w, [V::zero(s); 3])
            } else {
                (cross3(&w, &lever[chain.spring_joint(k)]), w)
            };
            for d in 0..3 {
                lin[d].store(&mut buf[d]);
                ang[d].store(&mut buf[3 + d]);
            }
            for (l, block) in out[i * 6 * m..]
                .chunks_exact_mut(6 * m)
                .take(count)
                .enumerate()
            {
                for (d, b) in buf.iter().enumerate() {
                    block[k * col_stride + d * row_stride] = b[l];
                }
            }
        }
        i += count;
    }
}

#[cfg(test)]
mod tests {
    //! Every instruction set this machine has (and pulp's scalar type) against an independent
    //! path: the Gram matrix of the dense whitened design built row by row by
    //! `crate::build_design`, and the scalar per-configuration Jacobian.
    use super::*;
    use crate::{
        build_design, IdentifyOptions, Measurements, SerialChain, VirtualJointModel, Workspace,
    };

    fn problem_data(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        // Deterministic, spread over the joint ranges; n is not a multiple of any lane count.
        let chain = SerialChain::bundled();
        let mut q = Vec::new();
        for i in 0..n {
            for (j, &(lo, hi)) in chain.limits().iter().enumerate() {
                let t = ((i * 7 + j * 3) % 17) as f64 / 16.0;
                q.push(lo + (hi - lo) * t);
            }
        }
        let w: Vec<f64> = (0..6 * n)
            .map(|k| ((k * 37 % 23) as f64 - 11.0) * if k % 6 < 3 { 4.0 } else { 0.3 })
            .collect();
        let d: Vec<f64> = (0..3 * n)
            .map(|k| ((k * 13 % 19) as f64 - 9.0) * 1e-5)
            .collect();
        let r: Vec<f64> = (0..3 * n)
            .map(|k| ((k * 11 % 7) as f64 - 3.0) * 1e-5)
            .collect();
        (q, w, d, r)
    }

    struct Each<'a, 'b>(&'b GramProblem<'a>, usize);
    impl WithSimd for Each<'_, '_> {
        type Output = Vec<f64>;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Vec<f64> {
            if self.0.rows == 6 {
                gram_lanes::<S, 6>(s, self.0, 0, self.1)
            } else {
                gram_lanes::<S, 3>(s, self.0, 0, self.1)
            }
        }
    }

    fn levels<'a, 'b>(pb: &'b GramProblem<'a>, n: usize) -> Vec<(&'static str, Vec<f64>)> {
        let mut out = vec![("scalar", Each(pb, n).with_simd(pulp::Scalar))];
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            if let Some(v3) = pulp::x86::V3::try_new() {
                out.push(("avx2", Simd::vectorize(v3, Each(pb, n))));
            }
            if let Some(v4) = pulp::x86::V4::try_new() {
                out.push(("avx512", Simd::vectorize(v4, Each(pb, n))));
            }
        }
        out
    }

    #[test]
    fn gram_equals_the_dense_design_on_every_instruction_set() {
        let chain = SerialChain::bundled();
        let model = VirtualJointModel::extended(7);
        let lanes = ChainLanes::new(&chain, &model);
        let n = 37;
        let (q, w, d, r) = problem_data(n);
        for rot in [false, true] {
            let opts = IdentifyOptions {
                use_rotations: rot,
                noise_sigma: [1e-5, 2e-5, 1.5e-5, 1e-4, 2e-4, 3e-4],
                ..Default::default()
            };
            let (design, rhs) = build_design(
                &chain,
                &model,
                Measurements::new(&q, &w, &d).with_rotation(Some(&r)),
                &opts,
            )
            .unwrap();
            let (m, p) = (21, 22);
            let rows = rhs.len();
            let mut expect = vec![0.0; p * p];
            for i in 0..rows {
                let row: Vec<f64> = design[i * m..(i + 1) * m]
                    .iter()
                    .copied()
                    .chain([rhs[i]])
                    .collect();
                for a in 0..p {
                    for b in 0..p {
                        expect[a * p + b] += row[a] * row[b];
                    }
                }
            }
            let scale = expect.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let pb = GramProblem {
                chain: &lanes,
                q: &q,
                wrench: &w,
                displacement: &d,
                rotation: rot.then_some(&r[..]),
                rows: if rot { 6 } else { 3 },
                inv_sigma: opts.noise_sigma.map(|s| 1.0 / s),
            };
            for (name, got) in levels(&pb, n) {
                let worst = got
                    .iter()
                    .zip(&expect)
                    .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()));
                assert!(
                    worst <= 1e-13 * scale,
                    "{name}, rotations {rot}: {worst:e} of {scale:e}"
                );
            }
        }
    }

    struct Jac<'a>(&'a ChainLanes, &'a [f64], usize, JacobianLayout);
    impl WithSimd for Jac<'_> {
        type Output = Vec<f64>;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Vec<f64> {
            let mut out = vec![0.0; self.2];
            jacobian_lanes(s, self.0, self.1, &mut out, self.3, None);
            out
        }
    }

    #[test]
    fn batched_jacobian_equals_the_scalar_one_on_every_instruction_set() {
        let chain = SerialChain::bundled();
        // Offsets and a custom spring list exercise the general-axis and offset branches.
        let offsets = (0..7)
            .map(|j| nalgebra::Vector3::new(0.01 * j as f64, -0.02, 0.005))
            .collect();
        let model = VirtualJointModel::extended(7)
            .with_offsets(offsets)
            .unwrap();
        let lanes = ChainLanes::new(&chain, &model);
        let n = 21;
        let (q, ..) = problem_data(n);
        let mut ws = Workspace::new(&chain, &model).unwrap();
        let mut expect = vec![0.0; n * 126];
        for (qi, oi) in q.chunks_exact(7).zip(expect.chunks_exact_mut(126)) {
            crate::jacobian_in_place(&chain, &model, qi, &mut ws, oi).unwrap();
        }
        // Row-major blocks hold the same values at (r, k) → r·m + k instead of 6k + r.
        let mut expect_row_major = vec![0.0; n * 126];
        for (src, dst) in expect
            .chunks_exact(126)
            .zip(expect_row_major.chunks_exact_mut(126))
        {
            for k in 0..21 {
                for r in 0..6 {
                    dst[r * 21 + k] = src[6 * k + r];
                }
            }
        }
        for (layout, expect) in [
            (JacobianLayout::ColumnMajor, &expect),
            (JacobianLayout::RowMajor, &expect_row_major),
        ] {
            let mut got = vec![(
                "scalar",
                Jac(&lanes, &q, n * 126, layout).with_simd(pulp::Scalar),
            )];
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            {
                if let Some(v3) = pulp::x86::V3::try_new() {
                    got.push((
                        "avx2",
                        Simd::vectorize(v3, Jac(&lanes, &q, n * 126, layout)),
                    ));
                }
                if let Some(v4) = pulp::x86::V4::try_new() {
                    got.push((
                        "avx512",
                        Simd::vectorize(v4, Jac(&lanes, &q, n * 126, layout)),
                    ));
                }
            }
            for (name, g) in got {
                let worst = g
                    .iter()
                    .zip(expect.iter())
                    .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()));
                assert!(worst <= 1e-14 * 8.0, "{name}, {layout:?}: {worst:e}");
            }
        }
    }
}
