//! The standard deviations, `identified` flag and excitation of predictions, from their
//! regressors, 8 or 16 rows at a time: the quadratic forms `aᵣ Σ aᵣᵀ` of the identification's
//! covariance Σ and the projections on its null space, written across rows (`crate::lanes`)
//! instead of one row's small matrices at a time.

use pulp::{Simd, WithSimd};

use super::{Prediction, StiffnessModel};
use crate::lanes::{gather, V};

/// What every prediction of one model shares, flattened (built once per call).
#[derive(Debug, Clone)]
pub(super) struct Uncertainty {
    /// Springs.
    m: usize,
    /// Axes predicted: 3 (positions) or 6 (with rotations).
    axes: usize,
    /// The covariance of the compliances, m×m row-major ((rad/(N·m))²), when known.
    covariance: Option<Vec<f64>>,
    /// `1 / column_scale` per spring.
    inverse_scale: Vec<f64>,
    /// The null space's vectors, one m-row each.
    null_space: Vec<f64>,
    /// [`EstimateRecord::identified_tol`](super::EstimateRecord::identified_tol).
    tolerance: f64,
}

impl Uncertainty {
    pub(super) fn new(model: &StiffnessModel) -> Self {
        let e = &model.estimate;
        let m = e.compliance.len();
        Self {
            m,
            axes: if model.noise.use_rotations { 6 } else { 3 },
            covariance: e
                .covariance
                .as_ref()
                .map(|rows| rows.iter().flatten().copied().collect()),
            inverse_scale: e.column_scale.iter().map(|s| 1.0 / s).collect(),
            null_space: e.null_space.iter().flatten().copied().collect(),
            tolerance: e.identified_tol,
        }
    }

    /// Sets `stddev`, `identified` and `excitation` of each of `out` (the rest as the caller
    /// left it) from its regressor in `regressors`, 6·m values per row (row-major 6×m: row r
    /// is axis r's `∂d_r/∂c`).
    ///
    /// - `excitation`: the largest over the axes of |N aᵣ| / |aᵣ / s| (N the null space, s
    ///   the column scales): the sine of the angle by which the row leaves the identified row
    ///   space; an axis with a zero regressor does not count.
    /// - `identified`: `excitation ≤ identified_tol`.
    /// - `stddev[r]`: `√(aᵣ Σ aᵣᵀ)` for each predicted axis of an identified row when the
    ///   covariance is known, else NaN.
    pub(super) fn fill(&self, regressors: &[f64], out: &mut [Prediction]) {
        debug_assert!(regressors.len() >= out.len() * 6 * self.m);
        struct Task<'a>(&'a Uncertainty, &'a [f64], &'a mut [Prediction]);
        impl WithSimd for Task<'_> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, s: S) {
                let Task(u, regressors, out) = self;
                let lanes = V::<S>::LANES;
                let mut a = vec![V::zero(s); u.m];
                for (b, chunk) in out.chunks_mut(lanes).enumerate() {
                    u.fill_lanes(s, regressors, b * lanes, chunk, &mut a);
                }
            }
        }
        pulp::Arch::new().dispatch(Task(self, regressors, out))
    }

    /// [`fill`](Self::fill) of the `out.len()` (≤ lanes) rows from `first`.
    #[inline(always)]
    fn fill_lanes<S: Simd>(
        &self,
        s: S,
        regressors: &[f64],
        first: usize,
        out: &mut [Prediction],
        a: &mut [V<S>],
    ) {
        let (m, count) = (self.m, out.len());
        let width = 6 * m;
        let mut excitation = [0.0f64; crate::lanes::MAX_LANES];
        let mut variance = [[f64::NAN; crate::lanes::MAX_LANES]; 6];
        let (mut scaled, mut outside) = (
            [0.0f64; crate::lanes::MAX_LANES],
            [0.0f64; crate::lanes::MAX_LANES],
        );
        for (r, variance_r) in variance.iter_mut().enumerate().take(self.axes) {
            for (k, ak) in a.iter_mut().enumerate() {
                *ak = gather(s, regressors, width, r * m + k, first, count);
            }
            if let Some(cov) = &self.covariance {
                let mut var = V::zero(s);
                for (i, ai) in a.iter().enumerate() {
                    let row = &cov[i * m..(i + 1) * m];
                    let mut sigma_a = V::zero(s);
                    for (c, aj) in row.iter().zip(a.iter()) {
                        sigma_a = aj.mul_add(V::splat(s, *c), sigma_a);
                    }
                    var = ai.mul_add(sigma_a, var);
                }
                var.store(variance_r);
            }
            let mut norm = V::zero(s);
            for (ak, inv) in a.iter().zip(&self.inverse_scale) {
                let x = *ak * V::splat(s, *inv);
                norm = x.mul_add(x, norm);
            }
            let mut off = V::zero(s);
            for nv in self.null_space.chunks_exact(m) {
                let mut p = V::zero(s);
                for (ak, v) in a.iter().zip(nv) {
                    p = ak.mul_add(V::splat(s, *v), p);
                }
                off = p.mul_add(p, off);
            }
            norm.store(&mut scaled);
            off.store(&mut outside);
            for l in 0..count {
                let scaled = scaled[l].sqrt();
                if scaled > 0.0 {
                    excitation[l] = excitation[l].max(outside[l].sqrt() / scaled);
                }
            }
        }
        for (l, o) in out.iter_mut().enumerate() {
            o.excitation = excitation[l];
            o.identified = excitation[l] <= self.tolerance;
            o.stddev = [f64::NAN; 6];
            if o.identified && self.covariance.is_some() {
                for (sd, v) in o.stddev.iter_mut().zip(&variance).take(self.axes) {
                    *sd = v[l].max(0.0).sqrt();
                }
            }
        }
    }
}

/// The deflection `a c` of each predicted axis (`axes` of 6; the others NaN) of a row with
/// regressor `a` (row-major 6×m) and compliance `c`.
pub(super) fn deflection_of(a: &[f64], c: &[f64], axes: usize) -> [f64; 6] {
    let m = c.len();
    let mut d = [f64::NAN; 6];
    for (r, dr) in d.iter_mut().enumerate().take(axes) {
        *dr = a[r * m..(r + 1) * m]
            .iter()
            .zip(c)
            .map(|(x, y)| x * y)
            .sum();
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeded uniform numbers in [−1, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        2.0 * ((*state >> 11) as f64 / (1u64 << 53) as f64) - 1.0
    }

    /// [`Uncertainty::fill_lanes`] over every row on the instruction set `S`.
    struct Fill<'a>(&'a Uncertainty, &'a [f64], usize);
    impl WithSimd for Fill<'_> {
        type Output = Vec<Prediction>;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Vec<Prediction> {
            let Fill(u, regressors, rows) = self;
            let mut out = vec![Prediction::UNSET; rows];
            let lanes = V::<S>::LANES;
            let mut a = vec![V::zero(s); u.m];
            for (b, chunk) in out.chunks_mut(lanes).enumerate() {
                u.fill_lanes(s, regressors, b * lanes, chunk, &mut a);
            }
            out
        }
    }

    /// Against the per-row formulas written out with nalgebra (the quadratic form `a Σ aᵀ`,
    /// the scaled row norm by division, the null-space projection), on 37 rows (partial
    /// batches) of a 7-spring model with a 2-vector null space, on pulp's scalar type and on
    /// every instruction set the machine has; with 3 and 6 axes and without a covariance.
    /// Rows are built to be identified (in the row space) or not (a null-space share of 1e-3),
    /// and one row has a zero axis (it does not count for the excitation).
    #[test]
    fn the_lanes_forms_are_the_per_row_formulas() {
        let (m, rows) = (7, 37);
        let mut state = 0x7e57_u64;
        let b = nalgebra::DMatrix::from_fn(m, m, |_, _| uniform(&mut state));
        let covariance = (&b * b.transpose()) * 1e-10;
        let null = nalgebra::DMatrix::from_fn(m, 2, |_, _| uniform(&mut state))
            .qr()
            .q();
        let scale: Vec<f64> = (0..m).map(|k| 1e-3 * (2.0 + k as f64)).collect();
        let mut regressors = vec![0.0; rows * 6 * m];
        for i in 0..rows {
            for r in 0..6 {
                let mut a = nalgebra::DVector::from_fn(m, |_, _| uniform(&mut state));
                // Into the row space (orthogonal to the null space), then a share of it back.
                a -= &null * (null.transpose() * &a);
                if i % 3 == 0 {
                    a += null.column(0) * (1e-3 * a.norm());
                }
                if i == 5 && r == 1 {
                    a.fill(0.0);
                }
                regressors[i * 6 * m + r * m..i * 6 * m + (r + 1) * m]
                    .copy_from_slice(a.as_slice());
            }
        }
        for (axes, with_covariance) in [(3, true), (6, true), (6, false)] {
            let u = Uncertainty {
                m,
                axes,
                covariance: with_covariance.then(|| covariance.transpose().as_slice().to_vec()),
                inverse_scale: scale.iter().map(|s| 1.0 / s).collect(),
                // The null space's vectors, one m-row each.
                null_space: (0..2)
                    .flat_map(|v| (0..m).map(move |k| (v, k)))
                    .map(|(v, k)| null[(k, v)])
                    .collect(),
                tolerance: 1e-6,
            };
            let mut got = vec![(
                "scalar",
                Fill(&u, &regressors, rows).with_simd(pulp::Scalar::new()),
            )];
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            {
                if let Some(v3) = pulp::x86::V3::try_new() {
                    got.push(("avx2", Simd::vectorize(v3, Fill(&u, &regressors, rows))));
                }
                if let Some(v4) = pulp::x86::V4::try_new() {
                    got.push(("avx512", Simd::vectorize(v4, Fill(&u, &regressors, rows))));
                }
            }
            for (set, out) in got {
                for i in 0..rows {
                    let mut excitation: f64 = 0.0;
                    let mut sd = [f64::NAN; 6];
                    for r in 0..axes {
                        let a = nalgebra::DVector::from_column_slice(
                            &regressors[i * 6 * m + r * m..i * 6 * m + (r + 1) * m],
                        );
                        if with_covariance {
                            sd[r] = (a.transpose() * &covariance * &a)[(0, 0)].max(0.0).sqrt();
                        }
                        let scaled = a
                            .iter()
                            .zip(&scale)
                            .map(|(x, s)| (x / s).powi(2))
                            .sum::<f64>()
                            .sqrt();
                        if scaled > 0.0 {
                            excitation = excitation.max((null.transpose() * &a).norm() / scaled);
                        }
                    }
                    let o = &out[i];
                    let identified = i % 3 != 0;
                    assert_eq!(o.identified, identified, "{set} row {i}: {}", o.excitation);
                    assert!(
                        // Rounding-sized (~1e-18) for a row in the row space.
                        (o.excitation - excitation).abs() <= 1e-12 * excitation + 1e-15,
                        "{set} row {i}: excitation {} vs {excitation}",
                        o.excitation
                    );
                    for (r, (got, want)) in o.stddev.iter().zip(&sd).enumerate() {
                        if !identified || !with_covariance || r >= axes {
                            assert!(got.is_nan(), "{set} row {i} axis {r}");
                            continue;
                        }
                        assert!(
                            (got - want).abs() <= 1e-12 * want.max(1e-300),
                            "{set} row {i} axis {r}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }
}
