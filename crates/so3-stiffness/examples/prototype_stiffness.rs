//! Stiffness of the seed prototype CSJM at a loaded pose, Euclidean vs connection-corrected.
//!
//! Run: `cargo run -p so3-stiffness --example prototype_stiffness`
//!
//! The seed gives the geometry and platform weight but not the cable stiffnesses or tensions.
//! This example picks them so that the numbers are of the order of the seed's Table 3:
//! an 80 N pre-tension in every cable at the home pose, and one cable stiffness k (cable plus
//! driving unit) chosen so that the unloaded tilt stiffness K_xx at home is 30 N·m/rad — K is
//! affine in k at fixed tensions, so k = (30 − K_xx(k=0)) / (K_xx(k=1) − K_xx(k=0)).
//! It then applies the seed's pre-load ᴬτ₀ = (−0.06, −3.08, 1.07) N·m (external moment, frame
//! A) with the platform weight, solves the equilibrium pose R₀ and prints both stiffness models.

use nalgebra::{Matrix3, Rotation3, Vector3};
use so3_stiffness::csjm::{
    stiffness_at, CsjmGeometry, CsjmSimulator, EquilibriumOptions, PointLoad, Stiffness,
};
use so3_stiffness::{so3, CsjmError};

const PRETENSION: f64 = 80.0; // N, every cable, at the home pose
const TARGET_TILT_STIFFNESS: f64 = 30.0; // N·m/rad, K_xx at home, unloaded

fn print_matrix(name: &str, m: &Matrix3<f64>) {
    println!("{name}");
    for i in 0..3 {
        println!(
            "    [{:>9.3} {:>9.3} {:>9.3}]",
            m[(i, 0)],
            m[(i, 1)],
            m[(i, 2)]
        );
    }
}

fn relative_asymmetry(m: &Matrix3<f64>) -> f64 {
    (m - m.transpose()).norm() / m.norm()
}

fn main() -> Result<(), CsjmError> {
    let geometry = CsjmGeometry::prototype();
    let gravity = PointLoad::prototype_gravity();
    let home = Rotation3::identity();

    // Calibrate the cable stiffness (affine dependence of K on k at fixed tensions).
    let k_xx = |k: f64| -> Result<f64, CsjmError> {
        Ok(
            stiffness_at(&geometry, &home, &[PRETENSION; 6], &[k; 6], &[gravity])?.covariant
                [(0, 0)],
        )
    };
    let (k0, k1) = (k_xx(0.0)?, k_xx(1.0)?);
    let cable_stiffness = (TARGET_TILT_STIFFNESS - k0) / (k1 - k0);
    println!("CSJM prototype (seed IV.A), platform weight 4.82 N at (0, 0, 0.081) m in A, z_B up");
    println!("pre-tension {PRETENSION} N per cable at R = I; cable stiffness k = {cable_stiffness:.1} N/m per cable");
    println!("  (chosen so that the unloaded K_xx at R = I is {TARGET_TILT_STIFFNESS} N·m/rad)\n");

    let sim =
        CsjmSimulator::with_pretension(geometry, [cable_stiffness; 6], [PRETENSION; 6], &home)?
            .with_load(gravity);
    let tau0 = Vector3::new(-0.06, -3.08, 1.07);
    let eq = sim.equilibrium(&tau0, &EquilibriumOptions::default())?;
    let s: Stiffness = eq.stiffness;

    println!(
        "external pre-load ᴬτ₀ = ({:.2}, {:.2}, {:.2}) N·m (seed Table 3)",
        tau0.x, tau0.y, tau0.z
    );
    println!(
        "equilibrium found in {} Newton steps, residual {:.1e} N·m",
        eq.iterations, eq.residual
    );
    print_matrix("pose R₀ = ᴮ_A R:", eq.pose.matrix());
    println!("rotation from home: {:.4} rad", so3::log(&eq.pose).norm());
    println!(
        "cable tensions [N]: {}\n",
        eq.tensions
            .iter()
            .map(|t| format!("{t:.1}"))
            .collect::<Vec<_>>()
            .join(", ")
    );

    print_matrix(
        "Euclidean stiffness K_D = ∂τ/∂ζ [N·m/rad] (earlier CDM model, no connection term):",
        &s.euclidean,
    );
    print_matrix(
        "connection term K_L = −½ hat(τ₀) [N·m/rad]:",
        &s.connection_term(),
    );
    print_matrix(
        "covariant stiffness K = K_D + K_L [N·m/rad] (Levi-Civita, this crate):",
        &s.covariant,
    );
    let p = s.principal_stiffnesses();
    println!(
        "principal stiffnesses of K: {:.3}, {:.3}, {:.3} N·m/rad (stable: {})\n",
        p[0],
        p[1],
        p[2],
        s.is_stable()
    );

    println!("gap between the models:");
    println!(
        "  ‖K − K_D‖_F             = {:.4} N·m/rad ({:.2}% of ‖K‖_F)",
        (s.covariant - s.euclidean).norm(),
        100.0 * (s.covariant - s.euclidean).norm() / s.covariant.norm()
    );
    println!(
        "  max |K_ij − K_D,ij|     = {:.4} N·m/rad",
        (s.covariant - s.euclidean).abs().max()
    );
    println!(
        "  asymmetry ‖K − Kᵀ‖/‖K‖  = {:.2e}  (covariant)",
        relative_asymmetry(&s.covariant)
    );
    println!(
        "  asymmetry ‖K_D − K_Dᵀ‖/‖K_D‖ = {:.2e}  (Euclidean)",
        relative_asymmetry(&s.euclidean)
    );
    let seed = s.paper_eq48b();
    println!(
        "  seed eq. 48b (K_D − hat τ₀): asymmetry {:.2e}, ‖K_48b − K‖_F = {:.4} N·m/rad",
        relative_asymmetry(&seed),
        (seed - s.covariant).norm()
    );

    // What the gap means for a Table-4-sized load increment: the displacement predicted by K.
    let dtau = Vector3::new(2.71, -0.93, 0.74);
    let (Some(z_cov), Some(z_euc)) = (s.covariant.lu().solve(&dtau), s.euclidean.lu().solve(&dtau))
    else {
        println!("stiffness is singular at this pose");
        return Ok(());
    };
    println!(
        "\nfor Δτ = (2.71, −0.93, 0.74) N·m: K⁻¹Δτ and K_D⁻¹Δτ differ by {:.4} rad ({:.2} deg)",
        (z_cov - z_euc).norm(),
        (z_cov - z_euc).norm().to_degrees()
    );
    Ok(())
}
