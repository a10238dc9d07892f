//! Prints findings, gains, verdict F statistics and the findings' cluster-robust F of diagnose
//! on a fixed set of simulated campaigns (for comparing engines): every effect on the default
//! campaign (40 poses) with four seeds, and each on a campaign of 1500 poses (15 000 rows,
//! above the row count where the passes run in two parts) with one seed. `cargo run --release -p vjm --example compare_diagnose > before.txt`,
//! change the engine, run again and compare the lines.
use vjm::diagnose::{diagnose, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, Effect, TrueModel, NOMINAL_TORSION};
use vjm::SpringAxis;
fn main() {
    let chain = vjm::SerialChain::bundled();
    let truths: Vec<(&str, TrueModel)> = vec![
        ("nominal", TrueModel::nominal(7)),
        (
            "tilt",
            TrueModel::nominal(7).with_effect(Effect::JointTilt {
                joint: 2,
                axis: SpringAxis::X,
                compliance: 1e-4,
            }),
        ),
        ("tilts", TrueModel::with_tilts(&NOMINAL_TORSION, 0.3)),
        (
            "backlash",
            TrueModel::nominal(7).with_effect(Effect::Backlash {
                joint: 3,
                lost_motion: 2e-4,
            }),
        ),
        (
            "bias",
            TrueModel::nominal(7).with_effect(Effect::WrenchBias {
                bias: [2.0, -1.0, 1.5, 0.1, 0.0, 0.05],
            }),
        ),
        (
            "frame",
            TrueModel::nominal(7).with_effect(Effect::FrameMisalignment {
                rotation: [0.02, -0.01, 0.015],
            }),
        ),
        (
            "gnl",
            TrueModel::nominal(7).with_effect(Effect::GeometricNonlinearity),
        ),
    ];
    let runs = (0..4u64)
        .map(|seed| (seed, 40))
        .chain(std::iter::once((4, 1500)));
    for (name, truth) in &truths {
        for (seed, n_poses) in runs.clone() {
            let spec = CampaignSpec {
                seed,
                n_poses,
                ..Default::default()
            };
            let c = simulate(&chain, truth, &spec).unwrap();
            let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
            let f: Vec<String> = d
                .findings
                .iter()
                .map(|f| format!("{}{:?}{:?}", f.effect, f.joint, f.axis))
                .collect();
            // The verdict: lack of fit, then each block's F statistic.
            let blocks: Vec<String> = d
                .verdict
                .blocks
                .iter()
                .map(|b| format!("{}={:.15e}", b.block, b.f_test.f))
                .collect();
            // Each finding's cluster-robust F (reported evidence, not a decision).
            let robust: Vec<String> = d
                .findings
                .iter()
                .map(|f| {
                    f.evidence
                        .selection
                        .cluster_robust
                        .map_or("none".into(), |t| format!("{:.15e}", t.f))
                })
                .collect();
            println!(
                "{name} {seed} poses={n_poses} gain={:.15e} base={:.15e} ext={:.15e} lof={:.15e} {} robust={} unexplained={} findings={}",
                d.gain,
                d.baseline.test_mean_rel_error,
                d.extended.test_mean_rel_error,
                d.verdict.lack_of_fit.f,
                blocks.join(" "),
                robust.join(","),
                d.unexplained,
                f.join(",")
            );
        }
    }
}
