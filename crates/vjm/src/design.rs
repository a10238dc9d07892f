//! Experiment design (item 6): scoring configurations by conditioning and picking a
//! well-conditioned subset from a pool; [`plan`] plans poses and wrenches against the
//! predicted standard errors.

pub mod plan;

use nalgebra::{DMatrix, Dyn, SymmetricEigen};
use serde::Serialize;

use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::kinematics::Workspace;
use crate::model::VirtualJointModel;
use crate::regressor::{regressor_rows, Measured};

/// Dexterity index κ_F⁻¹ of the actuated joints' Jacobian at `q` (rad), the measure of the
/// seed's Table I: 1/κ_F with κ_F = ⅙·√(tr(JJᵀ)·tr((JJᵀ)⁻¹)) for the 6×n Jacobian whose
/// linear rows are divided by `length` (m) to make units homogeneous. In (0, 1]; 0 at a
/// singularity. The seed's values are for its SHIR5 robot and its (unstated) length, so
/// they cannot be reproduced for another arm.
pub fn dexterity(chain: &SerialChain, q: &[f64], length: f64) -> Result<f64, VjmError> {
    if !(length.is_finite() && length > 0.0) {
        return Err(VjmError::InvalidOption {
            name: "length",
            message: format!(
                "must be finite and > 0 m, got {}",
                stiffness_core::num::Short(length)
            ),
        });
    }
    let model = VirtualJointModel::traditional(chain.n_joints());
    let mut j = crate::kinematics::jacobian(chain, &model, q)?;
    for k in 0..j.ncols() {
        for r in 0..3 {
            j[(r, k)] /= length;
        }
    }
    let jjt = &j * j.transpose();
    let eig = symmetric_eigen(jjt, "eigen-decomposition of J Jᵀ")?;
    let lmax = eig.eigenvalues.max();
    let lmin = eig.eigenvalues.min();
    if lmin <= 1e-12 * lmax.max(f64::MIN_POSITIVE) {
        return Ok(0.0);
    }
    let tr: f64 = eig.eigenvalues.iter().sum();
    let tr_inv: f64 = eig.eigenvalues.iter().map(|l| 1.0 / l).sum();
    Ok(6.0 / (tr * tr_inv).sqrt())
}

/// The information matrix AᵀA (m×m) of configuration `q` under each of `wrenches`.
fn information(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrenches: &[[f64; 6]],
    measured: Measured,
    ws: &mut Workspace,
    buf: &mut [f64],
) -> Result<DMatrix<f64>, VjmError> {
    let m = model.n_params();
    let rows = measured.rows();
    let mut info = DMatrix::zeros(m, m);
    for f in wrenches {
        regressor_rows(chain, model, q, f, measured, ws, buf)?;
        for r in 0..rows {
            let row = &buf[r * m..(r + 1) * m];
            for a in 0..m {
                for b in 0..m {
                    info[(a, b)] += row[a] * row[b];
                }
            }
        }
    }
    Ok(info)
}

/// The result of [`select_configurations`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Selection {
    /// Indices into the pool, in the order picked.
    pub indices: Vec<usize>,
    /// Condition number (σ_max/σ_min of the column-scaled design restricted to the pool's
    /// identifiable subspace) after each pick; `inf` until that subspace is covered.
    pub condition_numbers: Vec<f64>,
    /// Condition number of the whole pool on the same subspace.
    pub pool_condition_number: f64,
    /// Rank of the whole pool (the dimension of the identifiable subspace).
    pub rank: usize,
}

/// Greedily picks `count` configurations from `pool` (N×n row-major, rad), each measured
/// under all of `wrenches`, for a well-conditioned identification: parameters are scaled
/// by the pool's column norms, restricted to the pool's identifiable subspace (rank r),
/// and each step adds the configuration maximising log det of the reduced information
/// (D-optimal, with a tiny ridge so the first picks are well defined) until the subspace is
/// covered, then the one giving the smallest condition number. The score reported is the
/// condition number of the scaled design on that subspace.
pub fn select_configurations(
    chain: &SerialChain,
    model: &VirtualJointModel,
    pool: &[f64],
    wrenches: &[[f64; 6]],
    measured: Measured,
    count: usize,
) -> Result<Selection, VjmError> {
    let n = chain.n_joints();
    if pool.is_empty() || !pool.len().is_multiple_of(n) {
        return Err(VjmError::ShapeMismatch {
            what: "configuration pool (N×n row-major)",
            expected: (pool.len() / n).max(1) * n,
            got: pool.len(),
        });
    }
    if wrenches.is_empty() {
        return Err(VjmError::InvalidOption {
            name: "wrenches",
            message: "at least one wrench per configuration is needed".into(),
        });
    }
    let size = pool.len() / n;
    if count == 0 || count > size {
        return Err(VjmError::InvalidOption {
            name: "count",
            message: format!("must be in 1..={size} (the pool size), got {count}"),
        });
    }
    let m = model.n_params();
    let mut ws = Workspace::new(chain, model)?;
    let mut buf = vec![0.0; measured.rows() * m];
    let mut infos = Vec::with_capacity(size);
    for (i, q) in pool.chunks_exact(n).enumerate() {
        let info = information(chain, model, q, wrenches, measured, &mut ws, &mut buf).map_err(
            |e| match e {
                VjmError::NonFinite {
                    what,
                    column,
                    value,
                    ..
                } => VjmError::NonFinite {
                    what,
                    row: i,
                    column,
                    value,
                },
                other => other,
            },
        )?;
        infos.push(info);
    }
    let total: DMatrix<f64> = infos.iter().fold(DMatrix::zeros(m, m), |a, b| a + b);
    let scale = column_scale(&total);
    let scaled = |a: &DMatrix<f64>| DMatrix::from_fn(m, m, |i, j| a[(i, j)] * scale[i] * scale[j]);
    let eig = symmetric_eigen(
        scaled(&total),
        "eigen-decomposition of the pooled information",
    )?;
    let lmax = eig.eigenvalues.max();
    // Eigenvalues of the Gram matrix carry rounding of order 1e-16·λ_max in structurally
    // null directions (the squaring that identification avoids with TSQR), so the cut-off
    // is λ > 1e-12·λ_max, i.e. σ > 1e-6·σ_max — ample for a conditioning score.
    let keep: Vec<usize> = (0..m)
        .filter(|&i| eig.eigenvalues[i] > 1e-12 * lmax)
        .collect();
    let r = keep.len();
    let basis = DMatrix::from_fn(m, r, |i, j| eig.eigenvectors[(i, keep[j])]);
    let reduced: Vec<DMatrix<f64>> = infos
        .iter()
        .map(|a| basis.transpose() * scaled(a) * &basis)
        .collect();
    let cond = |a: &DMatrix<f64>| {
        let Ok(eig) = symmetric_eigen(
            a.clone(),
            "eigen-decomposition of a candidate's information",
        ) else {
            // Not a usable candidate (non-finite information): never the best.
            return f64::INFINITY;
        };
        let e = eig.eigenvalues;
        let (hi, lo) = (e.max(), e.min());
        if lo <= 1e-12 * hi.max(f64::MIN_POSITIVE) {
            f64::INFINITY
        } else {
            (hi / lo).sqrt()
        }
    };
    let pool_reduced = basis.transpose() * scaled(&total) * &basis;
    let ridge = 1e-12 * pool_reduced.trace() / r.max(1) as f64;
    let mut current = DMatrix::<f64>::identity(r, r) * ridge;
    let mut chosen = vec![false; size];
    let mut indices = Vec::with_capacity(count);
    let mut condition_numbers = Vec::with_capacity(count);
    let ridge_matrix = DMatrix::<f64>::identity(r, r) * ridge;
    let mut covered = false;
    for _ in 0..count {
        let mut best = (f64::NEG_INFINITY, usize::MAX);
        for (i, info) in reduced.iter().enumerate() {
            if chosen[i] {
                continue;
            }
            let cand = &current + info;
            // Until the subspace is covered: D-optimal (log det, ridge-regularised); then
            // directly the smallest condition number.
            let score = if covered {
                -cond(&(&cand - &ridge_matrix))
            } else {
                match cand.cholesky() {
                    Some(c) => c.l().diagonal().iter().map(|d| 2.0 * d.ln()).sum(),
                    None => f64::NEG_INFINITY,
                }
            };
            if score > best.0 {
                best = (score, i);
            }
        }
        let i = if best.1 == usize::MAX {
            (0..size).find(|&i| !chosen[i]).unwrap_or(0)
        } else {
            best.1
        };
        chosen[i] = true;
        current += &reduced[i];
        indices.push(i);
        let c = cond(&(&current - &ridge_matrix));
        covered = c.is_finite();
        condition_numbers.push(c);
    }
    Ok(Selection {
        indices,
        condition_numbers,
        pool_condition_number: cond(&pool_reduced),
        rank: r,
    })
}

/// Per-parameter scaling `1/‖column‖` from an information matrix `AᵀA` (its diagonal holds the
/// squared column norms). A column of pure rounding (a torsion about an axis through the tip
/// point) gets 0 rather than being blown up to unit norm, the rule of `lsq::ZERO_COLUMN_RTOL`.
pub(crate) fn column_scale(info: &DMatrix<f64>) -> Vec<f64> {
    let norms: Vec<f64> = (0..info.nrows())
        .map(|k| info[(k, k)].max(0.0).sqrt())
        .collect();
    let nmax = norms.iter().copied().fold(0.0, f64::max);
    norms
        .iter()
        .map(|&s| {
            if s > crate::lsq::ZERO_COLUMN_RTOL * nmax {
                1.0 / s
            } else {
                0.0
            }
        })
        .collect()
}

/// Capped symmetric eigen-decomposition (nalgebra's own loops forever on NaN).
pub(crate) fn symmetric_eigen(
    m: DMatrix<f64>,
    what: &'static str,
) -> Result<SymmetricEigen<f64, Dyn>, VjmError> {
    Ok(stiffness_core::decompose::symmetric_eigen(m, what)?)
}
