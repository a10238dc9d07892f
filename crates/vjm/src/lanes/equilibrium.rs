//! The deflected equilibrium of linear virtual springs under a row's wrench, over L rows at
//! once: the geometric non-linearity column of the diagnosis, which every row of a diagnosis'
//! main pass needs and which costs a fixed-point iteration per row.
//!
//! The algorithm is `crate::diagnose::rows::RowBuilder::exact_displacement`'s, step for step
//! (see its documentation for the kinematics): per step, `sin θ` and `1 − cos θ` of every
//! deflecting spring by their Taylor series, a sweep from the tip that carries the
//! displacement, and a sweep from the base that turns the wrench back and gives the next
//! deflections. Each lane stops where the scalar code stops (the first step whose update moves
//! no deflection by more than 1e-14 of the largest) and keeps that step's displacement; the
//! other lanes go on. The series (longer than the scalar code's) is exact in double precision
//! below 0.25 rad; a batch with a deflection beyond is left to the scalar code, which switches
//! to the library's sine.

use pulp::{Simd, WithSimd};

use super::vector::{
    add3, cross3, dot3, gather, rotation_minus_identity, sin_versine, MAX_LANES, SERIES_LIMIT,
};
use super::V;

/// Steps at most (the scalar code's cap).
const MAX_STEPS: usize = 100;

/// The inputs of a batch of rows for [`deflected_displacements`], K deflecting springs each.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EquilibriumRows<'a> {
    /// Compliance of each deflecting spring, rad/(N·m) (K values, none zero).
    pub(crate) compliance: &'a [f64],
    /// Per row r and spring k, at `(r·K + k)·6`: the spring's Jacobian column
    /// `[a × (p − c); a]` (base frame).
    pub(crate) columns: &'a [f64],
    /// Per row r and spring k, at `r·K + k`: the spring torque `Jᵀ W` under the row's wrench,
    /// N·m.
    pub(crate) torque: &'a [f64],
    /// Per row, at `6r`: the wrench `[f; m]`, base frame, N and N·m.
    pub(crate) wrench: &'a [f64],
}

/// The tip displacement (m, base frame) of the deflected equilibrium of each of the `n` rows
/// into `out`, or `false` when some row's deflection reached 0.25 rad (then `out` is
/// incomplete and the caller uses the scalar code for the batch).
pub(crate) fn deflected_displacements(
    rows: &EquilibriumRows<'_>,
    n: usize,
    out: &mut [[f64; 3]],
) -> bool {
    struct Task<'a, 'b>(&'b EquilibriumRows<'a>, usize, &'b mut [[f64; 3]]);
    impl WithSimd for Task<'_, '_> {
        type Output = bool;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> bool {
            let Task(rows, n, out) = self;
            deflected_lanes(s, rows, n, out)
        }
    }
    pulp::Arch::new().dispatch(Task(rows, n, out))
}

/// [`deflected_displacements`] in the instruction set `S`, `V::<S>::LANES` rows at a time.
#[inline(always)]
fn deflected_lanes<S: Simd>(
    s: S,
    rows: &EquilibriumRows<'_>,
    n: usize,
    out: &mut [[f64; 3]],
) -> bool {
    let lanes = V::<S>::LANES;
    let mut springs = Vec::with_capacity(rows.compliance.len());
    let mut i = 0;
    while i < n {
        let count = (n - i).min(lanes);
        if !equilibrium_lanes(s, rows, i, count, &mut springs, &mut out[i..i + count]) {
            return false;
        }
        i += count;
    }
    true
}

/// Per spring of a batch: compliance, axis, offset across the axis, and the deflections.
struct SpringLanes<S: Simd> {
    c: V<S>,
    a: [V<S>; 3],
    x: [V<S>; 3],
    theta: V<S>,
    next: V<S>,
    sin: V<S>,
    versine: V<S>,
    after: [V<S>; 3],
}

#[inline(always)]
fn equilibrium_lanes<S: Simd>(
    s: S,
    rows: &EquilibriumRows<'_>,
    i: usize,
    count: usize,
    springs: &mut Vec<SpringLanes<S>>,
    out: &mut [[f64; 3]],
) -> bool {
    let k_springs = rows.compliance.len();
    let zero = V::zero(s);
    springs.clear();
    springs.extend((0..k_springs).map(|k| {
        let w = 6 * k_springs;
        let u = [0, 1, 2].map(|d| gather(s, rows.columns, w, 6 * k + d, i, count));
        let a = [3, 4, 5].map(|d| gather(s, rows.columns, w, 6 * k + d, i, count));
        let c = V::splat(s, rows.compliance[k]);
        SpringLanes {
            c,
            a,
            x: cross3(&u, &a),
            theta: c * gather(s, rows.torque, k_springs, k, i, count),
            next: zero,
            sin: zero,
            versine: zero,
            after: [zero; 3],
        }
    }));
    let f = [0, 1, 2].map(|d| gather(s, rows.wrench, 6, d, i, count));
    let m = [3, 4, 5].map(|d| gather(s, rows.wrench, 6, d, i, count));
    let mut done = [false; MAX_LANES];
    done[count..].fill(true);
    let mut buf = [0.0; MAX_LANES];
    let mut d = [zero; 3];
    for _ in 0..MAX_STEPS {
        for sp in springs.iter_mut() {
            sp.theta.store(&mut buf);
            if buf[..count].iter().any(|t| t.abs() >= SERIES_LIMIT) {
                return false;
            }
            (sp.sin, sp.versine) = sin_versine(s, sp.theta);
        }
        d = [zero; 3];
        for sp in springs.iter_mut().rev() {
            let y = add3(&d, &sp.x);
            d = add3(&d, &rotation_minus_identity(&sp.a, sp.sin, sp.versine, &y));
            sp.after = d;
        }
        let (mut fk, mut mk) = (f, m);
        for sp in springs.iter_mut() {
            let lever = add3(&sp.after, &sp.x);
            sp.next = sp.c * (dot3(&sp.a, &cross3(&lever, &fk)) + dot3(&sp.a, &mk));
            let back_f = rotation_minus_identity(&sp.a, -sp.sin, sp.versine, &fk);
            let back_m = rotation_minus_identity(&sp.a, -sp.sin, sp.versine, &mk);
            fk = add3(&fk, &back_f);
            mk = add3(&mk, &back_m);
        }
        // Per lane: the largest update and the largest next deflection.
        let mut change = [0.0f64; MAX_LANES];
        let mut scale = [1e-300f64; MAX_LANES];
        let mut theta = [0.0; MAX_LANES];
        for sp in springs.iter() {
            sp.next.store(&mut buf);
            sp.theta.store(&mut theta);
            for l in 0..count {
                change[l] = change[l].max((buf[l] - theta[l]).abs());
                scale[l] = scale[l].max(buf[l].abs());
            }
        }
        let mut dl = [[0.0; MAX_LANES]; 3];
        for (v, b) in d.iter().zip(dl.iter_mut()) {
            v.store(b);
        }
        for l in 0..count {
            if !done[l] && change[l] <= 1e-14 * scale[l] {
                done[l] = true;
                out[l] = [dl[0][l], dl[1][l], dl[2][l]];
            }
        }
        if done.iter().all(|x| *x) {
            return true;
        }
        for sp in springs.iter_mut() {
            sp.theta = sp.next;
        }
    }
    // The cap: the lanes still going keep the last step's displacement, as the scalar code.
    let mut dl = [[0.0; MAX_LANES]; 3];
    for (v, b) in d.iter().zip(dl.iter_mut()) {
        v.store(b);
    }
    for l in 0..count {
        if !done[l] {
            out[l] = [dl[0][l], dl[1][l], dl[2][l]];
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch of 13 rows (a partial vector on every instruction set) with the Panda's
    /// nominal torsions, solved on pulp's scalar type and on every instruction set this
    /// machine has, against the scalar code of the diagnosis row by row.
    #[test]
    fn the_equilibrium_is_the_same_on_every_instruction_set() {
        use crate::dataset::Dataset;
        use crate::diagnose::rows::RowBuilder;
        let chain = crate::SerialChain::bundled();
        let n = 13;
        let q = super::super::seeded_configurations(&chain, n, 0x2545_F491_4F6C_DD1D);
        let mut state = 0x2545_F491_4F6C_DD1Du64 ^ 0x9e37;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let w: Vec<f64> = (0..6 * n)
            .map(|k| (2.0 * uniform() - 1.0) * if k % 6 < 3 { 80.0 } else { 3.0 })
            .collect();
        let data = Dataset::new(7, q, w, vec![1e-4; 3 * n], None, None, None).unwrap();
        let torsion = crate::model::NOMINAL_TORSION;
        let c: Vec<f64> = (0..21)
            .map(|s| {
                if s % 3 == 0 {
                    torsion[s / 3]
                } else if s % 3 == 1 {
                    0.2 * torsion[s / 3]
                } else {
                    0.0
                }
            })
            .collect();
        let mut b = RowBuilder::new(&chain, [0.0; 6]);
        let springs: Vec<usize> = (0..21).filter(|s| c[*s] != 0.0).collect();
        let compliance: Vec<f64> = springs.iter().map(|s| c[*s]).collect();
        let (mut columns, mut torque, mut wrench, mut want) = (vec![], vec![], vec![], vec![]);
        let mut row = b.empty_row();
        for i in 0..n {
            b.row_into(&data, i, &mut row);
            for &s in &springs {
                columns.extend_from_slice(&row.jacobian.as_slice()[6 * s..6 * s + 6]);
                torque.push(row.tau[s]);
            }
            wrench.extend_from_slice(&row.wrench);
            let d = b.exact_displacement(&row, &c);
            let lin = crate::diagnose::candidates::spring_prediction(&row, &c);
            let nonlinear = (0..3).map(|k| (d[k] - lin[k]).powi(2)).sum::<f64>().sqrt();
            want.push((d, nonlinear));
        }
        let rows = EquilibriumRows {
            compliance: &compliance,
            columns: &columns,
            torque: &torque,
            wrench: &wrench,
        };
        struct Solve<'a, 'b>(&'b EquilibriumRows<'a>, usize);
        impl WithSimd for Solve<'_, '_> {
            type Output = Option<Vec<[f64; 3]>>;
            #[inline(always)]
            fn with_simd<S: Simd>(self, s: S) -> Self::Output {
                let mut out = vec![[0.0; 3]; self.1];
                deflected_lanes(s, self.0, self.1, &mut out).then_some(out)
            }
        }
        let mut got = vec![("scalar", Solve(&rows, n).with_simd(pulp::Scalar::new()))];
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            if let Some(v3) = pulp::x86::V3::try_new() {
                got.push(("avx2", Simd::vectorize(v3, Solve(&rows, n))));
            }
            if let Some(v4) = pulp::x86::V4::try_new() {
                got.push(("avx512", Simd::vectorize(v4, Solve(&rows, n))));
            }
        }
        for (name, out) in got {
            let out = out.expect("deflections below 0.25 rad");
            for (i, (d, (e, nonlinear))) in out.iter().zip(&want).enumerate() {
                let diff = (0..3).map(|k| (d[k] - e[k]).powi(2)).sum::<f64>().sqrt();
                assert!(
                    *nonlinear > 0.0 && diff <= 1e-10 * nonlinear,
                    "{name}, row {i}: {diff:e} off (non-linear part {nonlinear:e})"
                );
            }
        }
    }
}
