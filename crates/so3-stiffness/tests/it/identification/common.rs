//! Shared helpers: a seeded RNG and an independent spring potential on SO(3).

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use so3_stiffness::so3;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

pub fn random_vector(rng: &mut ChaCha8Rng, scale: f64) -> Vector3<f64> {
    Vector3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    ) * scale
}

/// A conservative "cable" system written independently of the crate's simulator:
/// Φ(R) = Σ ½ k_s (‖R a_s − b_s‖ − L_s)² with rest lengths shorter than the cables
/// (pre-tension), so the holding moment at a generic pose is far from zero.
pub struct SpringPotential {
    pub a: Vec<Vector3<f64>>,
    pub b: Vec<Vector3<f64>>,
    pub k: Vec<f64>,
    pub rest: Vec<f64>,
}

impl SpringPotential {
    pub fn new(seed: u64) -> Self {
        let mut r = rng(seed);
        let mut p = SpringPotential {
            a: vec![],
            b: vec![],
            k: vec![],
            rest: vec![],
        };
        for s in 0..6 {
            let phi = s as f64 * std::f64::consts::PI / 3.0 + r.random_range(-0.2..0.2);
            let a = Vector3::new(0.05 * phi.cos(), 0.05 * phi.sin(), 0.08);
            let b = Vector3::new(0.064 * (phi + 0.3).cos(), 0.064 * (phi + 0.3).sin(), -0.08);
            let len = (a - b).norm();
            p.a.push(a);
            p.b.push(b);
            p.k.push(r.random_range(5_000.0..20_000.0));
            p.rest.push(len * r.random_range(0.97..0.99));
        }
        p
    }

    pub fn energy(&self, rot: &Rotation3<f64>) -> f64 {
        (0..self.a.len())
            .map(|s| {
                0.5 * self.k[s] * ((rot * self.a[s] - self.b[s]).norm() - self.rest[s]).powi(2)
            })
            .sum()
    }

    /// Holding moment τ = body gradient of Φ: τ = Σ k_s(l_s − L_s) a_s × (Rᵀu_s).
    pub fn moment(&self, rot: &Rotation3<f64>) -> Vector3<f64> {
        (0..self.a.len())
            .map(|s| {
                let c = rot * self.a[s] - self.b[s];
                let l = c.norm();
                self.k[s] * (l - self.rest[s]) * self.a[s].cross(&(rot.inverse() * (c / l)))
            })
            .sum()
    }

    /// Covariant Hessian at `r0`: Euclidean Hessian of f(ζ) = Φ(r0 exp ζ) at 0 (exponential
    /// coordinates are normal coordinates of the bi-invariant metric), by central differences
    /// of the energy only — no moment formula involved.
    pub fn covariant_hessian(&self, r0: &Rotation3<f64>) -> Matrix3<f64> {
        let h = 1e-4;
        let f = |z: Vector3<f64>| self.energy(&(r0 * so3::exp(&z)));
        let e = |i: usize| Vector3::ith(i, h);
        Matrix3::from_fn(|i, j| {
            (f(e(i) + e(j)) - f(e(i) - e(j)) - f(-e(i) + e(j)) + f(-e(i) - e(j))) / (4.0 * h * h)
        })
    }
}
