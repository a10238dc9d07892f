//! `V<S>`: one SIMD vector of f64 lanes of the dispatched instruction set `S` (pulp), with
//! arithmetic operators, and a lane-wise `sin_cos`.

// The Cephes constants are kept digit for digit as published.
#![allow(clippy::excessive_precision)]

use std::ops::{Add, Mul, Neg, Sub};

use pulp::Simd;

/// SIMD vectors per [`V`]: two independent instruction streams, so that the long dependent
/// chains of the kinematics (a 3×3 product per joint) overlap.
const UNROLL: usize = 2;

/// Most lanes a [`V`] has (8 f64 per vector under AVX-512); sizes lane buffers.
pub(crate) const MAX_LANES: usize = 8 * UNROLL;

/// `UNROLL · S::F64_LANES` lanes of f64 (16 under AVX-512, 8 under AVX2, 2 in the scalar
/// fallback).
#[derive(Clone, Copy)]
pub(crate) struct V<S: Simd> {
    s: S,
    v: [S::f64s; UNROLL],
}

/// `V { s, v: [e(0), e(1)] }`, the expression written out per vector (no closure: see
/// `horner`).
macro_rules! each {
    ($s:ident = $sv:expr, $i:ident => $e:expr) => {{
        #[allow(clippy::redundant_locals)]
        let $s = $sv;
        V {
            s: $s,
            v: [
                {
                    let $i = 0;
                    $e
                },
                {
                    let $i = 1;
                    $e
                },
            ],
        }
    }};
}
const _: () = assert!(UNROLL == 2, "`each!` writes out two vectors");

impl<S: Simd> V<S> {
    /// Lanes per [`V`].
    pub(crate) const LANES: usize = S::F64_LANES * UNROLL;

    #[inline(always)]
    pub(crate) fn splat(s: S, x: f64) -> Self {
        Self {
            s,
            v: [s.splat_f64s(x); UNROLL],
        }
    }
    #[inline(always)]
    pub(crate) fn zero(s: S) -> Self {
        Self::splat(s, 0.0)
    }
    /// From exactly [`Self::LANES`] values.
    #[inline(always)]
    pub(crate) fn load(s: S, lanes: &[f64]) -> Self {
        let (head, _) = S::as_simd_f64s(&lanes[..Self::LANES]);
        each!(s = s, i => head[i])
    }
    /// Into exactly [`Self::LANES`] values.
    #[inline(always)]
    pub(crate) fn store(self, lanes: &mut [f64]) {
        let (head, _) = S::as_mut_simd_f64s(&mut lanes[..Self::LANES]);
        head.copy_from_slice(&self.v);
    }
    /// `self · a + b`, fused where the instruction set has FMA.
    #[inline(always)]
    pub(crate) fn mul_add(self, a: Self, b: Self) -> Self {
        each!(s = self.s, i => s.mul_add_e_f64s(self.v[i], a.v[i], b.v[i]))
    }
    /// `acc + Σ_lanes-wise self·other` folded into one vector: both halves of the unrolled
    /// pair land in the same accumulator, which halves the accumulator memory of a Gram
    /// update (the packed 22×22 triangle is then 16 KiB under AVX-512 and stays in L1).
    #[inline(always)]
    pub(crate) fn fma_into(self, other: Self, acc: S::f64s) -> S::f64s {
        let mut t = acc;
        for i in 0..UNROLL {
            t = self.s.mul_add_e_f64s(self.v[i], other.v[i], t);
        }
        t
    }
    /// Sum of the lanes.
    #[cfg(test)]
    #[inline(always)]
    pub(crate) fn sum(self) -> f64 {
        let s = self.s;
        s.reduce_sum_f64s(s.add_f64s(self.v[0], self.v[1]))
    }
    /// Lane-wise select: `if_true` where `mask`, else `if_false`.
    #[inline(always)]
    fn select(s: S, mask: [S::m64s; UNROLL], if_true: Self, if_false: Self) -> Self {
        each!(s = s, i => s.select_f64s(mask[i], if_true.v[i], if_false.v[i]))
    }
}

impl<S: Simd> Add for V<S> {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        each!(s = self.s, i => s.add_f64s(self.v[i], rhs.v[i]))
    }
}
impl<S: Simd> Sub for V<S> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: Self) -> Self {
        each!(s = self.s, i => s.sub_f64s(self.v[i], rhs.v[i]))
    }
}
impl<S: Simd> Mul for V<S> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        each!(s = self.s, i => s.mul_f64s(self.v[i], rhs.v[i]))
    }
}
impl<S: Simd> Neg for V<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        each!(s = self.s, i => s.neg_f64s(self.v[i]))
    }
}

/// Gathers column `col` of the row-major `rows×width` table for the `count` measurements
/// from `i` into lanes; unused lanes are 0 (they then add nothing to any sum).
#[inline(always)]
pub(crate) fn gather<S: Simd>(
    s: S,
    data: &[f64],
    width: usize,
    col: usize,
    i: usize,
    count: usize,
) -> V<S> {
    let mut buf = [0.0; MAX_LANES];
    for (l, b) in buf.iter_mut().enumerate().take(count) {
        *b = data[(i + l) * width + col];
    }
    V::load(s, &buf)
}

/// Dot product of two 3-vectors of lanes.
#[inline(always)]
pub(crate) fn dot3<S: Simd>(a: &[V<S>; 3], b: &[V<S>; 3]) -> V<S> {
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// Cross product `a × b` of two 3-vectors of lanes.
#[inline(always)]
pub(crate) fn cross3<S: Simd>(a: &[V<S>; 3], b: &[V<S>; 3]) -> [V<S>; 3] {
    [
        a[1].mul_add(b[2], -(a[2] * b[1])),
        a[2].mul_add(b[0], -(a[0] * b[2])),
        a[0].mul_add(b[1], -(a[1] * b[0])),
    ]
}

/// Largest |θ| (rad) [`sin_versine`]'s series is used for.
pub(crate) const SERIES_LIMIT: f64 = 0.25;

/// `sin θ` and `1 − cos θ` by their series, exact in double precision for |θ| < [`SERIES_LIMIT`] (the
/// first term left out, θ¹⁷/17!, is below 1e-24 of `sin θ` there), lane-wise.
#[inline(always)]
pub(crate) fn sin_versine<S: Simd>(s: S, theta: V<S>) -> (V<S>, V<S>) {
    let t2 = theta * theta;
    let one = V::splat(s, 1.0);
    // Nested from the innermost factor: sin θ = θ(1 − θ²/(2·3)(1 − θ²/(4·5)(⋯))) and
    // 1 − cos θ = ½θ²(1 − θ²/(3·4)(1 − θ²/(5·6)(⋯))).
    let mut sin = one;
    let mut versine = one;
    for k in (1..=7).rev() {
        let (a, b) = (2.0 * k as f64, 2.0 * k as f64 + 1.0);
        sin = one - t2 * V::splat(s, 1.0 / (a * b)) * sin;
        versine = one - t2 * V::splat(s, 1.0 / (b * (b + 1.0))) * versine;
    }
    (theta * sin, V::splat(s, 0.5) * t2 * versine)
}

/// `(R − I) y` for rotations about the unit axes `a` with `sin θ` and `1 − cos θ` given
/// (Rodrigues), lane-wise.
#[inline(always)]
pub(crate) fn rotation_minus_identity<S: Simd>(
    a: &[V<S>; 3],
    sin: V<S>,
    versine: V<S>,
    y: &[V<S>; 3],
) -> [V<S>; 3] {
    let ay = cross3(a, y);
    let aay = cross3(a, &ay);
    // Written out: a closure (`array::from_fn`) is not inlined into the dispatched function.
    [
        aay[0].mul_add(versine, ay[0] * sin),
        aay[1].mul_add(versine, ay[1] * sin),
        aay[2].mul_add(versine, ay[2] * sin),
    ]
}

#[inline(always)]
pub(crate) fn add3<S: Simd>(a: &[V<S>; 3], b: &[V<S>; 3]) -> [V<S>; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

// sin/cos of joint angles: a quadrant reduction with π/2 in three parts (Cody–Waite) and the
// Cephes minimax polynomials on [−π/4, π/4], within an ulp or two of the platform's at a
// fraction of the cost (|x| ≤ 1e4; beyond, the platform call). Arranged without branches:
// the quadrant comes from the low bits of `x·2/π + 1.5·2⁵²` (round to nearest, exact for
// |k| < 2⁵¹) and is applied with selects.
const FRAC_2_PI: f64 = std::f64::consts::FRAC_2_PI;
const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5·2⁵²
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
/// Beyond this |x| (rad) the three-part reduction loses accuracy: those lanes take the
/// platform `sin_cos` (joint angles never get there; it keeps absurd inputs exact).
const REDUCTION_LIMIT: f64 = 1e4;

// No closures on the hot path: a closure is not `#[inline(always)]`, so it may be compiled
// outside the dispatched function, without its features, and call every intrinsic.
#[inline(always)]
fn horner<S: Simd>(s: S, z: V<S>, c: &[f64; 6]) -> V<S> {
    let mut acc = V::splat(s, c[0]);
    for &ci in &c[1..] {
        acc = z.mul_add(acc, V::splat(s, ci));
    }
    acc
}

/// Per vector, the lanes where bit `b` of `q + add` is clear.
#[inline(always)]
fn bits_clear<S: Simd>(s: S, q: &[S::u64s; UNROLL], b: u64, add: u64) -> [S::m64s; UNROLL] {
    [
        bit_clear(s, s.add_u64s(q[0], s.splat_u64s(add)), b),
        bit_clear(s, s.add_u64s(q[1], s.splat_u64s(add)), b),
    ]
}

/// Lanes where bit `b` of `q` is clear.
#[inline(always)]
fn bit_clear<S: Simd>(s: S, q: S::u64s, b: u64) -> S::m64s {
    s.equal_u64s(s.and_u64s(q, s.splat_u64s(b)), s.splat_u64s(0))
}

/// `(sin x, cos x)` lane by lane, within 2 ulp of the platform's.
#[inline(always)]
pub(crate) fn sin_cos<S: Simd>(s: S, x: V<S>) -> (V<S>, V<S>) {
    let t = x.mul_add(V::splat(s, FRAC_2_PI), V::splat(s, ROUND_MAGIC));
    let k = t - V::splat(s, ROUND_MAGIC);
    let quadrant: [S::u64s; UNROLL] =
        [s.transmute_u64s_f64s(t.v[0]), s.transmute_u64s_f64s(t.v[1])];
    let r = ((x - k * V::splat(s, PIO2_1)) - k * V::splat(s, PIO2_2)) - k * V::splat(s, PIO2_3);
    let z = r * r;
    let sr = (r * z).mul_add(horner(s, z, &SIN), r);
    let cr = (z * z).mul_add(horner(s, z, &COS), V::splat(s, 1.0) - V::splat(s, 0.5) * z);
    let even = bits_clear(s, &quadrant, 1, 0);
    let a = V::select(s, even, sr, cr);
    let b = V::select(s, even, cr, sr);
    let sin = V::select(s, bits_clear(s, &quadrant, 2, 0), a, -a);
    let cos = V::select(s, bits_clear(s, &quadrant, 2, 1), b, -b);
    let mut all_small = true;
    for v in x.v {
        let small = s.less_than_or_equal_f64s(s.abs_f64s(v), s.splat_f64s(REDUCTION_LIMIT));
        all_small &=
            s.reduce_min_f64s(s.select_f64s(small, s.splat_f64s(1.0), s.splat_f64s(0.0))) == 1.0;
    }
    if all_small {
        (sin, cos)
    } else {
        platform_sin_cos(s, x, sin, cos)
    }
}

/// `(sin x, cos x)` of every entry of `x` (at most [`MAX_LANES`]) into `out`, vectorised on
/// `arch`: one configuration's joint angles at once.
pub(crate) fn sin_cos_slice(arch: pulp::Arch, x: &[f64], out: &mut [(f64, f64)]) {
    struct Task<'a>(&'a [f64], &'a mut [(f64, f64)]);
    impl pulp::WithSimd for Task<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) {
            let Task(x, out) = self;
            for (xc, oc) in x.chunks(V::<S>::LANES).zip(out.chunks_mut(V::<S>::LANES)) {
                let mut buf = [0.0; MAX_LANES];
                buf[..xc.len()].copy_from_slice(xc);
                let (sv, cv) = sin_cos(s, V::load(s, &buf));
                let (mut sb, mut cb) = ([0.0; MAX_LANES], [0.0; MAX_LANES]);
                sv.store(&mut sb);
                cv.store(&mut cb);
                for (l, o) in oc.iter_mut().enumerate() {
                    *o = (sb[l], cb[l]);
                }
            }
        }
    }
    arch.dispatch(Task(x, out))
}

/// Lanes beyond [`REDUCTION_LIMIT`] (or not finite) through the platform `sin_cos`.
#[cold]
#[inline(never)]
fn platform_sin_cos<S: Simd>(s: S, x: V<S>, sin: V<S>, cos: V<S>) -> (V<S>, V<S>) {
    let n = V::<S>::LANES;
    let (mut xs, mut ss, mut cs) = ([0.0; MAX_LANES], [0.0; MAX_LANES], [0.0; MAX_LANES]);
    x.store(&mut xs);
    sin.store(&mut ss);
    cos.store(&mut cs);
    for l in 0..n {
        if xs[l].is_nan() || xs[l].abs() > REDUCTION_LIMIT {
            (ss[l], cs[l]) = xs[l].sin_cos();
        }
    }
    (V::load(s, &ss), V::load(s, &cs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pulp::WithSimd;

    /// Against the platform on a dense grid of joint-like angles, quadrant boundaries, and
    /// arguments that take the fallback; on every instruction set the machine has.
    struct Check(Vec<f64>);
    impl WithSimd for Check {
        type Output = f64;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> f64 {
            let n = V::<S>::LANES;
            let mut worst = 0.0f64;
            for chunk in self.0.chunks(n) {
                let mut v = [0.0; MAX_LANES];
                v[..chunk.len()].copy_from_slice(chunk);
                let (sv, cv) = sin_cos(s, V::load(s, &v));
                let (mut so, mut co) = ([0.0; MAX_LANES], [0.0; MAX_LANES]);
                sv.store(&mut so);
                cv.store(&mut co);
                for (l, &x) in chunk.iter().enumerate() {
                    let (s0, c0) = x.sin_cos();
                    worst = worst.max((so[l] - s0).abs()).max((co[l] - c0).abs());
                }
            }
            worst
        }
    }

    fn inputs() -> Vec<f64> {
        let n = 400_000;
        let mut xs: Vec<f64> = (0..=n)
            .map(|i| -20.0 + 40.0 * i as f64 / n as f64)
            .collect();
        for k in -12..=12 {
            let b = k as f64 * std::f64::consts::FRAC_PI_4;
            xs.extend([b, b.next_up(), b.next_down()]);
        }
        xs.extend([0.0, -0.0, 1e-300, 9999.0, 1e5, -3e7, 1e300]);
        xs
    }

    #[test]
    fn lane_sin_cos_matches_platform() {
        let worst = pulp::Arch::new().dispatch(Check(inputs()));
        assert!(worst <= 4.5e-16, "dispatched: max abs difference {worst:e}");
        let worst = Check(inputs()).with_simd(pulp::Scalar);
        assert!(worst <= 4.5e-16, "scalar: max abs difference {worst:e}");
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            if let Some(v3) = pulp::x86::V3::try_new() {
                let worst = Simd::vectorize(v3, Check(inputs()));
                assert!(worst <= 4.5e-16, "avx2: max abs difference {worst:e}");
            }
            if let Some(v4) = pulp::x86::V4::try_new() {
                let worst = Simd::vectorize(v4, Check(inputs()));
                assert!(worst <= 4.5e-16, "avx512: max abs difference {worst:e}");
            }
        }
    }

    struct CrossDot;
    impl WithSimd for CrossDot {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) {
            let v = |x: f64| V::splat(s, x);
            let a = [v(1.0), v(2.0), v(3.0)];
            let b = [v(-2.0), v(0.5), v(1.0)];
            let c = cross3(&a, &b);
            let mut out = [0.0; MAX_LANES];
            // (1,2,3) × (−2,0.5,1) = (2·1 − 3·0.5, 3·(−2) − 1·1, 1·0.5 − 2·(−2)) = (0.5, −7, 4.5)
            for (k, want) in [0.5, -7.0, 4.5].into_iter().enumerate() {
                c[k].store(&mut out);
                assert!(
                    out[..V::<S>::LANES].iter().all(|&x| x == want),
                    "component {k}"
                );
            }
            assert_eq!(
                dot3(&a, &b).sum(),
                (-2.0 + 1.0 + 3.0) * V::<S>::LANES as f64
            );
        }
    }

    #[test]
    fn cross_and_dot_are_the_vector_identities() {
        pulp::Arch::new().dispatch(CrossDot);
        CrossDot.with_simd(pulp::Scalar);
    }
}
