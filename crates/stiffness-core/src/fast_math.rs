//! The polynomial arctangent behind [`crate::so3::log`].
//!
//! Why: `log` used libm's `atan2(‖vee R‖, cos θ)`, which aims at correct rounding and cost a
//! third to a half of the whole call (13–20 ns in a batch loop on the benchmark machine), while
//! `log` needs only an ulp or two. `log` now reduces the angle itself, by the sign and size of
//! cos θ, to an argument |u| ≤ tan(π/6) (θ = 2 atan(tan(θ/2)), θ = π/2 − atan(cot θ) or
//! θ = π − 2 atan(tan((π − θ)/2))) and evaluates atan(u) = u + u·u²·f(u²) with [`atan_tail`],
//! a degree-13 polynomial in u². Because f takes u² rather than u, `log` forms u² without a
//! square root and the polynomial runs while the square root is taken. The tests below hold
//! `u + u·z·f(z)` to 1 ulp of `f64::atan` over the whole reduced range.

/// f(z) = (atan(√z) − √z)/z^{3/2} on z ∈ [0, 1/3], so that atan(u) = u + u·z·f(z) with z = u².
/// Chebyshev fit of degree 13 (mpmath `chebyfit`, 50 digits, on [0, (1 + 1e-6)/3]): with the
/// coefficients rounded to f64, |error of f|·z ≤ 5.7e-18, i.e. below 6.3e-18 relative to
/// atan(u) (u/atan u ≤ 1.1) and far under the rounding of the final sum.
const F: [f64; 14] = [
    -0.333_333_333_333_333_3,
    0.199_999_999_999_991_7,
    -0.142_857_142_855_519_76,
    0.111_111_110_985_537_03,
    -0.090_909_085_820_708_21,
    0.076_922_952_867_033_4,
    -0.066_664_696_226_516_79,
    0.058_802_125_009_543_474,
    -0.052_467_797_609_172_54,
    0.046_721_782_978_129_546,
    -0.039_937_315_041_215_81,
    0.029_952_644_963_317_756,
    -0.016_659_149_452_082_526,
    0.004_874_343_972_431_294,
];

/// f(z) of [`F`] (see there), for z ∈ [0, 1/3], by Estrin's scheme: a dependency chain
/// of 4 multiply-adds instead of Horner's 13 (the default x86-64 target has no FMA, so a
/// Horner step costs a multiply plus an add in latency).
#[inline]
pub(crate) fn atan_tail(z: f64) -> f64 {
    let z2 = z * z;
    let z4 = z2 * z2;
    let z8 = z4 * z4;
    let q0 = F[0] + F[1] * z;
    let q1 = F[2] + F[3] * z;
    let q2 = F[4] + F[5] * z;
    let q3 = F[6] + F[7] * z;
    let q4 = F[8] + F[9] * z;
    let q5 = F[10] + F[11] * z;
    let q6 = F[12] + F[13] * z;
    let r0 = q0 + q1 * z2;
    let r1 = q2 + q3 * z2;
    let r2 = q4 + q5 * z2;
    (r0 + r1 * z4) + (r2 + q6 * z4) * z8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Upper end of the range of [`atan_tail`]: z = u² ≤ tan²(π/6) = 1/3.
    const Z_MAX: f64 = 1.0 / 3.0;

    /// atan(u) for |u| ≤ tan(π/6), summed as `log` sums it.
    fn atan_reduced(u: f64) -> f64 {
        let z = u * u;
        (u * z) * atan_tail(z) + u
    }

    /// Distance in units in the last place (of the larger of the two), 0 if bit-identical.
    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        let scale = a.abs().max(b.abs());
        let ulp = if scale >= f64::MIN_POSITIVE {
            f64::from_bits(scale.to_bits() + 1) - scale
        } else {
            f64::from_bits(1)
        };
        (a - b).abs() / ulp
    }

    /// Dense grid over the whole reduced range, both signs, and log-spaced small arguments
    /// (1e-300 … 10^-0.3): within 1 ulp of libm everywhere, and not identical everywhere (or the test could not
    /// tell a polynomial from libm).
    #[test]
    fn reduced_atan_is_within_one_ulp_of_libm() {
        let u_max = Z_MAX.sqrt();
        let mut grid: Vec<f64> = (0..=2_000_000)
            .map(|i| u_max * f64::from(i) / 2_000_000.0)
            .collect();
        grid.extend((0..=2_997).map(|i| 10f64.powf(-300.0 + 0.1 * f64::from(i))));
        // The top of the range and its neighbours (z = 1/3 is the end of the fit).
        let mut u = u_max;
        for _ in 0..100 {
            grid.push(u);
            u = f64::from_bits(u.to_bits() - 1);
        }
        let (mut worst, mut differ) = (0.0f64, 0usize);
        for &u in &grid {
            for u in [u, -u] {
                let (got, want) = (atan_reduced(u), u.atan());
                let e = ulps(got, want);
                assert!(e <= 1.0, "atan({u:e}) = {got:e}, libm {want:e}: {e} ulp");
                worst = worst.max(e);
                differ += usize::from(e > 0.0);
            }
        }
        assert!(differ > 0, "never differs from libm: suspicious test");
        eprintln!(
            "reduced atan vs libm: worst {worst} ulp, {differ} of {} differ",
            2 * grid.len()
        );
    }

    #[test]
    fn reduced_atan_edge_cases() {
        // Zeros, subnormals and tiny arguments: atan(u) = u, bit for bit except that −0 comes
        // out as +0 (−0 + (−0·0)·f = +0; the angles in `log` are ≥ 0, so it never matters).
        for u in [
            5e-324,
            -5e-324,
            1e-310,
            f64::MIN_POSITIVE,
            1e-200,
            -1e-200,
            1e-20,
            -1e-20,
        ] {
            assert_eq!(atan_reduced(u).to_bits(), u.atan().to_bits(), "atan({u:e})");
        }
        for u in [0.0, -0.0] {
            assert_eq!(atan_reduced(u), 0.0);
        }
        // The tail itself at the ends of its range: −1/3 at 0, and finite, accurate at 1/3.
        assert_eq!(atan_tail(0.0), -1.0 / 3.0);
        let u = Z_MAX.sqrt();
        assert!(ulps(atan_reduced(u), std::f64::consts::FRAC_PI_6) <= 1.0);
    }
}
