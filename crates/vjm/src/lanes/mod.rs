//! Structure-of-arrays kinematics over `L` configurations at once.
//!
//! The batch paths (the streaming identification and [`jacobian_batch_in_place`]) evaluate
//! many independent configurations of one chain. Written per configuration, a 7-joint
//! Jacobian is a chain of small dependent 3×3 products that keeps one SIMD lane busy; written
//! across configurations, every operation is the same for all lanes, so `L` configurations
//! (8 or 16 with AVX2 or AVX-512, two vectors per step) go through the instructions one would
//! take. The code here is plain lane-wise
//! Rust over [`V`]: [`pulp`] (faer's SIMD layer, already a dependency through faer) runs it inside a
//! function compiled for the best instruction set the CPU reports (x86-64-v4: AVX-512,
//! or v3: AVX2 + FMA), through pulp's vector types; the same code with pulp's scalar type (1 lane) is
//! the portable fallback, so nothing depends on an unchecked CPU feature.
//!
//! Every function on the hot path is `#[inline(always)]`: a callee that is not inlined into
//! the dispatched function is compiled without the features (still correct, but scalar, and
//! `mul_add` would become a library call). Plain lane-wise arrays left to the auto-vectoriser
//! were tried first and measured ~10× slower: LLVM kept most of it scalar.
//!
//! [`jacobian_batch_in_place`]: crate::jacobian_batch_in_place

pub(crate) mod equilibrium;
pub(crate) mod gram;
pub(crate) mod kinematics;
pub(crate) mod sag;
mod vector;

pub(crate) use vector::{gather, sin_cos, sin_cos_slice, MAX_LANES, V};

/// Seeded configurations within `chain`'s limits, row-major (`rows` × n; the tests' own
/// generator, so that the lanes' tests need no testbed).
#[cfg(test)]
pub(crate) fn seeded_configurations(
    chain: &crate::SerialChain,
    rows: usize,
    mut state: u64,
) -> Vec<f64> {
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut q = Vec::new();
    for _ in 0..rows {
        for &(lo, hi) in chain.limits() {
            q.push(lo + (hi - lo) * uniform());
        }
    }
    q
}
