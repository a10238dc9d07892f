//! A branch-light `sin_cos` for the Jacobian hot loop.
//!
//! The platform `sin_cos` is a large share of a 7-joint Jacobian (one call per joint). Joint
//! angles are small (|q| ≲ 2π), so a quadrant reduction with a three-part π/2 (Cody–Waite)
//! and the Cephes minimax polynomials on [−π/4, π/4] give the same values to within an
//! ulp or two at a fraction of the cost; larger arguments fall back to the platform call.

// The Cephes constants are kept digit for digit as published.
#![allow(clippy::excessive_precision)]

const FRAC_2_PI: f64 = std::f64::consts::FRAC_2_PI;
// π/2 split so that k·PIO2_1 and k·PIO2_2 are exact for |k| < 2¹⁶ (Cephes DP1..DP3 × 2).
const PIO2_1: f64 = 1.570_796_251_296_997_070_31;
const PIO2_2: f64 = 7.549_789_415_861_596_353_36e-8;
const PIO2_3: f64 = 5.390_302_858_158_119_052_90e-15;
const SIN: [f64; 6] = [
    1.589_623_015_765_465_680_60e-10,
    -2.505_074_776_285_780_728_66e-8,
    2.755_731_362_138_572_452_13e-6,
    -1.984_126_982_958_953_859_96e-4,
    8.333_333_333_322_118_588_78e-3,
    -1.666_666_666_666_663_072_95e-1,
];
const COS: [f64; 6] = [
    -1.135_853_652_138_768_173_00e-11,
    2.087_570_084_197_473_167_78e-9,
    -2.755_731_417_929_673_881_12e-7,
    2.480_158_728_885_170_453_48e-5,
    -1.388_888_888_887_305_641_16e-3,
    4.166_666_666_666_659_292_18e-2,
];

#[inline(always)]
fn horner(z: f64, c: &[f64; 6]) -> f64 {
    ((((c[0] * z + c[1]) * z + c[2]) * z + c[3]) * z + c[4]) * z + c[5]
}

/// `(sin x, cos x)`, within 2 ulp of the platform's for |x| ≤ 1e4, identical beyond.
#[inline(always)]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if !x.is_finite() || x.abs() > 1e4 {
        return x.sin_cos();
    }
    let k = (x * FRAC_2_PI).round();
    let r = ((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3;
    let z = r * r;
    let s = r + r * z * horner(z, &SIN);
    let c = 1.0 - 0.5 * z + z * z * horner(z, &COS);
    match (k as i64) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests {
    /// Against the platform sin_cos on a dense grid of joint-like angles and a few large ones.
    #[test]
    fn matches_platform_sin_cos() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..=n {
            let x = -20.0 + 40.0 * i as f64 / n as f64;
            let (s, c) = super::sin_cos(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst <= 4.5e-16, "max abs difference {worst:e}");
        for x in [
            0.0,
            -0.0,
            1e-300,
            std::f64::consts::FRAC_PI_4,
            9999.0,
            1e5,
            -3e7,
        ] {
            let (s, c) = super::sin_cos(x);
            let (s0, c0) = x.sin_cos();
            assert!(
                (s - s0).abs() <= 4.5e-16 && (c - c0).abs() <= 4.5e-16,
                "{x}"
            );
        }
    }
}
