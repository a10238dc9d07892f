//! The chord matrix `I − C T₀` of the static equilibrium, factored once per configuration and
//! solved once per iteration, on buffers kept from one row to the next (a batch of equilibria
//! allocates nothing per row).
//!
//! Hand-written LU with partial pivoting (the pivot of largest magnitude, as nalgebra's `lu`).
//! The matrices are 7×7 to 42×42, one per row of a campaign: nalgebra's LU allocates its matrix
//! and permutation per call, and faer's recursive, dispatched LU took longer on a 7×7 than the
//! whole equilibrium's torque sweeps (profile of `predict_sag`, 2026-12-06). Pinned to nalgebra
//! by `chord_solves_equal_nalgebras`.

use nalgebra::DMatrix;

/// Reusable LU of an m×m chord matrix: `lu` row-major, L unit lower (below the diagonal) and U
/// upper; `pivot[k]` the row swapped with row k at step k.
#[derive(Debug, Clone, Default)]
pub(crate) struct ChordLu {
    lu: Vec<f64>,
    pivot: Vec<usize>,
    m: usize,
}

impl ChordLu {
    /// Factors `I − diag(c) t` (`t` m×m, `c` m values). False when the matrix is singular or
    /// not finite (a zero or non-finite pivot).
    pub(crate) fn factor(&mut self, c: &[f64], t: &DMatrix<f64>) -> bool {
        let m = c.len();
        self.m = m;
        self.lu.clear();
        self.lu.resize(m * m, 0.0);
        self.pivot.clear();
        self.pivot.resize(m, 0);
        let a = &mut self.lu;
        for i in 0..m {
            for k in 0..m {
                a[i * m + k] = f64::from(u8::from(i == k)) - c[i] * t[(i, k)];
            }
        }
        for k in 0..m {
            let mut p = k;
            for i in k + 1..m {
                if a[i * m + k].abs() > a[p * m + k].abs() {
                    p = i;
                }
            }
            let pivot = a[p * m + k];
            if pivot == 0.0 || !pivot.is_finite() {
                return false;
            }
            self.pivot[k] = p;
            if p != k {
                for j in 0..m {
                    a.swap(k * m + j, p * m + j);
                }
            }
            for i in k + 1..m {
                let l = a[i * m + k] / pivot;
                a[i * m + k] = l;
                if l != 0.0 {
                    for j in k + 1..m {
                        a[i * m + j] -= l * a[k * m + j];
                    }
                }
            }
        }
        true
    }

    /// Overwrites `rhs` (m values) with the solution of the factored system.
    pub(crate) fn solve(&self, rhs: &mut [f64]) {
        let (m, a) = (self.m, &self.lu);
        for k in 0..m {
            rhs.swap(k, self.pivot[k]);
        }
        for i in 1..m {
            let s: f64 = (0..i).map(|j| a[i * m + j] * rhs[j]).sum();
            rhs[i] -= s;
        }
        for i in (0..m).rev() {
            let s: f64 = (i + 1..m).map(|j| a[i * m + j] * rhs[j]).sum();
            rhs[i] = (rhs[i] - s) / a[i * m + i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against nalgebra's LU on seeded chord matrices of 1 to 42 springs, one buffer reused
    /// across sizes; a singular matrix is refused.
    #[test]
    fn chord_solves_equal_nalgebras() {
        let mut lu = ChordLu::default();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        // Small compliances (diagonally dominant, no row swap) and large ones (rows swapped).
        for (m, size) in [
            (1, 1e-3),
            (2, 1.0),
            (7, 1e-3),
            (7, 1.0),
            (21, 1.0),
            (42, 1.0),
            (21, 1e-3),
        ] {
            let t = DMatrix::from_fn(m, m, |_, _| 50.0 * next());
            let c: Vec<f64> = (0..m).map(|_| size * (1.0 + next())).collect();
            let a = DMatrix::from_fn(m, m, |i, k| f64::from(u8::from(i == k)) - c[i] * t[(i, k)]);
            let b: Vec<f64> = (0..m).map(|_| next()).collect();
            assert!(lu.factor(&c, &t));
            let mut x = b.clone();
            lu.solve(&mut x);
            let want = a
                .clone()
                .lu()
                .solve(&nalgebra::DVector::from_column_slice(&b))
                .unwrap();
            let scale = want.amax();
            for i in 0..m {
                assert!(
                    (x[i] - want[i]).abs() <= 1e-12 * scale,
                    "m = {m}, entry {i}"
                );
            }
        }
        // I − C T = 0: c = 1 and T = I.
        assert!(!lu.factor(&[1.0, 1.0], &DMatrix::identity(2, 2)));
    }
}
