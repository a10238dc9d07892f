//! The static sag of L configurations at once: the weight's torques at the rigid pose, the
//! Jacobian columns, and the exact static equilibrium of the virtual springs under the arm's
//! weight (and a payload) on the deflected chain — what `StiffnessModel::predict_sag` spends
//! its time on, lane-wise.
//!
//! The mathematics is [`DeflectedLoads`](crate::gravity::deflected)'s (the product of
//! exponentials about the springs' rigid axes, see its module docs): a sweep from the tip sums
//! the bodies beyond each spring moved by the springs after it, a sweep from the base turns
//! gravity into each spring's deflected frame. The iteration differs from the scalar code's:
//! plain fixed-point steps `θ ← C τ(θ)` instead of chord steps with an LU of `I − C K_G`.
//! They contract with the ratio ‖C K_G‖ (≈ 1e-3 to 1e-2 for an arm under its weight), which
//! costs a few more sweeps but no stiffness matrix and no factorisation per row; they stop on
//! the scalar code's rule ([`Contraction`], 1e-13 of the largest deflection), so both give the
//! same equilibrium to ~1e-13 of the deflection. Each lane stops on its own and keeps its
//! deflections, so a row's result does not depend on the rows batched with it.
//!
//! A lane is **not solved** (the caller runs the scalar code for that row) when a deflection
//! reaches 0.25 rad (the series below is exact only there), is not finite, or the steps have
//! not settled within [`MAX_STEPS`] (a ratio near 1: springs barely able to hold the arm).
//! The plain steps converge exactly when the equilibrium they reach is stable (‖C T(θ)‖ < 1
//! there); for springs far softer than an arm's (sags of decimetres) they can settle where the
//! chord steps from θ = 0, whose tangent no longer describes the load, overshoot 0.5 rad and
//! report a runaway: such a row then gets its (stable) equilibrium instead of that error.
//! Springs with centre offsets are left to the scalar code by the caller.

use pulp::Simd;

use super::kinematics::{ChainLanes, FramesLanes};
use super::vector::{
    add3, cross3, dot3, rotation_minus_identity, sin_versine, MAX_LANES, SERIES_LIMIT,
};
use super::V;
use crate::contraction::Contraction;

/// Fixed-point steps at most per lane; a lane beyond is not solved.
pub(crate) const MAX_STEPS: usize = 60;

/// The weights and springs of one sag call, flattened (built once per call).
#[derive(Debug, Clone)]
pub(crate) struct SagWeights {
    /// Per actuated joint, its body's mass (kg) and centre of mass (child frame, m).
    pub(crate) bodies: Vec<(f64, [f64; 3])>,
    /// The payload's mass (kg) and centre in the last joint's child frame relative to the tip
    /// point (`R_tip_offset · centre`, m).
    pub(crate) payload: Option<(f64, [f64; 3])>,
    /// Gravity, base frame, m/s².
    pub(crate) gravity: [f64; 3],
    /// Compliance per spring, rad/(N·m) (m/N for a translation); 0 = rigid.
    pub(crate) compliance: Vec<f64>,
}

/// What one batch gives per row `l` (of `count`).
pub(crate) struct SagBatchOut<'a> {
    /// Row-major 6×m regressor of the weight's torques per row, at `l·6m`:
    /// `a[r][k] = J[r][k] · τ_g,k` (the first-order sag is `a · c`).
    pub(crate) regressor: &'a mut [f64],
    /// The sag `[dx, dy, dz, rx, ry, rz]` (m, rad, base frame) of each solved row.
    pub(crate) sag: &'a mut [[f64; 6]],
    /// Whether the row's equilibrium was solved here (else: the scalar code).
    pub(crate) solved: &'a mut [bool],
}

/// Per-call scratch of [`sag_batch`] in the instruction set `S`.
pub(crate) struct SagScratch<S: Simd> {
    frames: FramesLanes<S>,
    q: Vec<V<S>>,
    /// Per joint: its body's centre of mass, base frame.
    body: Vec<[V<S>; 3]>,
    /// Per spring: base-frame axis and centre.
    axis: Vec<[V<S>; 3]>,
    centre: Vec<[V<S>; 3]>,
    /// Per spring: `sin θ`, `1 − cos θ`, the lever of the sweep from the tip, the mass beyond.
    sin: Vec<V<S>>,
    versine: Vec<V<S>>,
    lever: Vec<[V<S>; 3]>,
    carried: Vec<V<S>>,
    tau: Vec<V<S>>,
    theta: Vec<V<S>>,
    /// Per spring, each lane's deflection (a lane that has stopped keeps its own).
    frozen: Vec<[f64; MAX_LANES]>,
    /// The deflecting springs (compliance ≠ 0) and every spring.
    active: Vec<usize>,
    all: Vec<usize>,
}

impl<S: Simd> SagScratch<S> {
    #[inline(always)]
    pub(crate) fn new(s: S, chain: &ChainLanes, weights: &SagWeights) -> Self {
        let (nj, m) = (chain.n_joints(), chain.n_springs());
        let z = V::zero(s);
        Self {
            frames: FramesLanes::new(s, nj),
            q: vec![z; nj],
            body: vec![[z; 3]; nj],
            axis: vec![[z; 3]; m],
            centre: vec![[z; 3]; m],
            sin: vec![z; m],
            versine: vec![z; m],
            lever: vec![[z; 3]; m],
            carried: vec![z; m],
            tau: vec![z; m],
            theta: vec![z; m],
            frozen: vec![[0.0; MAX_LANES]; m],
            active: (0..m).filter(|&k| weights.compliance[k] != 0.0).collect(),
            all: (0..m).collect(),
        }
    }
}

#[inline(always)]
fn sub3<S: Simd>(a: &[V<S>; 3], b: &[V<S>; 3]) -> [V<S>; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn scale3<S: Simd>(a: &[V<S>; 3], x: V<S>) -> [V<S>; 3] {
    [a[0] * x, a[1] * x, a[2] * x]
}

/// `p + R v` for a row-major rotation of lanes and a constant vector.
#[inline(always)]
fn affine<S: Simd>(s: S, r: &[V<S>; 9], v: &[f64; 3], p: &[V<S>; 3]) -> [V<S>; 3] {
    // Written out, no closure: a closure is not inlined into the dispatched function.
    let v = [V::splat(s, v[0]), V::splat(s, v[1]), V::splat(s, v[2])];
    [
        r[2].mul_add(v[2], r[1].mul_add(v[1], r[0].mul_add(v[0], p[0]))),
        r[5].mul_add(v[2], r[4].mul_add(v[1], r[3].mul_add(v[0], p[1]))),
        r[8].mul_add(v[2], r[7].mul_add(v[1], r[6].mul_add(v[0], p[2]))),
    ]
}

/// The torque of the weight on each spring of `list` (indices into the model's springs) at
/// the deflection `scratch.theta` (whose `sin`/`versine` are set when `turned`; at θ = 0 pass
/// `turned = false`), into `scratch.tau[k]`.
#[inline(always)]
fn weight_torques<S: Simd>(
    s: S,
    chain: &ChainLanes,
    weights: &SagWeights,
    payload: Option<(V<S>, [V<S>; 3])>,
    list: &[usize],
    turned: bool,
    sc: &mut SagScratch<S>,
) {
    let z = V::zero(s);
    let (mut moment, mut mass) = ([z; 3], z);
    if let Some((pm, pp)) = payload {
        moment = scale3(&pp, pm);
        mass = pm;
    }
    let mut next_body = weights.bodies.len();
    for &k in list.iter().rev() {
        // The bodies whose last spring is k: joints from k's up to the next spring's.
        while next_body > chain.spring_joint(k) {
            next_body -= 1;
            let bm = V::splat(s, weights.bodies[next_body].0);
            moment = add3(&moment, &scale3(&sc.body[next_body], bm));
            mass = mass + bm;
        }
        sc.carried[k] = mass;
        let a = sc.axis[k];
        if chain.is_translation(k) {
            if turned {
                moment = add3(&moment, &scale3(&a, sc.theta[k] * mass));
            }
            continue;
        }
        let c = sc.centre[k];
        let mut lever = sub3(&moment, &scale3(&c, mass));
        if turned {
            lever = add3(
                &lever,
                &rotation_minus_identity(&a, sc.sin[k], sc.versine[k], &lever),
            );
            moment = add3(&lever, &scale3(&c, mass));
        }
        sc.lever[k] = lever;
    }
    let mut g = [
        V::splat(s, weights.gravity[0]),
        V::splat(s, weights.gravity[1]),
        V::splat(s, weights.gravity[2]),
    ];
    for &k in list {
        let a = sc.axis[k];
        if chain.is_translation(k) {
            sc.tau[k] = sc.carried[k] * dot3(&a, &g);
            continue;
        }
        sc.tau[k] = dot3(&a, &cross3(&sc.lever[k], &g));
        if turned {
            // Rᵀ = I − sin θ [a]× + (1 − cos θ) [a]×².
            g = add3(
                &g,
                &rotation_minus_identity(&a, -sc.sin[k], sc.versine[k], &g),
            );
        }
    }
}

/// The regressor and the sag of the `count` (≤ `V::<S>::LANES`) configurations of `q`
/// (`count` rows of n joint positions, rad, finite) into `out` (see [`SagBatchOut`]).
#[inline(always)]
pub(crate) fn sag_batch<S: Simd>(
    s: S,
    chain: &ChainLanes,
    weights: &SagWeights,
    q: &[f64],
    count: usize,
    sc: &mut SagScratch<S>,
    out: SagBatchOut<'_>,
) {
    let payload = rigid_pose(s, chain, weights, q, count, sc);
    // τ_g at the rigid pose, and the regressor J·diag(τ_g).
    let all = std::mem::take(&mut sc.all);
    weight_torques(s, chain, weights, payload, &all, false, sc);
    sc.all = all;
    write_regressor(s, chain, count, sc, out.regressor);
    let failed = settle(s, chain, weights, payload, count, sc);
    let (moved, quat) = tip_motion(s, chain, &failed, count, sc);
    write_sag(&moved, &quat, &failed, count, out.sag, out.solved);
}

/// The frames of the rigid pose of `q`'s `count` rows, the bodies' centres of mass and the
/// springs' axes and centres (base frame) into `sc`; the payload's mass and centre (base
/// frame) if any.
#[inline(always)]
fn rigid_pose<S: Simd>(
    s: S,
    chain: &ChainLanes,
    weights: &SagWeights,
    q: &[f64],
    count: usize,
    sc: &mut SagScratch<S>,
) -> Option<(V<S>, [V<S>; 3])> {
    let nj = chain.n_joints();
    debug_assert!(count <= V::<S>::LANES && q.len() >= count * nj);
    for j in 0..nj {
        sc.q[j] = super::vector::gather(s, q, nj, j, 0, count);
    }
    chain.evaluate(s, &sc.q, &mut sc.frames);
    for (j, (_, com)) in weights.bodies.iter().enumerate() {
        sc.body[j] = affine(s, &sc.frames.rot[j], com, &sc.frames.centre[j]);
    }
    let payload = match weights.payload {
        Some((pm, v)) => Some((
            V::splat(s, pm),
            affine(s, &sc.frames.rot[nj - 1], &v, &sc.frames.tip),
        )),
        None => None,
    };
    for k in 0..chain.n_springs() {
        sc.axis[k] = chain.spring_axis(s, &sc.frames, k);
        sc.centre[k] = sc.frames.centre[chain.spring_joint(k)];
    }
    payload
}

/// The row-major 6×m regressor `J[r][k] · τ_g,k` of each of the `count` rows (at `l·6m`),
/// from the rigid pose's Jacobian columns and torques in `sc`.
#[inline(always)]
fn write_regressor<S: Simd>(
    s: S,
    chain: &ChainLanes,
    count: usize,
    sc: &SagScratch<S>,
    regressor: &mut [f64],
) {
    let m = chain.n_springs();
    let z = V::zero(s);
    let tip = sc.frames.tip;
    let mut buf = [[0.0; MAX_LANES]; 6];
    for k in 0..m {
        let a = sc.axis[k];
        let t = sc.tau[k];
        let column: [V<S>; 6] = if chain.is_translation(k) {
            [a[0], a[1], a[2], z, z, z]
        } else {
            let u = cross3(&a, &sub3(&tip, &sc.centre[k]));
            [u[0], u[1], u[2], a[0], a[1], a[2]]
        };
        for (r, b) in buf.iter_mut().enumerate() {
            (column[r] * t).store(b);
        }
        for l in 0..count {
            for (r, b) in buf.iter().enumerate() {
                regressor[l * 6 * m + r * m + k] = b[l];
            }
        }
    }
}

/// The fixed point θ = C τ(θ) from θ₁ = C τ_g, lane by lane: each lane's deflections in
/// `sc.frozen` (zero for a lane that failed) and `sc.theta`; whether each lane failed.
#[inline(always)]
fn settle<S: Simd>(
    s: S,
    chain: &ChainLanes,
    weights: &SagWeights,
    payload: Option<(V<S>, [V<S>; 3])>,
    count: usize,
    sc: &mut SagScratch<S>,
) -> [bool; MAX_LANES] {
    let z = V::zero(s);
    let active = std::mem::take(&mut sc.active);
    let mut frozen = std::mem::take(&mut sc.frozen);
    frozen.iter_mut().for_each(|f| f.fill(0.0));
    let mut done = [false; MAX_LANES];
    let mut failed = [false; MAX_LANES];
    done[count..].fill(true);
    let mut steps = [Contraction::new(); MAX_LANES];
    let mut next = [0.0f64; MAX_LANES];
    let mut previous = [0.0f64; MAX_LANES];
    let mut change = [0.0f64; MAX_LANES];
    let mut scale = [1e-300f64; MAX_LANES];
    let mut bad = [false; MAX_LANES];
    // θ₀ = 0: the first step is C τ_g.
    for &k in &active {
        sc.theta[k] = z;
    }
    for step in 1..=MAX_STEPS {
        change.fill(0.0);
        scale.fill(1e-300);
        bad.fill(false);
        for &k in &active {
            let c = V::splat(s, weights.compliance[k]);
            (c * sc.tau[k]).store(&mut next);
            sc.theta[k].store(&mut previous);
            for l in 0..count {
                change[l] = change[l].max((next[l] - previous[l]).abs());
                scale[l] = scale[l].max(next[l].abs());
                bad[l] |= !next[l].is_finite() || next[l].abs() >= SERIES_LIMIT;
            }
            // A lane that has stopped keeps its deflections.
            for l in 0..count {
                if !done[l] {
                    frozen[k][l] = next[l];
                }
            }
            sc.theta[k] = V::load(s, &frozen[k]);
        }
        for l in 0..count {
            if done[l] {
                continue;
            }
            let left = steps[l].remaining(change[l], true);
            let settled = left <= 1e-13 * scale[l] || change[l] < 1e-300;
            if bad[l] || (!settled && step == MAX_STEPS) {
                failed[l] = true;
                done[l] = true;
            } else if settled {
                done[l] = true;
            }
        }
        if done.iter().all(|d| *d) {
            break;
        }
        // A failed lane's deflections may be beyond the series: zero them (its result is
        // discarded) so that no lane computes with them.
        for l in 0..count {
            if failed[l] {
                for &k in &active {
                    frozen[k][l] = 0.0;
                }
            }
        }
        let reload = failed[..count].iter().any(|f| *f);
        for &k in &active {
            if reload {
                sc.theta[k] = V::load(s, &frozen[k]);
            }
            let (sn, vs) = sin_versine(s, sc.theta[k]);
            sc.sin[k] = sn;
            sc.versine[k] = vs;
        }
        weight_torques(s, chain, weights, payload, &active, true, sc);
    }
    sc.active = active;
    sc.frozen = frozen;
    failed
}

/// The tip's motion at each lane's equilibrium: moved by the springs from the tip back
/// (E_1 ∘ ⋯ ∘ E_m (p) − p, base frame, m), and turned by G_m = R_1 ⋯ R_m (a quaternion
/// `[w, x, y, z]`).
#[inline(always)]
fn tip_motion<S: Simd>(
    s: S,
    chain: &ChainLanes,
    failed: &[bool; MAX_LANES],
    count: usize,
    sc: &mut SagScratch<S>,
) -> ([V<S>; 3], [V<S>; 4]) {
    let z = V::zero(s);
    let active = std::mem::take(&mut sc.active);
    let mut frozen = std::mem::take(&mut sc.frozen);
    for &k in &active {
        for l in 0..count {
            if failed[l] {
                frozen[k][l] = 0.0;
            }
        }
        sc.theta[k] = V::load(s, &frozen[k]);
        let (sn, vs) = sin_versine(s, sc.theta[k]);
        sc.sin[k] = sn;
        sc.versine[k] = vs;
    }
    let tip = sc.frames.tip;
    let mut moved = [z; 3];
    for &k in active.iter().rev() {
        let a = sc.axis[k];
        if chain.is_translation(k) {
            moved = add3(&moved, &scale3(&a, sc.theta[k]));
        } else {
            let y = sub3(&add3(&tip, &moved), &sc.centre[k]);
            moved = add3(
                &moved,
                &rotation_minus_identity(&a, sc.sin[k], sc.versine[k], &y),
            );
        }
    }
    // (cos θ/2, sin θ/2 · a) per rotation, multiplied in base-to-tip order.
    let one = V::splat(s, 1.0);
    let mut quat = [one, z, z, z];
    for &k in &active {
        if chain.is_translation(k) {
            continue;
        }
        let (sh, vh) = sin_versine(s, V::splat(s, 0.5) * sc.theta[k]);
        let a = sc.axis[k];
        let r = [one - vh, a[0] * sh, a[1] * sh, a[2] * sh];
        let p = quat;
        quat = [
            p[0] * r[0] - p[1] * r[1] - p[2] * r[2] - p[3] * r[3],
            p[0] * r[1] + p[1] * r[0] + p[2] * r[3] - p[3] * r[2],
            p[0] * r[2] - p[1] * r[3] + p[2] * r[0] + p[3] * r[1],
            p[0] * r[3] + p[1] * r[2] - p[2] * r[1] + p[3] * r[0],
        ];
    }
    sc.active = active;
    sc.frozen = frozen;
    (moved, quat)
}

/// Each solved lane's sag `[dx, dy, dz, rx, ry, rz]` (m, rad, base frame) from its tip
/// motion, and the solved flags of the `count` rows.
#[inline(always)]
fn write_sag<S: Simd>(
    moved: &[V<S>; 3],
    quat: &[V<S>; 4],
    failed: &[bool; MAX_LANES],
    count: usize,
    sag: &mut [[f64; 6]],
    solved: &mut [bool],
) {
    let mut lanes6 = [[0.0; MAX_LANES]; 7];
    for d in 0..3 {
        moved[d].store(&mut lanes6[d]);
    }
    for d in 0..4 {
        quat[d].store(&mut lanes6[3 + d]);
    }
    for l in 0..count {
        solved[l] = !failed[l];
        if failed[l] {
            continue;
        }
        let turn = nalgebra::UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
            lanes6[3][l],
            lanes6[4][l],
            lanes6[5][l],
            lanes6[6][l],
        ))
        .scaled_axis();
        sag[l] = [
            lanes6[0][l],
            lanes6[1][l],
            lanes6[2][l],
            turn.x,
            turn.y,
            turn.z,
        ];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gravity::{gravity_sag, Gravity, GravityWorkspace};
    use crate::stiffness_model::PointMass;
    use crate::{SerialChain, Spring, SpringAxis, VirtualJointModel};
    use pulp::WithSimd;

    /// Every row of `q` in batches of `S`'s lanes: regressors, sags and the solved flags.
    struct Solve<'a> {
        chain: &'a ChainLanes,
        weights: &'a SagWeights,
        q: &'a [f64],
    }
    type Solved = (Vec<f64>, Vec<[f64; 6]>, Vec<bool>);
    impl WithSimd for Solve<'_> {
        type Output = Solved;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Solved {
            let (n, m) = (self.chain.n_joints(), self.chain.n_springs());
            let rows = self.q.len() / n;
            let lanes = V::<S>::LANES;
            let mut sc = SagScratch::new(s, self.chain, self.weights);
            let (mut reg, mut sag, mut ok) = (
                vec![0.0; rows * 6 * m],
                vec![[0.0; 6]; rows],
                vec![false; rows],
            );
            let mut i = 0;
            while i < rows {
                let count = (rows - i).min(lanes);
                sag_batch(
                    s,
                    self.chain,
                    self.weights,
                    &self.q[i * n..(i + count) * n],
                    count,
                    &mut sc,
                    SagBatchOut {
                        regressor: &mut reg[i * 6 * m..(i + count) * 6 * m],
                        sag: &mut sag[i..i + count],
                        solved: &mut ok[i..i + count],
                    },
                );
                i += count;
            }
            (reg, sag, ok)
        }
    }

    fn weights(
        chain: &SerialChain,
        c: &[f64],
        g: &Gravity,
        payload: Option<&PointMass>,
    ) -> SagWeights {
        let v = g.vector();
        SagWeights {
            bodies: chain
                .mass_model()
                .unwrap()
                .bodies()
                .iter()
                .map(|b| (b.mass, [b.com.x, b.com.y, b.com.z]))
                .collect(),
            payload: payload.map(|p| {
                let v = chain.tip_offset().rotation * nalgebra::Vector3::from(p.centre());
                (p.mass(), [v.x, v.y, v.z])
            }),
            gravity: [v.x, v.y, v.z],
            compliance: c.to_vec(),
        }
    }

    /// Each instruction set this machine has (and pulp's scalar type) runs `solve`.
    fn on_every_instruction_set(solve: impl Fn() -> Solve<'static>) -> Vec<(&'static str, Solved)> {
        let mut got = vec![("scalar", solve().with_simd(pulp::Scalar::new()))];
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            if let Some(v3) = pulp::x86::V3::try_new() {
                got.push(("avx2", Simd::vectorize(v3, solve())));
            }
            if let Some(v4) = pulp::x86::V4::try_new() {
                got.push(("avx512", Simd::vectorize(v4, solve())));
            }
        }
        got
    }

    /// The lanes' sag against the scalar chord iterations (`gravity_sag`) and their regressor
    /// against the weight's workspace (τ_g and the Jacobian of the scalar kinematics), on 37
    /// configurations (partial batches everywhere), for torsions, tilts, link translations and
    /// springs on some joints only, with and without a payload, under an oblique gravity.
    #[test]
    fn the_lanes_sag_is_the_scalar_equilibriums() {
        let chain: &'static SerialChain = Box::leak(Box::new(SerialChain::bundled()));
        let payload = PointMass::new(2.5, [0.02, -0.03, 0.12]).unwrap();
        let gravity = Gravity::new([1.2, -0.7, -9.7]).unwrap();
        let rows = 37;
        let q: &'static [f64] = super::super::seeded_configurations(chain, rows, 0x5a6).leak();
        let torsion = crate::model::NOMINAL_TORSION;
        let partial = VirtualJointModel::from_springs(
            7,
            vec![
                Spring::rotation(1, SpringAxis::Z),
                Spring::rotation(3, SpringAxis::X),
                Spring::translation(4, SpringAxis::Y),
            ],
        )
        .unwrap();
        for (name, model) in [
            ("traditional", VirtualJointModel::traditional(7)),
            ("extended", VirtualJointModel::extended(7)),
            ("full", VirtualJointModel::full(7)),
            ("partial", partial),
        ] {
            let m = model.n_params();
            // Torsions at the testbed's nominal values, tilts a fifth, translations 1e-7 m/N,
            // one spring rigid.
            let c: Vec<f64> = model
                .springs()
                .iter()
                .enumerate()
                .map(|(k, s)| match (s.is_translation(), s.axis) {
                    _ if k == 2 => 0.0,
                    (true, _) => 1e-7,
                    (false, SpringAxis::Z) => 3.0 * torsion[s.joint],
                    (false, _) => 0.6 * torsion[s.joint],
                })
                .collect();
            for load in [None, Some(&payload)] {
                let w: &'static SagWeights =
                    Box::leak(Box::new(weights(chain, &c, &gravity, load)));
                let ws = Box::leak(Box::new(
                    crate::kinematics::Workspace::new(chain, &model).unwrap(),
                ));
                let lanes: &'static ChainLanes = ws.lanes();
                let mut g = GravityWorkspace::new(chain, &model, &gravity, load).unwrap();
                let mut jac = vec![0.0; 6 * m];
                for (set, (reg, sag, ok)) in on_every_instruction_set(|| Solve {
                    chain: lanes,
                    weights: w,
                    q,
                }) {
                    for i in 0..rows {
                        let qi = &q[7 * i..7 * i + 7];
                        assert!(ok[i], "{name} {set} row {i}: not solved");
                        let want = gravity_sag(chain, &model, &c, qi, &gravity, load).unwrap();
                        let size = want[..3].iter().map(|v| v * v).sum::<f64>().sqrt();
                        let turn = want[3..].iter().map(|v| v * v).sum::<f64>().sqrt();
                        assert!(size > 1e-5, "{name} row {i}: a sag to compare ({size:e})");
                        for d in 0..3 {
                            assert!(
                                (sag[i][d] - want[d]).abs() <= 1e-12 * size,
                                "{name} {set} row {i}: {:?} vs {want:?}",
                                sag[i]
                            );
                            assert!(
                                (sag[i][3 + d] - want[3 + d]).abs() <= 1e-12 * turn,
                                "{name} {set} row {i}: {:?} vs {want:?}",
                                sag[i]
                            );
                        }
                        g.evaluate(chain, qi).unwrap();
                        g.kinematics().write_jacobian(&mut jac);
                        let tau = g.torques();
                        let scale = tau.iter().fold(0.0f64, |a, t| a.max(t.abs()));
                        for k in 0..m {
                            for r in 0..6 {
                                let e = jac[6 * k + r] * tau[k];
                                let got = reg[i * 6 * m + r * m + k];
                                assert!(
                                    (got - e).abs() <= 1e-12 * scale,
                                    "{name} {set} row {i} spring {k} axis {r}: {got} vs {e}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// Soft springs (40 to 90 times the nominal torsions, tilts and link translations), so
    /// that some rows of a batch are solved and some are left to the scalar code: every row's
    /// `(solved, sag, regressor)` is bit for bit what it is when the row is solved alone, on
    /// every instruction set; a solved row agrees with the chord iterations wherever those
    /// settle (1e-12 of the sag); both kinds of rows occur.
    #[test]
    fn a_row_is_solved_as_if_alone_in_mixed_batches() {
        let chain: &'static SerialChain = Box::leak(Box::new(SerialChain::bundled()));
        let model = VirtualJointModel::full(7);
        let gravity = Gravity::default();
        let rows = 37;
        let q: &'static [f64] = super::super::seeded_configurations(chain, rows, 0x50f7).leak();
        let torsion = crate::model::NOMINAL_TORSION;
        let ws = Box::leak(Box::new(
            crate::kinematics::Workspace::new(chain, &model).unwrap(),
        ));
        let lanes: &'static ChainLanes = ws.lanes();
        let (mut solved, mut left, mut compared) = (0, 0, 0);
        for factor in [40.0, 60.0, 90.0] {
            let c: Vec<f64> = model
                .springs()
                .iter()
                .map(|s| match (s.is_translation(), s.axis) {
                    (true, _) => 2e-7 * factor,
                    (false, SpringAxis::Z) => factor * torsion[s.joint],
                    (false, _) => 0.3 * factor * torsion[s.joint],
                })
                .collect();
            let w: &'static SagWeights = Box::leak(Box::new(weights(chain, &c, &gravity, None)));
            let batched = on_every_instruction_set(|| Solve {
                chain: lanes,
                weights: w,
                q,
            });
            for (set, (reg, sag, ok)) in &batched {
                let m = model.n_params();
                for i in 0..rows {
                    let one: &'static [f64] = q[7 * i..7 * i + 7].to_vec().leak();
                    let alone = on_every_instruction_set(|| Solve {
                        chain: lanes,
                        weights: w,
                        q: one,
                    });
                    let (_, (reg1, sag1, ok1)) = alone.iter().find(|(s, _)| s == set).unwrap();
                    assert_eq!(ok[i], ok1[0], "{set} ×{factor} row {i}");
                    assert_eq!(
                        reg[i * 6 * m..(i + 1) * 6 * m]
                            .iter()
                            .map(|v| v.to_bits())
                            .collect::<Vec<_>>(),
                        reg1.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                        "{set} ×{factor} row {i}"
                    );
                    if !ok[i] {
                        left += 1;
                        continue;
                    }
                    solved += 1;
                    assert_eq!(
                        sag[i].map(f64::to_bits),
                        sag1[0].map(f64::to_bits),
                        "{set} row {i}"
                    );
                    if let Ok(want) =
                        gravity_sag(chain, &model, &c, &q[7 * i..7 * i + 7], &gravity, None)
                    {
                        compared += 1;
                        let size = want[..3].iter().map(|v| v * v).sum::<f64>().sqrt();
                        for d in 0..3 {
                            assert!(
                                (sag[i][d] - want[d]).abs() <= 1e-12 * size,
                                "{set} ×{factor} row {i}: {:?} vs {want:?}",
                                sag[i]
                            );
                        }
                    }
                }
            }
        }
        assert!(
            solved > 0 && left > 0 && compared > 0,
            "{solved} solved, {left} left, {compared} compared"
        );
    }

    /// Springs too soft for the series (deflections beyond 0.25 rad) leave their rows to the
    /// scalar code, and only theirs: a rigid row in the same batch is solved (sag exactly 0
    /// for a rigid model).
    #[test]
    fn rows_beyond_the_series_are_left_to_the_scalar_code() {
        let chain: &'static SerialChain = Box::leak(Box::new(SerialChain::bundled()));
        let model = VirtualJointModel::traditional(7);
        let q: &'static [f64] = super::super::seeded_configurations(chain, 5, 7).leak();
        let gravity = Gravity::default();
        let ws = Box::leak(Box::new(
            crate::kinematics::Workspace::new(chain, &model).unwrap(),
        ));
        let lanes: &'static ChainLanes = ws.lanes();
        let soft: &'static SagWeights =
            Box::leak(Box::new(weights(chain, &[0.05; 7], &gravity, None)));
        for (set, (_, _, ok)) in on_every_instruction_set(|| Solve {
            chain: lanes,
            weights: soft,
            q,
        }) {
            assert!(ok.iter().all(|o| !o), "{set}: {ok:?}");
        }
        let rigid: &'static SagWeights =
            Box::leak(Box::new(weights(chain, &[0.0; 7], &gravity, None)));
        for (set, (_, sag, ok)) in on_every_instruction_set(|| Solve {
            chain: lanes,
            weights: rigid,
            q,
        }) {
            assert!(ok.iter().all(|o| *o), "{set}");
            assert!(sag.iter().all(|s| *s == [0.0; 6]), "{set}: {sag:?}");
        }
    }
}
