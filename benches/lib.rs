//! Shared seeded data generators for the criterion benches (`benches/*.rs`) and the
//! `vjm-identify-raw` binary used by `peer_compare.py`.
//!
//! Every generator takes an explicit seed and uses [`ChaCha8Rng`], so a bench measures the
//! same inputs on every run and on every machine.
#![deny(missing_docs)]

use nalgebra::{Rotation3, Unit, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The seed the benches use unless they say otherwise.
pub const SEED: u64 = 0x5eed_2024;

/// CPU time consumed so far by all threads of this process, s, from Linux's per-thread
/// `/proc/self/task/*/schedstat` (ns resolution, brought up to date at scheduler events, so
/// read it around work of at least tens of milliseconds). Unlike wall time it does not grow
/// while other processes hold the cores; `None` where `/proc` is unavailable.
pub fn process_cpu_seconds() -> Option<f64> {
    let mut total_ns: u64 = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total_ns += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total_ns as f64 * 1e-9)
}

/// CPU time (user + system) of this process so far, s, from `/proc/self/stat`: unlike
/// [`process_cpu_seconds`] it includes threads that have already exited (scoped worker
/// threads), at the kernel's clock-tick resolution (10 ms); `None` where unavailable.
pub fn process_cpu_seconds_with_exited() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    // USER_HZ is 100 on every Linux ABI Rust targets.
    Some((utime + stime) / 100.0)
}

/// `VmRSS` and `VmHWM` of this process in bytes (Linux), if available.
pub fn rss_and_peak() -> Option<(u64, u64)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<u64> {
        let line = status.lines().find(|l| l.starts_with(name))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// Resets the peak-RSS counter (`VmHWM`) to the current RSS (Linux ≥ 4.0); `false` where
/// `/proc/self/clear_refs` cannot be written.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// A deterministic generator for stream `seed`.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// `n` rotation vectors (rad) with uniformly random axes and angles uniform in
/// `[min_angle, max_angle]`.
pub fn rotation_vectors(n: usize, min_angle: f64, max_angle: f64, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = rng(seed);
    (0..n)
        .map(|_| {
            let axis = random_unit(&mut rng);
            axis.into_inner() * rng.random_range(min_angle..=max_angle)
        })
        .collect()
}

/// `n` rotations with angles uniform in `[min_angle, max_angle]` about uniformly random axes.
pub fn rotations(n: usize, min_angle: f64, max_angle: f64, seed: u64) -> Vec<Rotation3<f64>> {
    rotation_vectors(n, min_angle, max_angle, seed)
        .iter()
        .map(|w| Rotation3::new(*w))
        .collect()
}

/// A unit vector uniform on the sphere (rejection sampling in the unit ball).
pub fn random_unit(rng: &mut impl Rng) -> Unit<Vector3<f64>> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n2 = v.norm_squared();
        if n2 > 1e-4 && n2 <= 1.0 {
            return Unit::new_normalize(v);
        }
    }
}

/// A seeded identification problem on a serial chain: N configurations, wrenches and the
/// tip displacements they cause, all row-major flat slices as `vjm::identify` takes them.
#[derive(Debug, Clone)]
pub struct VjmBatch {
    /// Number of measurements N.
    pub n: usize,
    /// Joint positions, N×n row-major (rad), uniform within the chain's joint limits.
    pub q: Vec<f64>,
    /// Wrenches at the tip point, N×6 row-major `[fx, fy, fz, mx, my, mz]` (N, N·m, base frame):
    /// forces uniform in ±50 N, moments uniform in ±5 N·m.
    pub wrench: Vec<f64>,
    /// Tip displacements, N×3 row-major (m, base frame): `A(J, F) c` of the extended model
    /// with [`VjmBatch::compliance`], plus seeded Gaussian noise of [`VjmBatch::NOISE_STD`].
    pub displacement: Vec<f64>,
    /// True compliances of the extended model (rad/(N·m)), joint-major `[z, x, y]`.
    pub compliance: Vec<f64>,
}

impl VjmBatch {
    /// Standard deviation of the displacement noise (m).
    pub const NOISE_STD: f64 = 1e-6;

    /// `n` seeded measurements on `chain` (data from the extended 3n-spring model).
    pub fn generate(chain: &vjm::SerialChain, n: usize, seed: u64) -> Result<Self, vjm::VjmError> {
        let joints = chain.n_joints();
        let model = vjm::VirtualJointModel::extended(joints);
        let m = model.n_params();
        let mut rng = rng(seed);
        let compliance: Vec<f64> = (0..joints)
            .flat_map(|_| [2e-5..2e-4, 2e-6..2e-5, 2e-6..2e-5])
            .map(|range| rng.random_range(range))
            .collect();
        let mut q = Vec::with_capacity(n * joints);
        let mut wrench = Vec::with_capacity(n * 6);
        let mut displacement = Vec::with_capacity(n * 3);
        let mut ws = vjm::Workspace::new(chain, &model)?;
        let mut rows = vec![0.0; 3 * m];
        for _ in 0..n {
            let qi: Vec<f64> = chain
                .limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..=hi))
                .collect();
            let fi: [f64; 6] = std::array::from_fn(|k| {
                let bound = if k < 3 { 50.0 } else { 5.0 };
                rng.random_range(-bound..bound)
            });
            vjm::regressor_rows(
                chain,
                &model,
                &qi,
                &fi,
                vjm::Measured::Translation,
                &mut ws,
                &mut rows,
            )?;
            for r in 0..3 {
                let clean: f64 = rows[r * m..(r + 1) * m]
                    .iter()
                    .zip(&compliance)
                    .map(|(a, c)| a * c)
                    .sum();
                displacement.push(clean + Self::NOISE_STD * rng.sample::<f64, _>(StandardNormal));
            }
            q.extend_from_slice(&qi);
            wrench.extend_from_slice(&fi);
        }
        Ok(Self {
            n,
            q,
            wrench,
            displacement,
            compliance,
        })
    }

    /// The first `n` measurements (the generator is sequential, so a prefix of a large batch
    /// is exactly the batch generated with the same seed and a smaller `n`).
    pub fn prefix(&self, n: usize) -> VjmBatchRef<'_> {
        let n = n.min(self.n);
        let joints = self.q.len() / self.n.max(1);
        VjmBatchRef {
            n,
            q: &self.q[..n * joints],
            wrench: &self.wrench[..n * 6],
            displacement: &self.displacement[..n * 3],
        }
    }
}

/// A borrowed prefix of a [`VjmBatch`].
#[derive(Debug, Clone, Copy)]
pub struct VjmBatchRef<'a> {
    /// Number of measurements N.
    pub n: usize,
    /// N×n joint positions (rad).
    pub q: &'a [f64],
    /// N×6 wrenches (N, N·m).
    pub wrench: &'a [f64],
    /// N×3 displacements (m).
    pub displacement: &'a [f64],
}
