//! Prints findings and gains of diagnose on a fixed set of simulated campaigns (for comparing engines).
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
    for (name, truth) in &truths {
        for seed in 0..4u64 {
            let spec = CampaignSpec {
                seed,
                ..Default::default()
            };
            let c = simulate(&chain, truth, &spec).unwrap();
            let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
            let f: Vec<String> = d
                .findings
                .iter()
                .map(|f| format!("{}{:?}{:?}", f.effect, f.joint, f.axis))
                .collect();
            println!(
                "{name} {seed} gain={:.15e} base={:.15e} ext={:.15e} findings={}",
                d.gain,
                d.baseline.test_mean_rel_error,
                d.extended.test_mean_rel_error,
                f.join(",")
            );
        }
    }
}
