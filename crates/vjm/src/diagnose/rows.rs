//! Per-row kinematics of the diagnosis, computed on the fly in every pass (never stored for
//! all rows): the 3n-spring Jacobian at the tip point, spring torques, tip frame, and the exact
//! deflected-equilibrium response the geometric non-linearity candidate needs.
//!
//! Everything here is the crate's own kinematics (`vjm::kinematics`, re-exported as [`crate::jacobian`] and friends); the diagnosis does
//! not use the testbed, which is the independent code path the tests check it against.

use std::cell::RefCell;

use nalgebra::{DMatrix, Vector3};

use super::candidates::{torque_sigma_into, RowKinematics};
use crate::chain::SerialChain;
use crate::dataset::Dataset;
use crate::gravity::{GravityWorkspace, RowFrame};
use crate::kinematics::{rotation_minus_identity, sin_and_versine, Workspace};
use crate::model::VirtualJointModel;

/// Reusable scratch that turns a dataset row into [`RowKinematics`].
#[derive(Debug, Clone)]
pub struct RowBuilder<'a> {
    chain: &'a SerialChain,
    model: VirtualJointModel,
    ws: Workspace,
    wrench_sigma: [f64; 6],
    /// The deflected equilibrium's per-spring state, reused from row to row (a builder
    /// belongs to one thread's pass, so the cell is never shared).
    springs: RefCell<Vec<DeflectingSpring>>,
    /// Rotation of the tip frame in the last joint's child frame (the chain's tip offset).
    tip_offset: nalgebra::Matrix3<f64>,
    /// Scratch of [`Self::rows_into`].
    batch: BatchScratch,
    /// The weight's torques and stiffness per row, for a diagnosis under gravity.
    gravity: Option<GravityWorkspace>,
    /// The compliances (3n, rad/(N·m)) at which gravity's stiffness couples into the load's
    /// torque ([`RowKinematics::tau`]); zeros until [`Self::set_linearisation`].
    coupling: Vec<f64>,
}

/// Rows evaluated together by [`RowBuilder::rows_into`]: the most lanes a dispatched
/// instruction set has (16 under AVX-512; AVX2 takes them 8 at a time).
pub const ROW_BATCH: usize = crate::lanes::MAX_LANES;

/// The buffers of a batch of rows, sized once for [`ROW_BATCH`] rows.
#[derive(Debug, Clone)]
struct BatchScratch {
    /// The deflecting springs (non-zero compliance) and their compliances.
    springs: Vec<usize>,
    compliance: Vec<f64>,
    q: Vec<f64>,
    jac: Vec<f64>,
    tip: Vec<f64>,
    rot: Vec<f64>,
    columns: Vec<f64>,
    torque: Vec<f64>,
    wrench: Vec<f64>,
    deflected: Vec<[f64; 3]>,
}

/// One deflecting spring of [`RowBuilder::exact_displacement`].
#[derive(Debug, Clone, Copy)]
struct DeflectingSpring {
    /// Compliance, rad/(N·m).
    c: f64,
    /// Undeflected base-frame axis.
    a: Vector3<f64>,
    /// The tip's offset from the spring's centre, across the axis.
    x: Vector3<f64>,
    /// Deflection of the current step and of the next, rad.
    theta: f64,
    next: f64,
    /// sin θ and 1 − cos θ.
    sin: f64,
    versine: f64,
    /// `v_k − p`: the tip's displacement once springs k.. are deflected.
    after: Vector3<f64>,
}

impl<'a> RowBuilder<'a> {
    /// Scratch for `chain`; `wrench_sigma` is the recorded wrench's per-axis noise (N, N·m)
    /// that sets each row's torsion-torque noise (backlash candidate).
    pub fn new(chain: &'a SerialChain, wrench_sigma: [f64; 6]) -> Self {
        let model = VirtualJointModel::extended(chain.n_joints());
        let m = model.n_params();
        let ws = Workspace::new(chain, &model).expect("the extended model fits its own chain");
        Self {
            chain,
            model,
            ws,
            wrench_sigma,
            springs: RefCell::new(Vec::new()),
            tip_offset: *chain.tip_offset().rotation.to_rotation_matrix().matrix(),
            batch: BatchScratch {
                springs: Vec::with_capacity(m),
                compliance: Vec::with_capacity(m),
                q: Vec::with_capacity(ROW_BATCH * chain.n_joints()),
                jac: vec![0.0; ROW_BATCH * 6 * m],
                tip: vec![0.0; ROW_BATCH * 3],
                rot: vec![0.0; ROW_BATCH * 9],
                columns: Vec::new(),
                torque: Vec::new(),
                wrench: Vec::new(),
                deflected: vec![[0.0; 3]; ROW_BATCH],
            },
            gravity: None,
            coupling: vec![0.0; m],
        }
    }

    /// The same builder for measurements taken under the weight `gravity` describes (a
    /// workspace for the extended model of this chain, [`GravityWorkspace::new`]): each row
    /// then carries τ_g(q) and its load torque includes gravity's coupling.
    pub fn with_gravity(mut self, gravity: GravityWorkspace) -> Self {
        assert_eq!(
            gravity.model(),
            &self.model,
            "the gravity workspace is made for the chain's extended model"
        );
        self.gravity = Some(gravity);
        self
    }

    /// The compliances (3n, rad/(N·m)) of the pass's linearisation, at which gravity's
    /// stiffness couples into the rows' load torques (no effect on a weightless builder).
    pub fn set_linearisation(&mut self, compliance: &[f64]) {
        self.coupling.copy_from_slice(compliance);
    }

    /// Gravity's part of a row whose Jacobian and load torque are in place, at the pass's
    /// linearisation C: the row is moved to the unloaded equilibrium under the weight (the
    /// sagged pose θ₀ = C τ₀, τ₀ = τ_g + K_G θ₀, where the measurement's reference was taken),
    /// its Jacobian, tip and load torque are those of that pose, `tau_gravity` is τ₀ (the
    /// preload of each spring) and `tau` the load torque with gravity's coupling. The sag
    /// (≈ 3 mrad on a Panda-class arm) turns the Jacobian by as much, which changes a
    /// millimetre-size deflection by micrometres: the size of the tracker's noise.
    ///
    /// A pose where the springs at the linearisation cannot hold the arm (K_θ − K_G singular,
    /// only at absurd compliances) keeps the weightless row.
    fn add_gravity(&mut self, row: &mut RowKinematics) {
        let Some(g) = self.gravity.as_mut() else {
            return;
        };
        if g.evaluate(self.chain, &row.q).is_err() {
            return;
        }
        let mut tip = Vector3::from(row.tip);
        let frame = RowFrame {
            jacobian: row.jacobian.as_mut_slice(),
            tip: &mut tip,
            tip_rotation: &mut row.tip_rotation,
        };
        if g.sag(&self.coupling, frame, &mut row.tau_gravity).is_err() {
            row.tau_gravity.fill(0.0);
            return;
        }
        row.tip = [tip.x, tip.y, tip.z];
        for (s, t) in row.tau_load.iter_mut().enumerate() {
            let col = &row.jacobian.as_slice()[6 * s..6 * s + 6];
            *t = col.iter().zip(&row.wrench).map(|(j, w)| j * w).sum();
        }
        if g.effective_torques(&self.coupling, &row.tau_load, &mut row.tau)
            .is_err()
        {
            row.tau.copy_from_slice(&row.tau_load);
        }
    }

    /// An empty record for [`Self::row_into`] to fill, sized for this chain.
    pub fn empty_row(&self) -> RowKinematics {
        let m = self.model.n_params();
        RowKinematics {
            q: vec![0.0; self.chain.n_joints()],
            jacobian: DMatrix::zeros(6, m),
            tau: vec![0.0; m],
            tau_load: vec![0.0; m],
            tau_gravity: vec![0.0; m],
            wrench: [0.0; 6],
            displacement: [0.0; 3],
            tip: [0.0; 3],
            tau_sigma: vec![0.0; self.chain.n_joints()],
            tip_rotation: nalgebra::Matrix3::identity(),
            deflected: None,
        }
    }

    /// The kinematics of the rows `rows` of `data` (at most [`ROW_BATCH`]) into `out`, one
    /// record per row (made by [`Self::empty_row`]), evaluated lane-wise over the rows
    /// (`crate::lanes`); with `deflect` (compliances, 3n, rad/(N·m)), also each row's
    /// deflected equilibrium under those compliances ([`RowKinematics::deflected`]), lane-wise
    /// too. The same values as [`Self::row_into`] and [`Self::exact_displacement`] row by row,
    /// to rounding (`tests/it/diagnose.rs`, `a_batch_of_rows_equals_the_rows_one_by_one`).
    pub fn rows_into(
        &mut self,
        data: &Dataset<'_>,
        rows: &[usize],
        deflect: Option<&[f64]>,
        out: &mut [RowKinematics],
    ) {
        let n = rows.len();
        assert!(
            n <= ROW_BATCH && out.len() >= n,
            "a batch of at most {ROW_BATCH} rows into as many records"
        );
        let nj = self.chain.n_joints();
        let m = self.model.n_params();
        let b = &mut self.batch;
        b.q.clear();
        for &i in rows {
            b.q.extend_from_slice(data.q(i));
        }
        crate::lanes::gram::jacobian_tip_batch(
            self.ws.lanes(),
            &b.q,
            &mut b.jac[..n * 6 * m],
            &mut b.tip[..3 * n],
            &mut b.rot[..9 * n],
        );
        for (r, (&i, row)) in rows.iter().zip(out.iter_mut()).enumerate() {
            row.q.copy_from_slice(&b.q[r * nj..(r + 1) * nj]);
            row.jacobian
                .as_mut_slice()
                .copy_from_slice(&b.jac[r * 6 * m..(r + 1) * 6 * m]);
            row.tip = [b.tip[3 * r], b.tip[3 * r + 1], b.tip[3 * r + 2]];
            let last = nalgebra::Matrix3::from_row_slice(&b.rot[9 * r..9 * r + 9]);
            row.tip_rotation = last * self.tip_offset;
            fill_from_jacobian(data, i, &self.wrench_sigma, row);
        }
        if self.gravity.is_some() {
            for row in &mut out[..n] {
                self.add_gravity(row);
            }
        }
        let b = &mut self.batch;
        let Some(c) = deflect.filter(|c| c.iter().any(|v| *v != 0.0)) else {
            return;
        };
        // The deflecting springs' columns and torques, row by row, for the lane-wise solve.
        b.springs.clear();
        b.springs.extend((0..c.len()).filter(|s| c[*s] != 0.0));
        b.compliance.clear();
        b.compliance.extend(b.springs.iter().map(|s| c[*s]));
        b.columns.clear();
        b.torque.clear();
        b.wrench.clear();
        for row in &out[..n] {
            for &s in &b.springs {
                b.columns
                    .extend_from_slice(&row.jacobian.as_slice()[6 * s..6 * s + 6]);
                b.torque.push(row.tau_load[s]);
            }
            b.wrench.extend_from_slice(&row.wrench);
        }
        let input = crate::lanes::equilibrium::EquilibriumRows {
            compliance: &b.compliance,
            columns: &b.columns,
            torque: &b.torque,
            wrench: &b.wrench,
        };
        if crate::lanes::equilibrium::deflected_displacements(&input, n, &mut b.deflected[..n]) {
            for (row, d) in out[..n].iter_mut().zip(&b.deflected) {
                row.deflected = Some(*d);
            }
        }
    }

    /// The kinematics of row `i` of `data`, written into `out` (made by [`Self::empty_row`]:
    /// a pass reuses one record, so a row costs no allocation). The rows are finite-checked
    /// and checked against the chain on entry, so the evaluation cannot fail; the workspace
    /// was made for this builder's model, so it is not checked again.
    pub fn row_into(&mut self, data: &Dataset<'_>, i: usize, out: &mut RowKinematics) {
        out.q.copy_from_slice(data.q(i));
        self.ws.evaluate(self.chain, &out.q);
        self.ws.write_jacobian(out.jacobian.as_mut_slice());
        // The tip frame of the evaluation the Jacobian came from (no second forward pass).
        let t = self.ws.p;
        out.tip = [t.x, t.y, t.z];
        out.tip_rotation = self.ws.tip_rotation(self.chain);
        fill_from_jacobian(data, i, &self.wrench_sigma, out);
        self.add_gravity(out);
    }

    /// The exact tip displacement (m, base frame) of linear springs of compliances `c` (3n,
    /// rad/(N·m)) under the row's wrench, with equilibrium in the deflected configuration:
    /// the fixed point `θ = C J(θ)ᵀ W`, then the deflected tip minus the unloaded one.
    ///
    /// The same kinematics as `vjm::kinematics::jacobian_deflected` (springs at the joint
    /// origins, composed `[z, x, y]` after the joint rotation), written in the base frame from
    /// the row's Jacobian alone. With `N_k` the undeflected frame of spring k and `S_k` its
    /// rotation, the deflected frame of spring k is `E_1 ⋯ E_{k−1} N_k` with
    /// `E_k = N_k S_k N_k⁻¹`, the rotation by θ_k about spring k's *undeflected* base-frame
    /// axis `a_k` through its centre `c_k`: the Jacobian's column `[a_k × (p − c_k); a_k]`
    /// gives both (only the offset's part across the axis matters, `(a × (p − c)) × a`). So
    /// - the deflected tip is `E_1(E_2(⋯E_K(p)))`, a sweep from the tip that carries the
    ///   displacement itself, `d ← d + (R_k − I)(d + p − c_k)`, with no cancellation against
    ///   the tip's distance from the base;
    /// - spring k's torque is `a_k · ((v_k − c_k) × f_k + m_k)`, with `v_k = E_k(⋯E_K(p))`
    ///   from that sweep and the wrench turned back through the springs before k,
    ///   `f_{k+1} = R_kᵀ f_k` (a sweep from the base).
    ///
    /// Springs of zero compliance never deflect and are left out.
    pub fn exact_displacement(&self, row: &RowKinematics, c: &[f64]) -> [f64; 3] {
        let j = &row.jacobian;
        // Per deflecting spring, base to tip: compliance, axis a, tip offset across the axis.
        let mut springs = self.springs.borrow_mut();
        springs.clear();
        springs.extend((0..c.len()).filter(|s| c[*s] != 0.0).map(|s| {
            let u = Vector3::new(j[(0, s)], j[(1, s)], j[(2, s)]);
            let a = Vector3::new(j[(3, s)], j[(4, s)], j[(5, s)]);
            DeflectingSpring {
                c: c[s],
                a,
                x: u.cross(&a),
                theta: c[s] * row.tau_load[s],
                next: 0.0,
                sin: 0.0,
                versine: 0.0,
                after: Vector3::zeros(),
            }
        }));
        let f = Vector3::new(row.wrench[0], row.wrench[1], row.wrench[2]);
        let m = Vector3::new(row.wrench[3], row.wrench[4], row.wrench[5]);
        let mut d = Vector3::zeros();
        // |C·K_C| is of order |W|·reach·c ≈ 1e-2, so the iteration contracts fast; 100 steps
        // is a cap, not an expectation. The displacement returned is the one at the last θ
        // whose update moved it by ≤ 1e-14 relative: it differs from the fixed point's by as
        // little (about 1e-12 of the column, which is the deflection's second-order part).
        for _ in 0..100 {
            for sp in springs.iter_mut() {
                (sp.sin, sp.versine) = sin_and_versine(sp.theta);
            }
            d = Vector3::zeros();
            for sp in springs.iter_mut().rev() {
                d += rotation_minus_identity(&sp.a, sp.sin, sp.versine, &(d + sp.x));
                sp.after = d;
            }
            let (mut fk, mut mk) = (f, m);
            for sp in springs.iter_mut() {
                sp.next = sp.c * (sp.a.dot(&(sp.after + sp.x).cross(&fk)) + sp.a.dot(&mk));
                fk += rotation_minus_identity(&sp.a, -sp.sin, sp.versine, &fk);
                mk += rotation_minus_identity(&sp.a, -sp.sin, sp.versine, &mk);
            }
            let change = springs
                .iter()
                .map(|sp| (sp.next - sp.theta).abs())
                .fold(0.0, f64::max);
            let scale = springs
                .iter()
                .map(|sp| sp.next.abs())
                .fold(1e-300, f64::max);
            if change <= 1e-14 * scale {
                break;
            }
            for sp in springs.iter_mut() {
                sp.theta = sp.next;
            }
        }
        [d.x, d.y, d.z]
    }
}

/// The rest of a row's record once its Jacobian is in place: the spring torques `Jᵀ W`, their
/// noise, the recorded wrench and displacement of row `i`, and no deflected equilibrium yet
/// (one record serves many rows).
fn fill_from_jacobian(
    data: &Dataset<'_>,
    i: usize,
    wrench_sigma: &[f64; 6],
    row: &mut RowKinematics,
) {
    let wrench = data.wrench(i);
    for (s, t) in row.tau_load.iter_mut().enumerate() {
        let col = &row.jacobian.as_slice()[6 * s..6 * s + 6];
        *t = col.iter().zip(&wrench).map(|(j, w)| j * w).sum();
    }
    // Weightless until the builder's gravity step (if any) adds its part.
    row.tau.copy_from_slice(&row.tau_load);
    row.tau_gravity.fill(0.0);
    torque_sigma_into(&row.jacobian, wrench_sigma, &mut row.tau_sigma);
    row.wrench = wrench;
    row.displacement = data.displacement(i);
    row.deflected = None;
}

/// Moves a row's kinematics (Jacobian, tip point, tip rotation) to the deflected state
/// `theta` (rad, 3n springs in the Jacobian's order), exactly
/// (`kinematics::deflect_in_place`; equal to `vjm::jacobian_deflected` to rounding,
/// `tests/it/diagnose.rs`, `a_row_deflected_in_place_equals_the_deflected_chain`).
pub fn deflect_row(row: &mut RowKinematics, theta: &[f64]) {
    let mut tip = Vector3::from(row.tip);
    crate::kinematics::deflect_in_place(
        row.jacobian.as_mut_slice(),
        &mut tip,
        &mut row.tip_rotation,
        theta,
    );
    row.tip = [tip.x, tip.y, tip.z];
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The series of `sin θ` and `1 − cos θ` against the library's `sin` (`1 − cos θ` as
    /// `2 sin²(θ/2)`, free of cancellation), relative, on both sides of the switch and at the
    /// fixtures 0 and 1e-8; then `(R − I) y` against the library's rotation matrix where the
    /// change is of the size of y (0.7 rad, π − 1e-6, π), about a skew axis and basis axes.
    #[test]
    fn rotation_minus_identity_equals_the_exponential_map() {
        for angle in [
            0.0, 1e-8, -3e-6, 1e-4, -2.5e-4, 9.999e-4, -9.999e-4, 1e-3, 0.7,
        ] {
            let (sin, versine) = sin_and_versine(angle);
            let h = (0.5 * angle).sin();
            let (want_sin, want_versine) = (angle.sin(), 2.0 * h * h);
            assert!(
                (sin - want_sin).abs() <= 2.0 * f64::EPSILON * want_sin.abs(),
                "{angle}"
            );
            assert!(
                (versine - want_versine).abs() <= 2.0 * f64::EPSILON * want_versine,
                "{angle}"
            );
        }
        let axes = [
            Vector3::z(),
            Vector3::x(),
            Vector3::new(0.3, -0.5, 0.8).normalize(),
        ];
        let y = Vector3::new(0.7, -1.3, 0.4);
        let pi = std::f64::consts::PI;
        for axis in &axes {
            for angle in [0.7, -0.7, pi - 1e-6, pi] {
                let (sin, versine) = sin_and_versine(angle);
                let ours = rotation_minus_identity(axis, sin, versine, &y);
                let r = nalgebra::Rotation3::from_axis_angle(
                    &nalgebra::Unit::new_normalize(*axis),
                    angle,
                );
                let d = (ours - (r * y - y)).amax();
                assert!(
                    d <= 4.0 * f64::EPSILON * y.norm(),
                    "angle {angle}: off by {d:e}"
                );
            }
        }
    }
}
