//! False findings at large N with a noisy force/torque sensor: the hidden-tilt campaign of
//! `benches/diagnose_scale.py` (J3x tilt of 4.5e-5 rad/(N·m), 20 loads per pose) diagnosed on
//! ten seeds with the testbed's F/T-sensor noise (1 % of full scale, read as 2σ) and on ten
//! without it (the tracker's noise in both; the weights assume what was simulated). It prints
//! each seed's findings and how many seeds name an effect that is not in the truth.
//! `cargo run --release -p vjm --example false_findings_at_scale -- [rows, default 2000000]`
//! (about 2 minutes at 2·10⁶ rows on 2 cores).
use vjm::diagnose::{diagnose, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, Effect, ForceSensorNoise, TrueModel};
use vjm::SpringAxis;

fn main() {
    let rows: usize = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("a row count"))
        .unwrap_or(2_000_000);
    let chain = vjm::SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::JointTilt {
        joint: 2,
        axis: SpringAxis::X,
        compliance: 4.5e-5,
    });
    for accuracy in [0.01, 0.0] {
        let mut false_runs = 0;
        for seed in 12..22u64 {
            let spec = CampaignSpec {
                n_poses: rows / 20,
                wrenches_per_pose: 20,
                seed,
                force_sensor: ForceSensorNoise {
                    relative_accuracy: accuracy,
                    ..Default::default()
                },
                ..Default::default()
            };
            let campaign = simulate(&chain, &truth, &spec).expect("campaign");
            let mut opts = DiagnoseOptions {
                per_row: false,
                ..Default::default()
            };
            if accuracy == 0.0 {
                opts.noise.wrench_sigma = [0.0; 6];
            }
            let d = diagnose(&chain, &campaign.dataset, &opts).expect("diagnosis");
            let named: Vec<String> = d
                .findings
                .iter()
                .map(|f| {
                    let joint = f.joint.map_or(String::new(), |j| format!(" J{j}"));
                    let axis = f.axis.clone().unwrap_or_default();
                    format!(
                        "{}{joint}{axis} (p = {:.1e})",
                        f.effect, f.evidence.selection.f_test.p_value
                    )
                })
                .collect();
            let extra = d
                .findings
                .iter()
                .filter(|f| !(f.effect == "joint_tilt" && f.joint == Some(3)))
                .count();
            if extra > 0 {
                false_runs += 1;
            }
            println!("F/T accuracy {accuracy}, seed {seed}: {}", named.join(", "));
        }
        println!(
            "F/T accuracy {accuracy}: {false_runs} of 10 seeds name an effect not in the truth ({rows} rows)"
        );
    }
}
