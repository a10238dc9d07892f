//! Small statistics helpers.

/// Two-sided 95 % quantile of Student's t with `dof` degrees of freedom (0.975 quantile),
/// from the Cornish–Fisher expansion (Abramowitz & Stegun 26.7.5) for dof ≥ 3 and exact
/// values below; `None` for dof = 0. Relative error below 1e-3 for dof ≥ 3.
pub fn student_t_975(dof: usize) -> Option<f64> {
    match dof {
        0 => None,
        1 => Some(12.706_204_736_174_7),
        2 => Some(4.302_652_729_749_46),
        _ => {
            let z: f64 = 1.959_963_984_540_054;
            let v = dof as f64;
            let z2 = z * z;
            let g1 = (z2 * z + z) / 4.0;
            let g2 = (5.0 * z2 * z2 * z + 16.0 * z2 * z + 3.0 * z) / 96.0;
            let g3 = (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z) / 384.0;
            let g4 = (79.0 * z.powi(9) + 776.0 * z.powi(7) + 1482.0 * z.powi(5)
                - 1920.0 * z.powi(3)
                - 945.0 * z)
                / 92160.0;
            Some(z + g1 / v + g2 / (v * v) + g3 / v.powi(3) + g4 / v.powi(4))
        }
    }
}
