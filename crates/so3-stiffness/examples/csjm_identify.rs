//! Identify the stiffness of a simulated CSJM the way the seed did (seed 000, section IV):
//! a seed-like virtual campaign, first- and second-order fits, and one verification pose.
//!
//! Run: `cargo run -p so3-stiffness --example csjm_identify`
//! (`-- --sweep` also prints the first- vs second-order error table over seeds 1–8 quoted in
//! `docs/csjm-identification.md`). Writes no file.
//!
//! The campaign: the seed prototype posed at the seed's R₀ under Table 3's pre-load
//! ᴬτ₀ = (−0.06, −3.08, 1.07) N·m, tilt stiffness calibrated to Table 3, 85 counterweight-like
//! load increments (every component in the sense of Table 4's increments, ‖Δτ‖ ≤ 3 N·m),
//! laser-tracker pose noise (Table 1) and F/T moment noise (Table 2). All moments are external
//! moments on the platform about O, components in the platform frame A (N·m); stiffnesses in
//! N·m/rad; angles in rad.

use nalgebra::{Matrix3, Vector3};
use so3_stiffness::csjm::EquilibriumOptions;
use so3_stiffness::identification::campaign::{
    paper_like_simulator, simulate_campaign, CampaignConfig, MomentNoise, TrackerNoise,
};
use so3_stiffness::identification::{identify, FitOptions, FitOrder, StiffnessEstimate};
use so3_stiffness::so3;

/// Largest load increment of the campaign, N·m (Table 4's increments reach 3.1 N·m).
const MAX_INCREMENT: f64 = 3.0;
/// RNG seed of the campaign shown.
const SEED: u64 = 1;

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

fn relative_error(estimate: &Matrix3<f64>, truth: &Matrix3<f64>) -> f64 {
    (estimate - truth).norm() / truth.norm()
}

fn report(order: &str, e: &StiffnessEstimate, truth: &Matrix3<f64>) {
    println!(
        "\n== {order}-order fit: N = {} increments, dof {} ==",
        e.n, e.dof
    );
    print_matrix("K = K_D − ½hat(τ₀) (N·m/rad, frame A at R₀)", &e.k);
    print_matrix("standard errors of K (N·m/rad)", &e.k_stderr);
    print_matrix("K − K_true (N·m/rad)", &(e.k - truth));
    println!(
        "relative Frobenius error ‖K − K_true‖/‖K_true‖ = {:.4}; cond(Ω) = {:.1}; \
         residual RMS (N·m) = ({:.3}, {:.3}, {:.3})",
        relative_error(&e.k, truth),
        e.omega_condition,
        e.residual_rms.x,
        e.residual_rms.y,
        e.residual_rms.z
    );
}

/// First- and second-order errors over seeds 1–8, noisy and noise-free, ≤ 1 and ≤ 3 N·m.
fn sweep() -> Result<(), Box<dyn std::error::Error>> {
    let cables = paper_like_simulator()?;
    println!("\n| max ‖Δτ‖ (N·m) | noise | first order, seeds 1–8 | second order, seeds 1–8 |");
    println!("|---|---|---|---|");
    for max_increment in [1.0, 3.0] {
        for noisy in [false, true] {
            let (mut first, mut second) = (Vec::new(), Vec::new());
            for seed in 1..=8 {
                let mut config = CampaignConfig::paper_like(max_increment, seed);
                if !noisy {
                    config.schedule.tracker = TrackerNoise::none();
                    config.schedule.moment_noise = MomentNoise::none();
                }
                let campaign = simulate_campaign(&cables, &config)?;
                let truth = campaign.true_stiffness.covariant;
                for (order, out) in [
                    (FitOrder::First, &mut first),
                    (FitOrder::Second, &mut second),
                ] {
                    let e = identify(&campaign.dataset, &FitOptions::with_order(order))?;
                    out.push(format!("{:.4}", relative_error(&e.k, &truth)));
                }
            }
            println!(
                "| {max_increment} | {} | {} | {} |",
                if noisy { "Tables 1–2" } else { "none" },
                first.join(", "),
                second.join(", ")
            );
        }
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cables = paper_like_simulator()?;
    let config = CampaignConfig::paper_like(MAX_INCREMENT, SEED);
    let campaign = simulate_campaign(&cables, &config)?;
    let truth = campaign.true_stiffness.covariant;
    let r0 = campaign.dataset.reference().orientation;
    println!(
        "seed-like campaign: {} increments, ‖Δτ‖ ≤ {MAX_INCREMENT} N·m, pre-load τ₀ = ({:.2}, {:.2}, {:.2}) N·m, seed {SEED}",
        config.schedule.increments, config.schedule.preload.x, config.schedule.preload.y, config.schedule.preload.z
    );
    println!(
        "cable stiffness k = {:.0} N/m, tensions at R₀ (N): {:.1?}",
        cables.cables()[0].stiffness,
        cables.tensions(&campaign.true_r0)?
    );
    print_matrix(
        "true K at R₀ (simulator's covariant stiffness, N·m/rad)",
        &truth,
    );

    let first = identify(&campaign.dataset, &FitOptions::with_order(FitOrder::First))?;
    let second = identify(&campaign.dataset, &FitOptions::with_order(FitOrder::Second))?;
    report("first", &first, &truth);
    report("second", &second, &truth);

    // Verification (eqs. 61–65) on Table 4's case-1 load increment: the simulator gives the
    // actual pose, the estimates predict it from R₀ (with K_D, see docs/seed-000-tables.md §3).
    let dtau = Vector3::new(2.71, -0.93, 0.74);
    let actual = cables
        .equilibrium(
            &(config.schedule.preload + dtau),
            &EquilibriumOptions::starting_at(campaign.true_r0),
        )?
        .pose;
    println!(
        "\nverification: Δτ = ({:.2}, {:.2}, {:.2}) N·m (Table 4, case 1) moves the platform by {:.4} rad",
        dtau.x,
        dtau.y,
        dtau.z,
        so3::distance(&campaign.true_r0, &actual)
    );
    for (order, e) in [("first", &first), ("second", &second)] {
        let case = e.verify(&r0, &dtau, &actual)?;
        println!(
            "  {order}-order: Δζ_est = ({:.4}, {:.4}, {:.4}) rad, E_θ = {:.2e} rad",
            case.zeta_est.x, case.zeta_est.y, case.zeta_est.z, case.e_theta
        );
    }

    if std::env::args().any(|a| a == "--sweep") {
        sweep()?;
    }
    Ok(())
}
