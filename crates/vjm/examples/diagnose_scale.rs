//! Diagnose wall time and stage times against the number of rows, on seeded campaigns of the
//! bundled Panda (10 loads per pose): nominal torsions only, or with `--tilt` the campaign of
//! `benches/diagnose_scale.py` (its hidden J3x tilt of 4.5e-5 rad/(N·m) and its seed), so that
//! the Rust and the Python figures time the same job.
//! `cargo run --release -p vjm --example diagnose_scale -- [--tilt] 10000 100000`
use std::time::Instant;
use vjm::diagnose::{diagnose_with_progress, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, Effect, TrueModel};
use vjm::SpringAxis;

fn main() {
    let chain = vjm::SerialChain::bundled();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tilt = args.iter().any(|a| a == "--tilt");
    let sizes: Vec<usize> = args
        .iter()
        .filter(|a| *a != "--tilt")
        .map(|a| a.parse().expect("a row count or --tilt"))
        .collect();
    let (truth, seed) = if tilt {
        let t = TrueModel::nominal(7).with_effect(Effect::JointTilt {
            joint: 2,
            axis: SpringAxis::X,
            compliance: 0.45e-4,
        });
        (t, 20261201)
    } else {
        (TrueModel::nominal(7), 7)
    };
    for n in sizes {
        let spec = CampaignSpec {
            n_poses: n / 10,
            wrenches_per_pose: 10,
            seed,
            ..Default::default()
        };
        let t = Instant::now();
        let c = simulate(&chain, &truth, &spec).expect("campaign");
        let sim = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut last = 0.0;
        let mut stages = Vec::new();
        let opts = DiagnoseOptions {
            per_row: false,
            ..Default::default()
        };
        let d = diagnose_with_progress(&chain, &c.dataset, &opts, &mut |p| {
            let now = t.elapsed().as_secs_f64();
            stages.push(format!("{}:{:.2}", p.stage, now - last));
            last = now;
        })
        .expect("diagnosis");
        println!(
            "rows {n}: simulate {sim:.2} s, diagnose {:.2} s ({}), findings {:?}, unexplained {}",
            t.elapsed().as_secs_f64(),
            stages.join(" "),
            d.findings
                .iter()
                .map(|f| format!("{} J{:?}{:?}", f.effect, f.joint, f.axis))
                .collect::<Vec<_>>(),
            d.unexplained
        );
    }
}
