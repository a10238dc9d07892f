//! Forward kinematics with virtual joints, the 6×m virtual-joint Jacobian and the
//! complementary stiffness K_C.
//!
//! Every rotational virtual spring k is a revolute joint about the unit axis w_k through the
//! point c_k (its joint's spring centre), both in base-frame components. At the undeflected
//! state its Jacobian column at the tip point p is `[w_k × (p − c_k); w_k]`. A translational
//! spring (the full model's link springs) is a prismatic joint along w_k: its column is
//! `[w_k; 0]` ([`column`]).

use nalgebra::{DMatrix, Isometry3, Matrix3, Point3, Translation3, Vector3};

use crate::chain::{check_finite, rotation_about, SerialChain};
use crate::error::VjmError;
use crate::lanes::kinematics::ChainLanes;
use crate::model::{basis_index, local_spring_axis, spring_axes, VirtualJointModel};

/// Reusable scratch for batched kinematics (Data in pinocchio's Model/Data split).
///
/// Create one per thread with [`Workspace::new`] and pass it to the `_in_place` functions;
/// they then allocate nothing per configuration.
#[derive(Debug, Clone)]
pub struct Workspace {
    n_joints: usize,
    /// Spring axes in their joint's child frame.
    local_axes: Vec<Vector3<f64>>,
    /// Per spring: `Some(i)` when its local axis is the basis vector e_i (then the base-frame
    /// axis is column i of the joint rotation, no product needed).
    basis_axis: Vec<Option<usize>>,
    /// Scratch: sin and cos of each joint angle.
    sc: Vec<(f64, f64)>,
    /// The instruction set found when the workspace was made (detected once, not per call).
    arch: pulp::Arch,
    /// The chain and model flattened for the lane-wise batch path (built once, here).
    lanes: ChainLanes,
    /// Per spring: its actuated joint.
    pub(crate) spring_joint: Vec<usize>,
    /// Per spring: true for a translation (column `[w_k; 0]`).
    pub(crate) translation: Vec<bool>,
    offsets: Vec<Vector3<f64>>,
    any_offset: bool,
    /// A copy of the model's springs and offsets, to reject a workspace built for another model.
    model: VirtualJointModel,
    /// Per actuated joint, its child frame at the last evaluation: rotation (base ← child) and
    /// origin (base frame, m).
    rot: Vec<Matrix3<f64>>,
    pos: Vec<Vector3<f64>>,
    /// Per actuated joint, its springs' centre (base frame, m): `pos` unless offset.
    centre: Vec<Vector3<f64>>,
    /// Base-frame spring axes w_k and centres c_k of the last evaluation.
    pub(crate) w: Vec<Vector3<f64>>,
    pub(crate) c: Vec<Vector3<f64>>,
    /// Tip point of the last evaluation.
    pub(crate) p: Vector3<f64>,
    /// 6×m column-major Jacobian scratch used by the regressor.
    pub(crate) jac: Vec<f64>,
}

impl Workspace {
    /// Scratch for `model` on `chain`.
    pub fn new(chain: &SerialChain, model: &VirtualJointModel) -> Result<Self, VjmError> {
        model.check_chain(chain)?;
        let m = model.n_params();
        let n = chain.n_joints();
        let local_axes: Vec<Vector3<f64>> = model
            .springs()
            .iter()
            .map(|s| local_spring_axis(chain, s))
            .collect();
        let basis_axis = local_axes.iter().map(basis_index).collect();
        Ok(Self {
            lanes: ChainLanes::new(chain, model),
            n_joints: n,
            basis_axis,
            sc: vec![(0.0, 1.0); n],
            arch: pulp::Arch::new(),
            local_axes,
            spring_joint: model.springs().iter().map(|s| s.joint).collect(),
            translation: model.springs().iter().map(|s| s.is_translation()).collect(),
            offsets: model.offsets().to_vec(),
            any_offset: model.offsets().iter().any(|o| *o != Vector3::zeros()),
            model: model.clone(),
            rot: vec![Matrix3::identity(); n],
            pos: vec![Vector3::zeros(); n],
            centre: vec![Vector3::zeros(); n],
            w: vec![Vector3::zeros(); m],
            c: vec![Vector3::zeros(); m],
            p: Vector3::zeros(),
            jac: vec![0.0; 6 * m],
        })
    }

    /// Number of parameters m this workspace was built for.
    pub fn n_params(&self) -> usize {
        self.local_axes.len()
    }

    fn check(&self, chain: &SerialChain, model: &VirtualJointModel) -> Result<(), VjmError> {
        // Field by field, cheapest first; the model's name does not matter here.
        if self.n_joints != chain.n_joints()
            || self.model.springs() != model.springs()
            || self.model.offsets() != model.offsets()
        {
            return Err(VjmError::InvalidModel {
                message: "the workspace was built for another chain or model; create it with Workspace::new(chain, model)".into(),
            });
        }
        Ok(())
    }

    /// [`evaluate`](Self::evaluate) and the 6×m Jacobian there into `self.jac` (no checks).
    pub(crate) fn evaluate_jacobian(&mut self, chain: &SerialChain, q: &[f64]) {
        self.evaluate(chain, q);
        let mut jac = std::mem::take(&mut self.jac);
        self.write_jacobian(&mut jac);
        self.jac = jac;
    }

    /// Evaluates joint frames, spring axes/centres and the tip point at `q` (no checks).
    #[inline]
    pub(crate) fn evaluate(&mut self, chain: &SerialChain, q: &[f64]) {
        // All sines and cosines first: they are independent, so their polynomial chains
        // overlap instead of waiting on each joint's 3×3 product.
        crate::lanes::sin_cos_slice(self.arch, q, &mut self.sc);
        let mut r = Matrix3::identity();
        let mut t = Vector3::zeros();
        for (j, joint) in chain.joints().iter().enumerate() {
            let (s, c) = self.sc[j];
            // Rodrigues, premultiplied by the fixed origin rotation (see ActuatedJoint::b0).
            let local = joint.b0 + joint.b1 * s + joint.b2 * (1.0 - c);
            t += r * joint.t;
            r *= local;
            self.rot[j] = r;
            self.pos[j] = t;
        }
        let tip = chain.tip_offset().translation.vector;
        self.p = t + r * tip;
        // Spring centres: once per joint, and no product at all for the usual zero offsets.
        let centre = if self.any_offset {
            for j in 0..self.n_joints {
                self.centre[j] = self.pos[j] + self.rot[j] * self.offsets[j];
            }
            &self.centre
        } else {
            &self.pos
        };
        for k in 0..self.local_axes.len() {
            let j = self.spring_joint[k];
            self.w[k] = match self.basis_axis[k] {
                Some(i) => self.rot[j].column(i).into_owned(),
                None => self.rot[j] * self.local_axes[k],
            };
            self.c[k] = centre[j];
        }
    }

    /// Actuated joint `j`'s child frame at the last evaluation: rotation (base ← child) and
    /// origin (base frame, m).
    #[inline]
    pub(crate) fn joint_frame(&self, j: usize) -> (&Matrix3<f64>, &Vector3<f64>) {
        (&self.rot[j], &self.pos[j])
    }

    /// The chain and model flattened for the lane-wise batch path.
    #[inline]
    pub(crate) fn lanes(&self) -> &ChainLanes {
        &self.lanes
    }

    /// Rotation (base ← tip) of the tip frame at the last evaluation.
    #[inline]
    pub(crate) fn tip_rotation(&self, chain: &SerialChain) -> Matrix3<f64> {
        self.rot[self.n_joints - 1] * chain.tip_offset().rotation.to_rotation_matrix().matrix()
    }

    /// Writes the 6×m Jacobian of the last evaluation into `out`, column-major.
    #[inline]
    pub(crate) fn write_jacobian(&self, out: &mut [f64]) {
        for (k, col) in out.chunks_exact_mut(6).enumerate() {
            let w = self.w[k];
            if self.translation[k] {
                col[..3].copy_from_slice(w.as_slice());
                col[3..].fill(0.0);
                continue;
            }
            let lin = w.cross(&(self.p - self.c[k]));
            col[0] = lin.x;
            col[1] = lin.y;
            col[2] = lin.z;
            col[3] = w.x;
            col[4] = w.y;
            col[5] = w.z;
        }
    }
}

/// Checks a wrench `[fx, fy, fz, mx, my, mz]` for finite values.
pub(crate) fn check_wrench(wrench: &[f64; 6], row: usize) -> Result<(), VjmError> {
    check_finite("wrench", wrench, row, 0)
}

/// The 6×m virtual-joint Jacobian at joint positions `q` (rad): rows `[linear; angular]`,
/// base-frame components, linear part at the tip point; column k belongs to spring k.
///
/// ```
/// use vjm::{jacobian, SerialChain, VirtualJointModel};
/// let panda = SerialChain::bundled();
/// let j = jacobian(&panda, &VirtualJointModel::extended(7), &[0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8]).unwrap();
/// assert_eq!(j.shape(), (6, 21));
/// ```
pub fn jacobian(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
) -> Result<DMatrix<f64>, VjmError> {
    let mut ws = Workspace::new(chain, model)?;
    let mut out = vec![0.0; 6 * model.n_params()];
    jacobian_in_place(chain, model, q, &mut ws, &mut out)?;
    Ok(DMatrix::from_column_slice(6, model.n_params(), &out))
}

/// [`jacobian`] into a caller-owned buffer: `out` has 6·m entries, **column-major**
/// (`out[6*k + r]` is row r of column k, as nalgebra stores a 6×m matrix). No allocation.
pub fn jacobian_in_place(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    ws: &mut Workspace,
    out: &mut [f64],
) -> Result<(), VjmError> {
    ws.check(chain, model)?;
    chain.check_q(q, 0)?;
    if out.len() != 6 * model.n_params() {
        return Err(VjmError::ShapeMismatch {
            what: "Jacobian output buffer (6·m)",
            expected: 6 * model.n_params(),
            got: out.len(),
        });
    }
    ws.evaluate(chain, q);
    ws.write_jacobian(out);
    Ok(())
}

/// How each configuration's 6×m Jacobian is laid out in a batched output buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum JacobianLayout {
    /// `out[i·6m + 6k + r]`: column-major blocks, as nalgebra stores a 6×m matrix.
    ColumnMajor,
    /// `out[i·6m + r·m + k]`: row-major blocks, i.e. a C-ordered (N, 6, m) array (numpy's
    /// layout, so the Python bindings write straight into the array they return).
    RowMajor,
}

/// Jacobians of N configurations: `q` is N×n row-major, `out` is N blocks of 6·m
/// column-major Jacobians. One workspace, no allocation per configuration.
pub fn jacobian_batch_in_place(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    ws: &mut Workspace,
    out: &mut [f64],
) -> Result<(), VjmError> {
    jacobian_batch_with_layout(chain, model, q, ws, out, JacobianLayout::ColumnMajor)
}

/// [`jacobian_batch_in_place`] with the blocks of `out` laid out as `layout` says.
pub fn jacobian_batch_with_layout(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    ws: &mut Workspace,
    out: &mut [f64],
    layout: JacobianLayout,
) -> Result<(), VjmError> {
    ws.check(chain, model)?;
    let n = chain.n_joints();
    let m6 = 6 * model.n_params();
    if !q.len().is_multiple_of(n) {
        return Err(VjmError::ShapeMismatch {
            what: "q (N×n row-major)",
            expected: q.len().div_ceil(n) * n,
            got: q.len(),
        });
    }
    let rows = q.len() / n;
    if out.len() != rows * m6 {
        return Err(VjmError::ShapeMismatch {
            what: "batched Jacobian output (N·6·m)",
            expected: rows * m6,
            got: out.len(),
        });
    }
    for (i, qi) in q.chunks_exact(n).enumerate() {
        check_finite("q", qi, i, 0)?;
    }
    // Lane-wise over configurations (see `crate::lanes`), on the workspace's flattened chain.
    crate::lanes::gram::jacobian_batch(&ws.lanes, q, out, layout);
    Ok(())
}

/// The tip pose with the virtual joints deflected by `theta` (rad, one per spring):
/// at each joint, after its actuated rotation, the springs' rotations are composed in
/// model order about their axes through the spring centre. An independent, slow,
/// allocation-based code path, used to check [`jacobian`] and for nonlinear equilibria.
pub fn forward_kinematics_deflected(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
) -> Result<Isometry3<f64>, VjmError> {
    Ok(deflected_state(chain, model, q, theta)?.tip)
}

/// The 6×m virtual-joint Jacobian at the deflected state `theta` (see
/// [`forward_kinematics_deflected`]); at `theta = 0` it equals [`jacobian`].
pub fn jacobian_deflected(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
) -> Result<DMatrix<f64>, VjmError> {
    let state = deflected_state(chain, model, q, theta)?;
    let (frames, p) = (state.springs, state.tip.translation.vector);
    let mut jac = DMatrix::zeros(6, model.n_params());
    for (k, ((w, c), s)) in frames.iter().zip(model.springs()).enumerate() {
        let (lin, ang) = column(w, c, &p, s.is_translation());
        jac.fixed_view_mut::<3, 1>(0, k).copy_from(&lin);
        jac.fixed_view_mut::<3, 1>(3, k).copy_from(&ang);
    }
    Ok(jac)
}

/// The Jacobian column `[linear; angular]` at the tip point `p` of a spring with base-frame
/// axis `w` through the centre `c`: `[w × (p − c); w]` for a rotation, `[w; 0]` for a
/// translation.
pub(crate) fn column(
    w: &Vector3<f64>,
    c: &Vector3<f64>,
    p: &Vector3<f64>,
    translation: bool,
) -> (Vector3<f64>, Vector3<f64>) {
    if translation {
        (*w, Vector3::zeros())
    } else {
        (w.cross(&(p - c)), *w)
    }
}

/// The deflected chain: per spring its base-frame axis and centre (the column of a translation
/// is `[w; 0]`, see [`column`]), per actuated joint its
/// child frame after its springs' rotations (the frame its body moves with), and the tip pose.
#[derive(Debug)]
pub(crate) struct DeflectedState {
    pub(crate) springs: Vec<(Vector3<f64>, Vector3<f64>)>,
    pub(crate) joint_frames: Vec<Isometry3<f64>>,
    pub(crate) tip: Isometry3<f64>,
}

/// The deflected chain at `q` and `theta` (see [`forward_kinematics_deflected`]).
pub(crate) fn deflected_state(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
) -> Result<DeflectedState, VjmError> {
    model.check_chain(chain)?;
    chain.check_q(q, 0)?;
    if theta.len() != model.n_params() {
        return Err(VjmError::ShapeMismatch {
            what: "theta (virtual joint deflections)",
            expected: model.n_params(),
            got: theta.len(),
        });
    }
    check_finite("theta", theta, 0, 0)?;
    let mut t = Isometry3::identity();
    let mut springs = Vec::with_capacity(model.n_params());
    let mut joint_frames = Vec::with_capacity(chain.n_joints());
    for (j, joint) in chain.joints().iter().enumerate() {
        t = t * joint.origin() * rotation_about(joint.axis(), q[j]);
        let axes = spring_axes(joint.axis());
        let d = model.offsets()[j];
        for (k, s) in model.springs().iter().enumerate() {
            if s.joint != j {
                continue;
            }
            let local = axes[s.axis.index()];
            let w = t.rotation * local;
            let c = (t * Point3::from(d)).coords;
            springs.push((w, c));
            if s.is_translation() {
                t *= Translation3::from(local * theta[k]);
                continue;
            }
            let shift = Isometry3::from_parts(Translation3::from(d), Default::default());
            t = t * shift * rotation_about(&local, theta[k]) * shift.inverse();
        }
        joint_frames.push(t);
    }
    Ok(DeflectedState {
        springs,
        joint_frames,
        tip: t * chain.tip_offset(),
    })
}

/// The complementary stiffness K_C = (∂Jᵀ/∂θ)F (seed eq. 4), m×m, N·m/rad:
/// `K_C[(k, i)] = ∂(J_kᵀ F)/∂θ_i` at the undeflected state, for the wrench
/// `[fx, fy, fz, mx, my, mz]` (N, N·m, base frame) applied at the tip point.
///
/// Analytic: for rotational springs i before k in the chain, ∂w_k/∂θ_i = w_i × w_k and
/// ∂(p − c_k)/∂θ_i = w_i × (p − c_k); for i at or after k only the tip point moves,
/// ∂p/∂θ_i = w_i × (p − c_i). A translational spring i moves the tip by ∂p/∂θ_i = w_i and
/// everything after it alike (no term for the k after it); a translational k has
/// `J_kᵀF = w_k·f`, changed only by the rotations before it.
pub fn complementary_stiffness(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrench: &[f64; 6],
) -> Result<DMatrix<f64>, VjmError> {
    let mut ws = Workspace::new(chain, model)?;
    let m = model.n_params();
    let mut out = vec![0.0; m * m];
    complementary_stiffness_in_place(chain, model, q, wrench, &mut ws, &mut out)?;
    Ok(DMatrix::from_column_slice(m, m, &out))
}

/// [`complementary_stiffness`] into `out` (m·m entries, column-major). No allocation.
pub fn complementary_stiffness_in_place(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrench: &[f64; 6],
    ws: &mut Workspace,
    out: &mut [f64],
) -> Result<(), VjmError> {
    ws.check(chain, model)?;
    chain.check_q(q, 0)?;
    check_wrench(wrench, 0)?;
    let m = model.n_params();
    if out.len() != m * m {
        return Err(VjmError::ShapeMismatch {
            what: "K_C output buffer (m·m)",
            expected: m * m,
            got: out.len(),
        });
    }
    ws.evaluate(chain, q);
    complementary_stiffness_at(ws, wrench, out);
    Ok(())
}

/// [`complementary_stiffness_in_place`] at the pose `ws` was last evaluated at (no checks).
pub(crate) fn complementary_stiffness_at(ws: &Workspace, wrench: &[f64; 6], out: &mut [f64]) {
    let m = ws.n_params();
    let f = Vector3::new(wrench[0], wrench[1], wrench[2]);
    let mo = Vector3::new(wrench[3], wrench[4], wrench[5]);
    let tr = &ws.translation;
    for i in 0..m {
        let wi = ws.w[i];
        // Tip motion when θ_i moves; used for every k ≤ i.
        let dp = column(&wi, &ws.c[i], &ws.p, tr[i]).0;
        for k in 0..m {
            let wk = ws.w[k];
            let value = match (i < k, tr[i], tr[k]) {
                // A translation before k moves k's centre and the tip alike.
                (true, true, _) => 0.0,
                (true, false, true) => wi.cross(&wk).dot(&f),
                (true, false, false) => {
                    let r = ws.p - ws.c[k];
                    let dw = wi.cross(&wk);
                    let dlin = dw.cross(&r) + wk.cross(&wi.cross(&r));
                    dlin.dot(&f) + dw.dot(&mo)
                }
                // A translation's generalised force w_k·f does not see the tip move.
                (false, _, true) => 0.0,
                (false, _, false) => wk.cross(&dp).dot(&f),
            };
            out[i * m + k] = value;
        }
    }
}

/// Moves a chain's kinematics at joint positions q — its 6×m virtual-joint Jacobian `jac`
/// (column-major, springs at the joint origins in model order), tip point and tip rotation —
/// to the deflected state `theta` (rad, one per column), exactly: the deflected frame of spring k
/// is `E_1 ⋯ E_{k−1} N_k` with `E_k` the rotation by θ_k about spring k's undeflected axis
/// `a_k` through its centre (the composition of [`RowBuilder::exact_displacement`]), so its
/// column is `[G_k (a_k × (v_k − c_k)); G_k a_k]` with `G_k = R_1 ⋯ R_{k−1}` (R_k the rotation of E_k) and
/// `v_k = E_k(⋯E_K(p))`, and the tip moves to `E_1(⋯E_K(p))`. A translational column `[w_k; 0]`
/// (zero angular part) is the shift E_k(y) = y + θ_k w_k: its column becomes `[G_k w_k; 0]`. Both sweeps are O(3n); the
/// result equals `vjm::kinematics::jacobian_deflected` to rounding
/// (`tests/it/diagnose.rs`, `a_row_deflected_in_place_equals_the_deflected_chain`). The
/// sag of an arm under its weight moves a measurement's reference there.
pub(crate) fn deflect_in_place(
    jac: &mut [f64],
    tip: &mut Vector3<f64>,
    tip_rotation: &mut Matrix3<f64>,
    theta: &[f64],
) {
    if theta.iter().all(|t| *t == 0.0) {
        return;
    }
    let m = theta.len();
    assert_eq!(jac.len(), 6 * m, "a 6×m Jacobian for m deflections");
    // Sweep from the tip: v_k − c_k across a_k, and the tip's displacement.
    let mut after = vec![Vector3::zeros(); m];
    let mut d = Vector3::zeros();
    let mut rot = vec![(0.0, 0.0); m];
    for k in (0..m).rev() {
        let col = &jac[6 * k..6 * k + 6];
        let u = Vector3::new(col[0], col[1], col[2]);
        let a = Vector3::new(col[3], col[4], col[5]);
        // A translation's column `[w; 0]` (a rotation's axis is a unit vector): it moves the
        // tip along w and turns nothing.
        if a == Vector3::zeros() {
            d += u * theta[k];
            continue;
        }
        let x = u.cross(&a);
        after[k] = d + x;
        if theta[k] != 0.0 {
            rot[k] = sin_and_versine(theta[k]);
            d += rotation_minus_identity(&a, rot[k].0, rot[k].1, &(d + x));
        }
    }
    // Sweep from the base: the rotation of springs 1..=k, G_k R_k, applied to each column
    // (a_k × (v_k − c_k) = R_k (a_k × (w − c_k)) with w = E_{k+1}(⋯(p)), and R_k a_k = a_k).
    let mut g = Matrix3::<f64>::identity();
    for k in 0..m {
        let a = Vector3::new(jac[6 * k + 3], jac[6 * k + 4], jac[6 * k + 5]);
        if a == Vector3::zeros() {
            let u = g * Vector3::new(jac[6 * k], jac[6 * k + 1], jac[6 * k + 2]);
            jac[6 * k..6 * k + 3].copy_from_slice(u.as_slice());
            continue;
        }
        if theta[k] != 0.0 {
            let (sin, versine) = rot[k];
            let hat = a.cross_matrix();
            let r = Matrix3::identity() + hat * sin + hat * hat * versine;
            g *= r;
        }
        let u = g * a.cross(&after[k]);
        let w = g * a;
        for r in 0..3 {
            jac[6 * k + r] = u[r];
            jac[6 * k + r + 3] = w[r];
        }
    }
    *tip += d;
    *tip_rotation = g * *tip_rotation;
}

/// `(sin θ, 1 − cos θ)` for a spring deflection θ (rad). Deflections are of order 1e-4 rad,
/// where the Taylor series to the terms kept is exact in double precision (the first term
/// left out is below 1e-25 relative for |θ| < 1e-3); the diagnosis evaluates them for every
/// deflecting spring in every step of every row's equilibrium, so they skip the library's
/// `sin_cos`. `1 − cos θ` is formed without the cancellation of `1.0 - cos`.
pub(crate) fn sin_and_versine(theta: f64) -> (f64, f64) {
    if theta.abs() >= 1e-3 {
        let h = (0.5 * theta).sin();
        return (theta.sin(), 2.0 * h * h);
    }
    let t2 = theta * theta;
    let sin = theta * (1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0)));
    let versine = 0.5 * t2 * (1.0 - t2 / 12.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0)));
    (sin, versine)
}

/// `(R − I) y` for the rotation R about the unit axis `a` with `sin θ = sin` and
/// `1 − cos θ = versine` (Rodrigues: `R = I + sin θ [a]× + (1 − cos θ) [a]×²`).
pub(crate) fn rotation_minus_identity(
    a: &Vector3<f64>,
    sin: f64,
    versine: f64,
    y: &Vector3<f64>,
) -> Vector3<f64> {
    let ay = a.cross(y);
    ay * sin + a.cross(&ay) * versine
}

/// Inverse condition number σ_min/σ_max of the actuated Jacobian `[J_lin; L·J_ang]` at `q`
/// (joint angles, rad), L = 0.5 m so that a rotation of 1 rad weighs as 0.5 m of the tip: 0 at
/// a singularity, 1 for an isotropic pose; 0 as well when the Jacobian is not finite. Planning
/// keeps poses above a floor of it. (The virtual testbed computes its own from its independent
/// kinematics, `testbed::inverse_condition`.)
pub fn inverse_condition(chain: &SerialChain, q: &[f64]) -> f64 {
    let model = VirtualJointModel::traditional(chain.n_joints());
    let (Ok(mut ws), Ok(())) = (Workspace::new(chain, &model), chain.check_q(q, 0)) else {
        return 0.0;
    };
    ws.evaluate(chain, q);
    inverse_condition_at(&mut ws)
}

/// [`inverse_condition`] at the pose `ws` was last evaluated at (a workspace of the chain's
/// traditional model, [`Workspace::evaluate`] done): a loop over poses reuses one workspace
/// and the frames it already evaluated.
pub(crate) fn inverse_condition_at(ws: &mut Workspace) -> f64 {
    let mut jac = std::mem::take(&mut ws.jac);
    ws.write_jacobian(&mut jac);
    let j = DMatrix::from_column_slice(6, jac.len() / 6, &jac);
    ws.jac = jac;
    inverse_condition_of(j)
}

/// σ_min/σ_max of `[J_lin; L·J_ang]` (L = 0.5 m) for the actuated 6×n Jacobian `j`
/// (`[linear; angular]` rows); 0 when it cannot be decomposed (not finite) or is zero.
pub(crate) fn inverse_condition_of(mut j: DMatrix<f64>) -> f64 {
    j.rows_mut(3, 3).scale_mut(0.5);
    // A pose whose Jacobian cannot be decomposed (non-finite) is unusable: condition 0, so a
    // pose sampler rejects it (and ends with its attempt cap).
    let Ok(svd) = stiffness_core::decompose::svd(j, false, false, "SVD of the pose Jacobian")
    else {
        return 0.0;
    };
    let s = svd.singular_values;
    let smax = s.iter().copied().fold(0.0, f64::max);
    let smin = s.iter().copied().fold(f64::INFINITY, f64::min);
    if smax > 0.0 {
        smin / smax
    } else {
        0.0
    }
}
