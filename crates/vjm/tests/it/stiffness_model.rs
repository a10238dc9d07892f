//! The stiffness model file and predictions from it: exact predictions through aliases on
//! noise-free testbed data, flagged rows outside the identified space, calibrated standard
//! deviations on noisy data, bitwise round trips, and refusal of edited, stale or foreign files.

#![allow(clippy::needless_range_loop)] // loops over [dx, dy, dz] read clearer indexed

use std::path::{Path, PathBuf};
use vjm::Measurements;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::dataset::{Dataset, SetLabel};
use vjm::stiffness_model::IDENTIFIED_TOL;
use vjm::testbed::{simulate, CampaignSpec, TrueModel};
use vjm::{
    identify, DataSource, IdentifyOptions, Load, ModelError, PointMass, SerialChain,
    StiffnessModel, VirtualJointModel,
};

/// example-robot-data's `ur5_robot.urdf` (the `example-robot-data` wheel installs it under a
/// cmeel prefix); `UR5_URDF` overrides. `None` (test skipped with a message) when absent.
fn ur5_urdf() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("UR5_URDF") {
        return Some(PathBuf::from(p));
    }
    let out = std::process::Command::new("python3")
        .args([
            "-c",
            "import sysconfig; print(sysconfig.get_paths()['purelib'])",
        ])
        .output()
        .ok()?;
    let site = String::from_utf8(out.stdout).ok()?;
    let p = Path::new(site.trim())
        .join("cmeel.prefix/share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf");
    p.is_file().then_some(p)
}

/// A scratch directory of this test binary (removed and recreated per test name).
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vjm-it-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// All 3n springs non-zero: torsions 1e-4…3e-4, tilts 2e-5…6e-5 rad/(N·m), seeded.
fn all_springs(n: usize, seed: u64) -> TrueModel {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let compliance = (0..3 * n)
        .map(|k| {
            if k % 3 == 0 {
                rng.random_range(1e-4..3e-4)
            } else {
                rng.random_range(2e-5..6e-5)
            }
        })
        .collect();
    TrueModel {
        compliance,
        effects: Vec::new(),
    }
}

fn rows_of(data: &Dataset<'_>, set: SetLabel) -> Vec<usize> {
    (0..data.len())
        .filter(|&i| data.set(i) == Some(set))
        .collect()
}

/// Identifies `model` on the training rows of a campaign; the model file's data source is
/// the row count.
fn fit(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: &Dataset<'_>,
    opts: &IdentifyOptions,
) -> (vjm::Identification, StiffnessModel) {
    let train = rows_of(data, SetLabel::Train);
    let n = chain.n_joints();
    let q: Vec<f64> = train.iter().flat_map(|&i| data.q(i).to_vec()).collect();
    let w: Vec<f64> = train.iter().flat_map(|&i| data.wrench(i)).collect();
    let d: Vec<f64> = train.iter().flat_map(|&i| data.displacement(i)).collect();
    assert_eq!(q.len(), train.len() * n);
    let id = identify(chain, model, Measurements::new(&q, &w, &d), opts).unwrap();
    let sm = StiffnessModel::from_identification(
        &id,
        chain,
        model,
        opts,
        DataSource::in_memory(train.len()),
    )
    .unwrap();
    (id, sm)
}

#[test]
fn ur5_noise_free_predictions_are_exact_although_springs_alias() {
    let Some(urdf) = ur5_urdf() else {
        println!("skipped: example-robot-data's ur5_robot.urdf not found (set UR5_URDF)");
        return;
    };
    let chain = SerialChain::from_urdf_file(&urdf, "base_link", "tool0").unwrap();
    assert_eq!(chain.n_joints(), 6);
    let model = VirtualJointModel::extended(6);
    let truth = all_springs(6, 11);
    assert!(truth.compliance.iter().all(|&c| c > 0.0));
    let spec = CampaignSpec {
        noise: false,
        seed: 5,
        ..Default::default()
    };
    let campaign = simulate(&chain, &truth, &spec).unwrap();
    let (id, sm) = fit(
        &chain,
        &model,
        &campaign.dataset,
        &IdentifyOptions::default(),
    );
    // The data cannot separate some springs (e.g. J1y and J2z on parallel axes).
    assert!(id.rank < 18, "rank {}", id.rank);
    assert!(!id.aliases.is_empty());
    let test = rows_of(&campaign.dataset, SetLabel::Test);
    assert!(test.len() >= 20);
    let q: Vec<f64> = test
        .iter()
        .flat_map(|&i| campaign.dataset.q(i).to_vec())
        .collect();
    let w: Vec<f64> = test
        .iter()
        .flat_map(|&i| campaign.applied_wrench[i])
        .collect();
    let pred = sm.predict(&chain, &q, Load::Wrench(&w)).unwrap();
    let mut worst = 0.0f64;
    for (p, &i) in pred.iter().zip(&test) {
        let t = campaign.true_displacement[i];
        let norm = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        assert!(p.identified, "row {i}: excitation {:e}", p.excitation);
        for k in 0..3 {
            worst = worst.max((p.deflection[k] - t[k]).abs() / norm);
        }
        // No rotations in the model: unavailable, not zero.
        assert!(p.deflection[3..].iter().all(|v| v.is_nan()));
    }
    println!(
        "UR5 extended, rank {}/18, aliases {:?}: worst relative error {worst:e} over {} held-out rows",
        id.rank,
        id.alias_labels,
        test.len()
    );
    assert!(worst <= 1e-9, "worst relative error {worst:e}");
    // Setting the aliased springs to 0, as a user would without the model file, is far off.
    let zeroed: Vec<f64> = id.compliance.iter().map(|c| c.unwrap_or(0.0)).collect();
    let i = test[0];
    let naive = vjm::predict_deflection(
        &chain,
        &model,
        &zeroed,
        campaign.dataset.q(i),
        &campaign.applied_wrench[i],
        false,
    )
    .unwrap();
    let t = campaign.true_displacement[i];
    let err =
        ((naive[0] - t[0]).powi(2) + (naive[1] - t[1]).powi(2) + (naive[2] - t[2]).powi(2)).sqrt();
    assert!(err > 1e-3 * (t[0].powi(2) + t[1].powi(2) + t[2].powi(2)).sqrt());
}

#[test]
fn a_pose_outside_what_the_data_saw_is_flagged() {
    // All measurements at one pose under pure forces: the 21 springs are seen only through
    // Σ c_k J_k J_kᵀ (translational columns: a symmetric 3×3, 6 numbers), so another pose excites directions the data could not see.
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = all_springs(7, 4).compliance;
    let q0 = [0.1, -0.4, 0.2, -2.0, 0.3, 1.7, 0.5];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (mut q, mut w, mut d) = (vec![], vec![], vec![]);
    for _ in 0..12 {
        let f: [f64; 6] = std::array::from_fn(|k| {
            if k < 3 {
                rng.random_range(-40.0..40.0)
            } else {
                0.0
            }
        });
        let di = vjm::predict_deflection(&chain, &model, &truth, &q0, &f, false).unwrap();
        q.extend(q0);
        w.extend(f);
        d.extend(&di[..3]);
    }
    let opts = IdentifyOptions::default();
    let id = identify(&chain, &model, Measurements::new(&q, &w, &d), &opts).unwrap();
    assert!(id.rank <= 6, "rank {}", id.rank);
    let sm =
        StiffnessModel::from_identification(&id, &chain, &model, &opts, DataSource::in_memory(12))
            .unwrap();
    let q1 = [0.8, 0.3, -0.5, -1.2, 0.9, 2.4, -0.3];
    let load = [10.0, -20.0, 30.0, 0.0, 0.0, 0.0];
    let both: Vec<f64> = q0.iter().chain(&q1).copied().collect();
    let p = sm
        .predict(&chain, &both, Load::Wrench(&[load, load].concat()))
        .unwrap();
    // Same pose, new load: identified and exact.
    assert!(p[0].identified, "excitation {:e}", p[0].excitation);
    let t0 = vjm::predict_deflection(&chain, &model, &truth, &q0, &load, false).unwrap();
    for k in 0..3 {
        assert!((p[0].deflection[k] - t0[k]).abs() <= 1e-9 * t0[k].abs().max(1e-6));
    }
    // Another pose: flagged, with no band.
    assert!(!p[1].identified);
    assert!(
        p[1].excitation > 1e3 * IDENTIFIED_TOL,
        "{:e}",
        p[1].excitation
    );
    assert!(p[1].stddev.iter().all(|s| s.is_nan()));
}

#[test]
fn payload_wrench_is_gravity_on_a_point_mass_in_the_tip_frame() {
    let (chain, sm, _) = panda_model();
    let q = [0.3, -0.2, 0.1, -1.9, 0.4, 1.5, 0.7];
    let c = [0.05, -0.02, 0.1];
    let payload = Load::Payload(PointMass::new(2.5, c).unwrap());
    let p = sm.predict(&chain, &q, payload).unwrap()[0];
    // Independently: the mass's base-frame position from the tip pose, moment r × F.
    let tip = chain.forward_kinematics(&q).unwrap();
    let at = tip.transform_point(&nalgebra::Point3::from(c)) - tip.translation.vector;
    let f = [0.0, 0.0, -2.5 * 9.80665];
    let m = [
        at.y * f[2] - at.z * f[1],
        at.z * f[0] - at.x * f[2],
        at.x * f[1] - at.y * f[0],
    ];
    let want = [f[0], f[1], f[2], m[0], m[1], m[2]];
    for k in 0..6 {
        assert!(
            (p.wrench[k] - want[k]).abs() < 1e-12,
            "component {k}: {} vs {}",
            p.wrench[k],
            want[k]
        );
    }
    // The payload's prediction is the prediction under its wrench.
    let by_wrench = sm.predict(&chain, &q, Load::Wrench(&p.wrench)).unwrap()[0];
    assert_eq!(by_wrench.deflection[..3], p.deflection[..3]);
    for (mass, com, what) in [
        (
            f64::NAN,
            c,
            "the mass must be a finite number ≥ 0 kg, got NaN",
        ),
        (-1.0, c, "the mass must be a finite number ≥ 0 kg, got -1"),
        (
            1.0,
            [0.0, f64::INFINITY, 0.0],
            "the centre of mass cy must be finite",
        ),
    ] {
        let err = PointMass::new(mass, com).unwrap_err();
        assert!(err.to_string().contains(what), "{err}");
    }
}

/// A small identified Panda model (noise-free campaign, extended model, aliases).
fn panda_model() -> (SerialChain, StiffnessModel, Dataset<'static>) {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 12,
        seed: 9,
        ..Default::default()
    };
    let campaign = simulate(&chain, &all_springs(7, 2), &spec).unwrap();
    let (_, sm) = fit(
        &chain,
        &VirtualJointModel::extended(7),
        &campaign.dataset,
        &IdentifyOptions::default(),
    );
    (chain, sm, campaign.dataset)
}

#[test]
fn save_load_predict_is_bitwise_identical() {
    let (chain, sm, data) = panda_model();
    let dir = scratch("roundtrip");
    let path = dir.join("model.json");
    sm.save(&path).unwrap();
    let back = StiffnessModel::load(&path, &chain).unwrap();
    assert_eq!(back, sm);
    let q = data.q_flat();
    let payload = Load::Payload(PointMass::new(3.0, [0.0, 0.05, 0.08]).unwrap());
    let a = sm.predict(&chain, q, payload).unwrap();
    let b = back.predict(&chain, q, payload).unwrap();
    for (x, y) in a.iter().zip(&b) {
        for k in 0..6 {
            assert_eq!(x.deflection[k].to_bits(), y.deflection[k].to_bits());
            assert_eq!(x.stddev[k].to_bits(), y.stddev[k].to_bits());
        }
    }
    // Saving again gives the same file; no temporary file is left.
    let text = std::fs::read_to_string(&path).unwrap();
    back.save(&path).unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    assert!(text.contains("\"schema\": \"robot-stiffness/vjm-model/1\""));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn edited_stale_and_foreign_model_files_are_refused() {
    let (chain, sm, _) = panda_model();
    let dir = scratch("refused");
    let good = sm.to_json();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    // An edited value (the first compliance, its last digit changed).
    let key = "\"compliance\": [\n";
    let at = good.find(key).unwrap() + key.len();
    let end = at + good[at..].find(',').unwrap();
    let number = good[at..end].trim();
    let last = number.chars().last().unwrap();
    let changed = format!(
        "{}{}",
        &number[..number.len() - 1],
        if last == '1' { '2' } else { '1' }
    );
    let edited = format!(
        "{}{}{}",
        &good[..at],
        good[at..end].replace(number, &changed),
        &good[end..]
    );
    assert_ne!(edited, good);
    let p = write("edited.json", &edited);
    let err = StiffnessModel::load(&p, &chain).unwrap_err();
    assert!(matches!(err, ModelError::Edited { .. }), "{err}");
    assert!(err.to_string().contains("edited.json"), "{err}");
    // Reformatting alone is not an edit.
    let compact: serde_json::Value = serde_json::from_str(&good).unwrap();
    let p = write("compact.json", &compact.to_string());
    assert_eq!(StiffnessModel::load(&p, &chain).unwrap(), sm);
    // An older schema.
    let p = write("old.json", &good.replace("vjm-model/1", "vjm-model/0"));
    let err = StiffnessModel::load(&p, &chain).unwrap_err();
    assert!(matches!(err, ModelError::Schema { .. }), "{err}");
    // Not a model file at all; a missing field.
    let p = write("junk.json", "q1,q2\n1,2\n");
    assert!(matches!(
        StiffnessModel::load(&p, &chain),
        Err(ModelError::Format { .. })
    ));
    let p = write(
        "missing.json",
        &good.replace("\"created_by\"", "\"made_by\""),
    );
    assert!(matches!(
        StiffnessModel::load(&p, &chain),
        Err(ModelError::Format { .. })
    ));
    // Another robot: another tip, another joint count, the same links from another URDF text.
    let p = write("model.json", &good);
    let tcp = SerialChain::bundled_with_tip(vjm::BUNDLED_TCP).unwrap();
    let err = StiffnessModel::load(&p, &tcp).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::OtherRobot {
                what: "the tip link",
                ..
            }
        ),
        "{err}"
    );
    let six =
        SerialChain::from_urdf_str(vjm::BUNDLED_URDF, vjm::BUNDLED_BASE, "panda_link6").unwrap();
    let err = StiffnessModel::load(&p, &six).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::OtherRobot {
                what: "the joint count",
                ..
            }
        ),
        "{err}"
    );
    let other_text = vjm::BUNDLED_URDF.replacen("<robot", "<!-- another revision -->\n<robot", 1);
    let other =
        SerialChain::from_urdf_str(&other_text, vjm::BUNDLED_BASE, vjm::BUNDLED_FLANGE).unwrap();
    let err = StiffnessModel::load(&p, &other).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::OtherRobot {
                what: "the URDF content (SHA-256)",
                ..
            }
        ),
        "{err}"
    );
    // Same joints and links, another geometry, no URDF text to compare: the kinematics hash.
    let moved: Vec<vjm::JointSpec> = chain
        .joints()
        .iter()
        .enumerate()
        .map(|(j, a)| {
            let mut o = *a.origin();
            if j == 3 {
                o.translation.vector.x += 1e-3;
            }
            (a.name().to_string(), o, *a.axis(), a.limits())
        })
        .collect();
    let moved = SerialChain::from_joints(
        vjm::BUNDLED_BASE,
        vjm::BUNDLED_FLANGE,
        moved,
        *chain.tip_offset(),
    )
    .unwrap();
    let err = StiffnessModel::load(&p, &moved).unwrap_err();
    assert!(matches!(err, ModelError::OtherRobot { .. }), "{err}");
    assert!(err.to_string().contains("kinematics"), "{err}");
    // Predicting with another robot is refused too.
    let err = sm
        .predict(&tcp, &[0.0; 7], Load::Wrench(&[0.0; 6]))
        .unwrap_err();
    assert!(matches!(err, ModelError::OtherRobot { .. }), "{err}");
    // A failed save leaves nothing behind and names the file.
    let err = sm.save(dir.join("no-such-dir/model.json")).unwrap_err();
    assert!(err.to_string().contains("no-such-dir/model.json"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_prediction_inputs_name_the_row() {
    let (chain, sm, _) = panda_model();
    let mut q = vec![0.2; 14];
    q[9] = f64::NAN;
    let err = sm
        .predict(&chain, &q, Load::Wrench(&[1.0; 12]))
        .unwrap_err();
    assert!(err.to_string().contains("row 1"), "{err}");
    let err = sm
        .predict(&chain, &[0.2; 13], Load::Wrench(&[1.0; 12]))
        .unwrap_err();
    assert!(
        matches!(err, ModelError::Vjm(vjm::VjmError::ShapeMismatch { .. })),
        "{err}"
    );
    let err = sm
        .predict(&chain, &[0.2; 14], Load::Wrench(&[1.0; 6]))
        .unwrap_err();
    assert!(
        matches!(err, ModelError::Vjm(vjm::VjmError::ShapeMismatch { .. })),
        "{err}"
    );
    let mut w = vec![1.0; 12];
    w[10] = f64::INFINITY;
    let err = sm
        .predict(&chain, &[0.2; 14], Load::Wrench(&w))
        .unwrap_err();
    assert!(
        err.to_string().contains("wrench at row 1, column 4"),
        "{err}"
    );
}

/// The standard deviations are those of the predicted true deflection: over ≥ 200 seeded noisy
/// campaigns (default testbed noise: laser tracker and force sensor), (prediction − true
/// deflection)/stddev on held-out rows falls within ±1 in 63–73 % and within ±2 in 93–97 % of
/// the pooled components, with the robust covariance the model file carries. `COVERAGE_SEEDS`
/// raises the seed count. The identification's own covariance is reported alongside.
#[test]
fn standard_deviations_cover_the_true_deflection() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = all_springs(7, 21);
    let seeds: u64 = std::env::var("COVERAGE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    // [robust, model] × [components, within 1σ, within 2σ]
    let mut count = [[0usize; 3]; 2];
    for seed in 0..seeds {
        let spec = CampaignSpec {
            n_poses: 20,
            seed: 1000 + seed,
            ..Default::default()
        };
        let campaign = simulate(&chain, &truth, &spec).unwrap();
        let (_, plain) = fit(
            &chain,
            &model,
            &campaign.dataset,
            &IdentifyOptions::default(),
        );
        let robust = robust(plain.clone(), &chain, &campaign.dataset);
        assert_eq!(robust.estimate().covariance_method, "robust");
        let test = rows_of(&campaign.dataset, SetLabel::Test);
        let q: Vec<f64> = test
            .iter()
            .flat_map(|&i| campaign.dataset.q(i).to_vec())
            .collect();
        let w: Vec<f64> = test
            .iter()
            .flat_map(|&i| campaign.applied_wrench[i])
            .collect();
        for (c, sm) in count.iter_mut().zip([&robust, &plain]) {
            for (p, &i) in sm
                .predict(&chain, &q, Load::Wrench(&w))
                .unwrap()
                .iter()
                .zip(&test)
            {
                assert!(p.identified);
                for k in 0..3 {
                    let z = (p.deflection[k] - campaign.true_displacement[i][k]) / p.stddev[k];
                    c[0] += 1;
                    c[1] += (z.abs() <= 1.0) as usize;
                    c[2] += (z.abs() <= 2.0) as usize;
                }
            }
        }
    }
    let pct = |c: [usize; 3], k: usize| 100.0 * c[k] as f64 / c[0] as f64;
    println!(
        "coverage over {seeds} seeds, {} components: robust 1σ {:.2} %, 2σ {:.2} %; model 1σ {:.2} %, 2σ {:.2} %",
        count[0][0],
        pct(count[0], 1),
        pct(count[0], 2),
        pct(count[1], 1),
        pct(count[1], 2)
    );
    assert!(
        (63.0..=73.0).contains(&pct(count[0], 1)),
        "1σ coverage {}",
        pct(count[0], 1)
    );
    assert!(
        (93.0..=97.0).contains(&pct(count[0], 2)),
        "2σ coverage {}",
        pct(count[0], 2)
    );
}

fn robust(sm: StiffnessModel, chain: &SerialChain, data: &Dataset<'_>) -> StiffnessModel {
    let train = rows_of(data, SetLabel::Train);
    let q: Vec<f64> = train.iter().flat_map(|&i| data.q(i).to_vec()).collect();
    let w: Vec<f64> = train.iter().flat_map(|&i| data.wrench(i)).collect();
    let d: Vec<f64> = train.iter().flat_map(|&i| data.displacement(i)).collect();
    sm.with_robust_covariance(chain, Measurements::new(&q, &w, &d))
        .unwrap()
}

/// `predict` and `predict_sag` run in fixed-size row blocks on every core: on 2 500 rows
/// (three blocks) the values are bit for bit those of a one-thread pool, of a four-thread
/// pool and of each row predicted alone, the columns' (`predict_columns`,
/// `predict_sag_columns`) those of the records, and a bad row in the last block is the error
/// reported, also when a later row is bad too.
#[test]
fn batched_predictions_do_not_depend_on_threads_or_blocks() {
    let (chain, extended, data) = panda_model();
    // The traditional model's compliances are all ≥ 0: its sag is the exact equilibrium
    // (the extended one's aliases make it the first-order part).
    let (_, traditional) = fit(
        &chain,
        &VirtualJointModel::traditional(7),
        &data,
        &IdentifyOptions::default(),
    );
    for sm in [&extended, &traditional] {
        batched_model_check(&chain, sm);
    }
}

fn batched_model_check(chain: &SerialChain, sm: &StiffnessModel) {
    use vjm::gravity::Gravity;
    let chain = chain.clone();
    let rows = 2_500;
    let q = crate::strategies::random_configurations(&chain, rows, 41);
    let w = crate::strategies::random_wrenches(rows, 42);
    let g = Gravity::default();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            (
                sm.predict(&chain, &q, Load::Wrench(&w)).unwrap(),
                sm.predict_sag(&chain, &q, &g, None).unwrap(),
            )
        })
    };
    let (one, one_sag) = run(1);
    let (four, four_sag) = run(4);
    let bits = |p: &vjm::Prediction| -> Vec<u64> {
        p.deflection
            .iter()
            .chain(&p.stddev)
            .chain(&p.wrench)
            .chain([&p.excitation])
            .map(|v| v.to_bits())
            .chain([p.identified as u64])
            .collect()
    };
    assert_eq!(one.len(), rows);
    assert_eq!(one_sag.len(), rows);
    for i in 0..rows {
        assert_eq!(bits(&one[i]), bits(&four[i]), "predict row {i}");
        assert_eq!(bits(&one_sag[i]), bits(&four_sag[i]), "predict_sag row {i}");
        assert!(
            one[i].deflection[..3].iter().all(|v| v.is_finite()),
            "row {i}"
        );
    }
    for i in [0, 1023, 1024, 2047, 2048, rows - 1] {
        let qi = &q[7 * i..7 * i + 7];
        let alone = sm
            .predict(&chain, qi, Load::Wrench(&w[6 * i..6 * i + 6]))
            .unwrap();
        let alone_sag = sm.predict_sag(&chain, qi, &g, None).unwrap();
        assert_eq!(bits(&alone[0]), bits(&one[i]), "predict row {i} alone");
        assert_eq!(
            bits(&alone_sag[0]),
            bits(&one_sag[i]),
            "predict_sag row {i} alone"
        );
    }
    // The columns (`predict_columns`, `predict_sag_columns`) hold the records' values bit for
    // bit, weightless, under gravity and with a payload, on one thread and on four.
    let payload = vjm::PointMass::new(1.5, [0.01, -0.02, 0.05]).unwrap();
    let under_gravity = sm
        .predict_under_gravity(&chain, &q, Load::Wrench(&w), &g)
        .unwrap();
    let with_payload = sm.predict_sag(&chain, &q, &g, Some(&payload)).unwrap();
    for threads in [1, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let cases = [
                (
                    "predict",
                    &one,
                    sm.predict_columns(&chain, &q, Load::Wrench(&w), None),
                ),
                (
                    "predict under gravity",
                    &under_gravity,
                    sm.predict_columns(&chain, &q, Load::Wrench(&w), Some(&g)),
                ),
                (
                    "predict_sag",
                    &one_sag,
                    sm.predict_sag_columns(&chain, &q, &g, None),
                ),
                (
                    "predict_sag with a payload",
                    &with_payload,
                    sm.predict_sag_columns(&chain, &q, &g, Some(&payload)),
                ),
            ];
            for (what, records, columns) in cases {
                let columns = columns.unwrap();
                assert_eq!(columns.rows(), rows, "{what}");
                for (i, record) in records.iter().enumerate() {
                    assert_eq!(
                        bits(&columns.row(i)),
                        bits(record),
                        "{what} row {i}, {threads} threads"
                    );
                }
            }
        });
    }
    let mut bad = q.clone();
    bad[7 * 2100 + 3] = f64::NAN;
    bad[7 * 2400] = f64::INFINITY;
    for threads in [1, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let errors = pool.install(|| {
            [
                sm.predict(&chain, &bad, Load::Wrench(&w)).unwrap_err(),
                sm.predict_sag(&chain, &bad, &g, None).unwrap_err(),
                sm.predict_columns(&chain, &bad, Load::Wrench(&w), None)
                    .unwrap_err(),
                sm.predict_sag_columns(&chain, &bad, &g, None).unwrap_err(),
            ]
        });
        for e in errors {
            assert!(e.to_string().contains("row 2100"), "{threads} threads: {e}");
        }
    }
}
