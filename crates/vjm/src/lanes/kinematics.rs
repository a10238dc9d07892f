//! Forward kinematics of a chain with its virtual springs, over L configurations at once:
//! per joint the base-frame rotation and spring centre, and the tip point.

use pulp::Simd;

use super::vector::dot3;
use super::{sin_cos, V};
use crate::chain::SerialChain;
use crate::model::{basis_index, local_spring_axis, VirtualJointModel};

/// A spring's axis in its joint's child frame: a basis vector (the common case, a URDF
/// joint axis along x, y or z) needs no product to be taken to the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
enum LocalAxis {
    Basis(usize),
    General([f64; 3]),
}

/// The chain and model flattened for lane-wise evaluation (built once per batch call).
#[derive(Debug, Clone)]
pub(crate) struct ChainLanes {
    /// Per joint: `b0, b1, b2` row-major (Rodrigues terms premultiplied by the origin
    /// rotation, see `ActuatedJoint::b0`) and the origin translation.
    b: Vec<[[f64; 9]; 3]>,
    t: Vec<[f64; 3]>,
    tip: [f64; 3],
    /// Per joint: spring-centre offset in the child frame, when any is non-zero.
    offsets: Option<Vec<[f64; 3]>>,
    spring_joint: Vec<usize>,
    spring_axis: Vec<LocalAxis>,
    /// Per spring: true for a translation (column `[w; 0]`).
    translation: Vec<bool>,
}

/// The result of [`ChainLanes::evaluate`]: base-frame quantities, lane by lane.
#[derive(Clone)]
pub(crate) struct FramesLanes<S: Simd> {
    /// Per joint: child-frame rotation, row-major.
    pub(crate) rot: Vec<[V<S>; 9]>,
    /// Per joint: spring centre (the joint origin plus any offset), m.
    pub(crate) centre: Vec<[V<S>; 3]>,
    /// Tip point, m.
    pub(crate) tip: [V<S>; 3],
}

impl<S: Simd> FramesLanes<S> {
    #[inline(always)]
    pub(crate) fn new(s: S, n_joints: usize) -> Self {
        Self {
            rot: vec![[V::zero(s); 9]; n_joints],
            centre: vec![[V::zero(s); 3]; n_joints],
            tip: [V::zero(s); 3],
        }
    }
}

fn row_major(m: &nalgebra::Matrix3<f64>) -> [f64; 9] {
    std::array::from_fn(|e| m[(e / 3, e % 3)])
}

impl ChainLanes {
    /// Flattens `chain` and `model` (the caller has checked that they match).
    pub(crate) fn new(chain: &SerialChain, model: &VirtualJointModel) -> Self {
        let joints = chain.joints();
        let offsets = model.offsets();
        let any_offset = offsets.iter().any(|o| *o != nalgebra::Vector3::zeros());
        let spring_axis = model
            .springs()
            .iter()
            .map(|s| {
                let a = local_spring_axis(chain, s);
                match basis_index(&a) {
                    Some(i) => LocalAxis::Basis(i),
                    None => LocalAxis::General([a.x, a.y, a.z]),
                }
            })
            .collect();
        Self {
            b: joints
                .iter()
                .map(|j| [row_major(&j.b0), row_major(&j.b1), row_major(&j.b2)])
                .collect(),
            t: joints.iter().map(|j| [j.t.x, j.t.y, j.t.z]).collect(),
            tip: {
                let v = chain.tip_offset().translation.vector;
                [v.x, v.y, v.z]
            },
            offsets: any_offset.then(|| offsets.iter().map(|o| [o.x, o.y, o.z]).collect()),
            spring_joint: model.springs().iter().map(|s| s.joint).collect(),
            spring_axis,
            translation: model.springs().iter().map(|s| s.is_translation()).collect(),
        }
    }

    pub(crate) fn n_joints(&self) -> usize {
        self.t.len()
    }

    /// True when some spring's centre is offset from its joint's origin.
    pub(crate) fn has_offsets(&self) -> bool {
        self.offsets.is_some()
    }

    pub(crate) fn n_springs(&self) -> usize {
        self.spring_joint.len()
    }

    /// The joint of spring `k`.
    #[inline(always)]
    pub(crate) fn spring_joint(&self, k: usize) -> usize {
        self.spring_joint[k]
    }

    /// True when spring `k` is a translation.
    #[inline(always)]
    pub(crate) fn is_translation(&self, k: usize) -> bool {
        self.translation[k]
    }

    /// Evaluates the frames at `q[j]` (joint j's angle in every lane, rad).
    #[inline(always)]
    pub(crate) fn evaluate<S: Simd>(&self, s: S, q: &[V<S>], out: &mut FramesLanes<S>) {
        let mut r = [V::zero(s); 9];
        for e in [0, 4, 8] {
            r[e] = V::splat(s, 1.0);
        }
        let mut t = [V::zero(s); 3];
        for (j, (b, tj)) in self.b.iter().zip(&self.t).enumerate() {
            let (sn, cs) = sin_cos(s, q[j]);
            let omc = V::splat(s, 1.0) - cs;
            let mut local = [V::zero(s); 9];
            for e in 0..9 {
                local[e] = V::splat(s, b[2][e])
                    .mul_add(omc, V::splat(s, b[1][e]).mul_add(sn, V::splat(s, b[0][e])));
            }
            // t += R·t_j with the parent rotation, then R ← R·local (for the first joint R
            // is the identity: no product).
            if j == 0 {
                for a in 0..3 {
                    t[a] = V::splat(s, tj[a]);
                }
                r = local;
            } else {
                affine(s, &r, tj, &mut t);
                let prev = r;
                for a in 0..3 {
                    for col in 0..3 {
                        r[3 * a + col] = prev[3 * a + 2].mul_add(
                            local[6 + col],
                            prev[3 * a + 1].mul_add(local[3 + col], prev[3 * a] * local[col]),
                        );
                    }
                }
            }
            out.rot[j] = r;
            out.centre[j] = t;
        }
        out.tip = t;
        affine(s, &r, &self.tip, &mut out.tip);
        if let Some(offsets) = &self.offsets {
            for (j, d) in offsets.iter().enumerate() {
                let rj = out.rot[j];
                affine(s, &rj, d, &mut out.centre[j]);
            }
        }
    }

    /// Base-frame axis w_k of spring `k` after [`evaluate`](Self::evaluate).
    #[inline(always)]
    pub(crate) fn spring_axis<S: Simd>(
        &self,
        s: S,
        frames: &FramesLanes<S>,
        k: usize,
    ) -> [V<S>; 3] {
        let r = &frames.rot[self.spring_joint[k]];
        match self.spring_axis[k] {
            LocalAxis::Basis(i) => [r[i], r[3 + i], r[6 + i]],
            LocalAxis::General(a) => {
                let a = [V::splat(s, a[0]), V::splat(s, a[1]), V::splat(s, a[2])];
                [
                    dot3(&[r[0], r[1], r[2]], &a),
                    dot3(&[r[3], r[4], r[5]], &a),
                    dot3(&[r[6], r[7], r[8]], &a),
                ]
            }
        }
    }
}

/// `p ← p + R·v` for a row-major rotation of lanes and a constant vector (a plain function,
/// not a closure, so that it is always inlined into the dispatched code).
#[inline(always)]
fn affine<S: Simd>(s: S, r: &[V<S>; 9], v: &[f64; 3], p: &mut [V<S>; 3]) {
    for a in 0..3 {
        p[a] = r[3 * a + 2].mul_add(
            V::splat(s, v[2]),
            r[3 * a + 1].mul_add(V::splat(s, v[1]), r[3 * a].mul_add(V::splat(s, v[0]), p[a])),
        );
    }
}
