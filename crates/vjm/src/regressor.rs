//! Regressor rows of the identification problem (seed eqs. 9–10).
//!
//! With C_Θ = diag(c) the tip deflection is Δx = J C_Θ Jᵀ F = A(J, F) c with
//! `A[r][k] = J[r][k] · (J_kᵀ F)`: row r of the Jacobian times the generalised force on
//! spring k. (The seed's printed A has the column index of the inner sum wrong in its last
//! row, `J_61 Σ J_i6 F_i`; the mathematics is `J_61 Σ J_i1 F_i`.)

use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::kinematics::{check_wrench, Workspace};
use crate::model::VirtualJointModel;

/// Which components of the tip deflection are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Measured {
    /// Translation only `[dx, dy, dz]` (m): 3 rows per wrench.
    Translation,
    /// Translation and rotation `[dx, dy, dz, rx, ry, rz]` (m, rad): 6 rows per wrench.
    Full,
}

impl Measured {
    /// Rows per wrench: 3 or 6.
    pub fn rows(self) -> usize {
        match self {
            Measured::Translation => 3,
            Measured::Full => 6,
        }
    }
}

/// Writes the regressor rows A(J, F) of one configuration `q` (rad) under `wrench`
/// `[fx, fy, fz, mx, my, mz]` (N, N·m, base frame, at the tip point) into `out`,
/// **row-major** `rows × m` (rows = 3 or 6): `out[r*m + k] = J[r][k]·(J_kᵀF)`, in m/(N·m)·… so
/// that `A c` is the deflection in m (rows 0–2) and rad (rows 3–5), base frame.
/// No allocation.
pub fn regressor_rows(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrench: &[f64; 6],
    measured: Measured,
    ws: &mut Workspace,
    out: &mut [f64],
) -> Result<(), VjmError> {
    let m = model.n_params();
    let rows = measured.rows();
    if out.len() != rows * m {
        return Err(VjmError::ShapeMismatch {
            what: "regressor output buffer (rows·m)",
            expected: rows * m,
            got: out.len(),
        });
    }
    check_wrench(wrench, 0)?;
    let mut jac = std::mem::take(&mut ws.jac);
    let result = crate::kinematics::jacobian_in_place(chain, model, q, ws, &mut jac);
    if result.is_ok() {
        for k in 0..m {
            let col = &jac[6 * k..6 * k + 6];
            let g: f64 = col.iter().zip(wrench).map(|(a, b)| a * b).sum();
            for r in 0..rows {
                out[r * m + k] = col[r] * g;
            }
        }
    }
    ws.jac = jac;
    result
}
