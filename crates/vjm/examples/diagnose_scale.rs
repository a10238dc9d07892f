//! Diagnose wall time and stage times against the number of rows, on seeded campaigns of the
//! bundled Panda (10 loads per pose). `cargo run --release -p vjm --example diagnose_scale -- 10000 100000`
use std::time::Instant;
use vjm::diagnose::{diagnose_with_progress, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, TrueModel};

fn main() {
    let chain = vjm::SerialChain::bundled();
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("a row count"))
        .collect();
    for n in sizes {
        let spec = CampaignSpec {
            n_poses: n / 10,
            wrenches_per_pose: 10,
            seed: 7,
            ..Default::default()
        };
        let t = Instant::now();
        let c = simulate(&chain, &TrueModel::nominal(7), &spec).expect("campaign");
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
            "rows {n}: simulate {sim:.2} s, diagnose {:.2} s ({}), findings {}, unexplained {}",
            t.elapsed().as_secs_f64(),
            stages.join(" "),
            d.findings.len(),
            d.unexplained
        );
    }
}
