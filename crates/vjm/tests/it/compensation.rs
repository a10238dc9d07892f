//! Compensation checked against the testbed's own kinematics (`testbed::kinematics`), which
//! shares no code with the crate's Jacobian, K_C or the compensation's deflection.

use vjm::testbed::kinematics::deflected_tip;
use vjm::testbed::{simulate, Campaign, CampaignSpec, Effect, TrueModel};
use vjm::Measurements;
use vjm::{
    compensate, compensate_in_place, identify, predict_deflection, CompensateOptions,
    CompensatedRow, CompensationBuffers, CompensationStatus, CompensationTargets,
    CompensationWorkspace, IdentifyOptions, Load, PointMass, SerialChain, VirtualJointModel,
};

const G: f64 = vjm::stiffness_model::GRAVITY;

/// A Panda-class truth with all 21 springs non-zero: torsions from the testbed's nominal
/// values, tilts 0.3–0.6 of them.
fn extended_truth() -> TrueModel {
    let mut t = TrueModel::nominal(7);
    for j in 0..7 {
        t.compliance[3 * j + 1] = 0.3 * t.compliance[3 * j] * (1.0 + 0.1 * j as f64);
        t.compliance[3 * j + 2] = 0.6 * t.compliance[3 * j] / (1.0 + 0.1 * j as f64);
    }
    t
}

fn noise_free(n_poses: usize, seed: u64) -> CampaignSpec {
    CampaignSpec {
        n_poses,
        wrenches_per_pose: 2,
        noise: false,
        seed,
        ..Default::default()
    }
}

/// True remaining tip error over the true deflection, per row, at targets `q_comp` for the
/// rows `rows` of `campaign`: both from the testbed's truth and kinematics.
fn true_ratios(
    chain: &SerialChain,
    truth: &TrueModel,
    campaign: &Campaign,
    rows: &[usize],
    q_comp: &[f64],
) -> Vec<f64> {
    let n = chain.n_joints();
    let zero = vec![0.0; 3 * n];
    rows.iter()
        .enumerate()
        .map(|(k, &i)| {
            let qn = campaign.dataset.q(i);
            let qc = &q_comp[k * n..(k + 1) * n];
            let w = campaign.applied_wrench[i];
            let target = deflected_tip(chain, qn, &zero);
            let (d0, _) = truth.displacement(chain, qn, &w);
            let (d, tip) = truth.displacement(chain, qc, &w);
            ((tip + d) - target).norm() / d0.norm()
        })
        .collect()
}

fn rows_of(campaign: &Campaign, rows: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let mut q = Vec::new();
    let mut wrench = Vec::new();
    for &i in rows {
        q.extend_from_slice(campaign.dataset.q(i));
        wrench.extend_from_slice(&campaign.applied_wrench[i]);
    }
    (q, wrench)
}

/// Default options with one change (the struct is non-exhaustive).
fn with_opts(change: impl FnOnce(&mut CompensateOptions)) -> CompensateOptions {
    let mut o = CompensateOptions::default();
    change(&mut o);
    o
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

/// With the true compliances of a linear truth, the loaded tip lands on the nominal point to
/// far better than 2 % of the deflection (the criterion), as measured by the testbed.
#[test]
fn true_linear_model_cancels_the_deflection() {
    let chain = SerialChain::bundled();
    let truth = extended_truth();
    let campaign = simulate(&chain, &truth, &noise_free(30, 11)).unwrap();
    let rows: Vec<usize> = (0..campaign.dataset.len()).collect();
    let (q, loads) = rows_of(&campaign, &rows);
    let opts = with_opts(|o| o.with_kc = false);
    let model = VirtualJointModel::extended(7);
    let out = compensate(
        &chain,
        &model,
        &truth.compliance,
        &q,
        Load::Wrench(&loads),
        &opts,
    )
    .unwrap();
    for (i, r) in out.rows.iter().enumerate() {
        assert_eq!(r.status, CompensationStatus::Converged, "row {i}: {r:?}");
        assert!(r.position_error <= 1e-9, "row {i}: {r:?}");
        assert!(r.iterations <= 10, "row {i}: {r:?}");
    }
    let ratios = true_ratios(&chain, &truth, &campaign, &rows, &out.q);
    println!(
        "true linear model: worst remaining/uncompensated = {:.2e}",
        max(&ratios)
    );
    assert!(max(&ratios) <= 0.02, "{ratios:?}");
    // The residual is the model's: far below the criterion.
    assert!(max(&ratios) <= 1e-5, "{ratios:?}");
}

/// A truth with geometric non-linearity (equilibrium in the deflected configuration): with K_C
/// the compensation stays within 2 %; and K_C is what closes most of the gap left without it.
#[test]
fn true_model_with_kc_cancels_geometric_nonlinearity() {
    let chain = SerialChain::bundled();
    let truth = extended_truth().with_effect(Effect::GeometricNonlinearity);
    let spec = CampaignSpec {
        force_range: (60.0, 80.0),
        ..noise_free(20, 12)
    };
    let campaign = simulate(&chain, &truth, &spec).unwrap();
    let rows: Vec<usize> = (0..campaign.dataset.len()).collect();
    let (q, loads) = rows_of(&campaign, &rows);
    let model = VirtualJointModel::extended(7);
    let mut worst = [0.0; 2];
    for (k, with_kc) in [true, false].into_iter().enumerate() {
        let opts = with_opts(|o| o.with_kc = with_kc);
        let out = compensate(
            &chain,
            &model,
            &truth.compliance,
            &q,
            Load::Wrench(&loads),
            &opts,
        )
        .unwrap();
        assert!(out
            .rows
            .iter()
            .all(|r| r.status == CompensationStatus::Converged));
        worst[k] = max(&true_ratios(&chain, &truth, &campaign, &rows, &out.q));
    }
    println!(
        "geometric truth: worst remaining/uncompensated with K_C {:.2e}, without {:.2e}",
        worst[0], worst[1]
    );
    assert!(worst[0] <= 0.02, "{worst:?}");
    assert!(worst[0] < worst[1], "{worst:?}");
}

/// A model identified from a default noisy 40-pose campaign compensates the held-out poses
/// to within 25 % of their deflection (criterion on the mean; the worst row is printed).
#[test]
fn identified_model_compensates_held_out_poses() {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::JointTilt {
        joint: 1,
        axis: vjm::SpringAxis::X,
        compliance: 6e-5,
    });
    let campaign = simulate(&chain, &truth, &CampaignSpec::default()).unwrap();
    let ds = &campaign.dataset;
    let (train, test): (Vec<usize>, Vec<usize>) =
        (0..ds.len()).partition(|&i| ds.set(i) != Some(vjm::dataset::SetLabel::Test));
    assert!(!test.is_empty());
    let model = VirtualJointModel::extended(7);
    let (mut q, mut f, mut d) = (vec![], vec![], vec![]);
    for &i in &train {
        q.extend_from_slice(ds.q(i));
        f.extend_from_slice(&ds.wrench(i));
        d.extend_from_slice(&ds.displacement(i));
    }
    let id = identify(
        &chain,
        &model,
        Measurements::new(&q, &f, &d),
        &IdentifyOptions::default(),
    )
    .unwrap();
    let compliance = id.solution.solution.clone();
    let (qt, loads) = rows_of(&campaign, &test);
    let out = compensate(
        &chain,
        &model,
        &compliance,
        &qt,
        Load::Wrench(&loads),
        &Default::default(),
    )
    .unwrap();
    assert!(out
        .rows
        .iter()
        .all(|r| r.status == CompensationStatus::Converged));
    let ratios = true_ratios(&chain, &truth, &campaign, &test, &out.q);
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    println!(
        "identified model, {} held-out rows: mean remaining/uncompensated {:.1} %, worst {:.1} %",
        ratios.len(),
        100.0 * mean,
        100.0 * max(&ratios)
    );
    assert!(mean <= 0.25, "{mean}");
}

/// The predicted remaining error is the model's own: re-evaluated at the corrected targets
/// through the dense path (`predict_deflection`, LU on I − C·K_C, and the chain's FK) the
/// loaded tip sits on the nominal point. This checks the O(m) K_C·θ product of the iteration.
#[test]
fn predicted_remaining_error_agrees_with_predict_deflection() {
    let chain = SerialChain::bundled();
    let truth = extended_truth();
    let campaign = simulate(&chain, &truth, &noise_free(8, 13)).unwrap();
    let rows: Vec<usize> = (0..campaign.dataset.len()).collect();
    let (q, loads) = rows_of(&campaign, &rows);
    let model = VirtualJointModel::extended(7);
    // Large compliances so that K_C changes the deflection by percents.
    let c: Vec<f64> = truth.compliance.iter().map(|c| 20.0 * c).collect();
    for match_orientation in [false, true] {
        let opts = with_opts(|o| o.match_orientation = match_orientation);
        let out = compensate(&chain, &model, &c, &q, Load::Wrench(&loads), &opts).unwrap();
        for (k, r) in out.rows.iter().enumerate() {
            assert_eq!(r.status, CompensationStatus::Converged, "{r:?}");
            let qn = &q[7 * k..7 * k + 7];
            let qc = &out.q[7 * k..7 * k + 7];
            let w: [f64; 6] = loads[6 * k..6 * k + 6].try_into().unwrap();
            let d = predict_deflection(&chain, &model, &c, qc, &w, true).unwrap();
            let t0 = chain.forward_kinematics(qn).unwrap();
            let t1 = chain.forward_kinematics(qc).unwrap();
            let p = t1.translation.vector + nalgebra::Vector3::new(d[0], d[1], d[2]);
            let err = (p - t0.translation.vector).norm();
            assert!(
                err <= 2e-9,
                "row {k}: {err:e} (deflection {:e})",
                r.deflection
            );
            let d_nom = predict_deflection(&chain, &model, &c, qn, &w, true).unwrap();
            let d_nom = nalgebra::Vector3::new(d_nom[0], d_nom[1], d_nom[2]).norm();
            assert!((r.deflection - d_nom).abs() <= 1e-12 * d_nom);
            if match_orientation {
                assert!(r.rotation_error <= 1e-9, "{r:?}");
                let rot = nalgebra::Rotation3::new(nalgebra::Vector3::new(d[3], d[4], d[5]))
                    * t1.rotation.to_rotation_matrix();
                let e =
                    stiffness_core::so3::log(&(rot * t0.rotation.to_rotation_matrix().inverse()))
                        .norm();
                assert!(e <= 2e-9, "row {k}: orientation {e:e}");
            }
        }
    }
}

/// A payload's wrench: weight along −z of the base, moment of the weight at the centre of mass
/// (tip frame) about the tip point; compensating under it equals compensating under that
/// wrench when the centre of mass is on the tip point.
#[test]
fn payload_load() {
    let pm = PointMass::new(2.0, [0.1, 0.0, 0.0]).unwrap();
    let w = pm.wrench_at(&nalgebra::Matrix3::identity());
    // (0.1, 0, 0) × (0, 0, −2g) = (0, 0.2 g, 0).
    let expect = [0.0, 0.0, -2.0 * G, 0.0, 0.2 * G, 0.0];
    for k in 0..6 {
        assert!((w[k] - expect[k]).abs() < 1e-12, "{w:?}");
    }
    // A quarter turn about z carries the centre of mass to +y.
    let rz = nalgebra::Rotation3::from_axis_angle(
        &nalgebra::Vector3::z_axis(),
        std::f64::consts::FRAC_PI_2,
    );
    let w = pm.wrench_at(rz.matrix());
    assert!(
        (w[3] + 0.2 * G).abs() < 1e-12 && w[4].abs() < 1e-12,
        "{w:?}"
    );

    let chain = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [1e-4; 7];
    let q = [0.2, -0.3, 0.1, -2.0, 0.3, 1.8, 0.8];
    let opts = CompensateOptions::default();
    let on_tip = Load::Payload(PointMass::new(5.0, [0.0; 3]).unwrap());
    let a = compensate(&chain, &model, &c, &q, on_tip, &opts).unwrap();
    let weight = [0.0, 0.0, -5.0 * G, 0.0, 0.0, 0.0];
    let b = compensate(&chain, &model, &c, &q, Load::Wrench(&weight), &opts).unwrap();
    assert_eq!(a, b);
    // An offset centre of mass: converges too and deflects differently.
    let offset = Load::Payload(PointMass::new(5.0, [0.0, 0.0, 0.2]).unwrap());
    let off = compensate(&chain, &model, &c, &q, offset, &opts).unwrap();
    assert_eq!(off.rows[0].status, CompensationStatus::Converged);
    assert!(off.rows[0].position_error <= 1e-9);
    assert!((off.rows[0].deflection - a.rows[0].deflection).abs() > 1e-6 * a.rows[0].deflection);
}

/// The zero pose is singular for the pose task: reported per row, no panic, targets finite;
/// the other rows are unaffected.
#[test]
fn singular_rows_are_reported() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [1e-4; 7];
    let good = [0.2, -0.3, 0.1, -2.0, 0.3, 1.8, 0.8];
    let mut q = vec![0.0; 7];
    q.extend_from_slice(&good);
    let w = [0.0, 0.0, -50.0, 0.0, 0.0, 0.0];
    let loads: Vec<f64> = w.iter().chain(&w).copied().collect();
    // At q = 0 joints 1, 3, 5 and 7 are coaxial: the pose task (6 rows) loses rank.
    let pose = with_opts(|o| o.match_orientation = true);
    let out = compensate(&chain, &model, &c, &q, Load::Wrench(&loads), &pose).unwrap();
    assert_eq!(
        out.rows[0].status,
        CompensationStatus::NearSingular,
        "{:?}",
        out.rows[0]
    );
    assert!(out.q.iter().all(|x| x.is_finite()));
    assert_eq!(out.rows[1].status, CompensationStatus::Converged);
    let single = compensate(&chain, &model, &c, &good, Load::Wrench(&w), &pose).unwrap();
    assert_eq!(single.q, out.q[7..]);
}

/// A target at a joint limit that the correction must cross is reported with that joint.
#[test]
fn targets_outside_the_limits_are_reported() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [1e-4; 7];
    let (lo, _) = chain.limits()[3];
    let q = [0.2, -0.3, 0.1, lo, 0.3, 1.8, 0.8];
    // Loads of both signs along x and z: some push joint 4 out.
    let mut seen = false;
    for s in [1.0, -1.0] {
        for w in [
            [0.0, 0.0, 80.0 * s, 0.0, 0.0, 0.0],
            [80.0 * s, 0.0, 0.0, 0.0, 0.0, 0.0],
        ] {
            let out = compensate(
                &chain,
                &model,
                &c,
                &q,
                Load::Wrench(&w),
                &Default::default(),
            )
            .unwrap();
            let r = out.rows[0];
            if out.q[3] < lo {
                assert_eq!(r.status, CompensationStatus::OutsideLimits, "{r:?}");
                assert_eq!(r.limit_joint, Some(3));
                seen = true;
            }
            let unchecked = with_opts(|o| o.check_limits = false);
            let out = compensate(&chain, &model, &c, &q, Load::Wrench(&w), &unchecked).unwrap();
            assert_eq!(out.rows[0].status, CompensationStatus::Converged);
        }
    }
    assert!(seen, "no load pushed joint 4 beyond its limit");
}

/// The in-place call with one workspace gives the same bits as the allocating call, row by row.
#[test]
fn in_place_equals_allocating() {
    let chain = SerialChain::bundled();
    let truth = extended_truth();
    let campaign = simulate(&chain, &truth, &noise_free(5, 14)).unwrap();
    let rows: Vec<usize> = (0..campaign.dataset.len()).collect();
    let (q, loads) = rows_of(&campaign, &rows);
    let model = VirtualJointModel::extended(7);
    let opts = CompensateOptions::default();
    let all = compensate(
        &chain,
        &model,
        &truth.compliance,
        &q,
        Load::Wrench(&loads),
        &opts,
    )
    .unwrap();
    let mut ws = CompensationWorkspace::new(&chain, &model).unwrap();
    let mut qo = vec![0.0; 7];
    let mut ro = vec![all.rows[0]; 1];
    for i in 0..rows.len() {
        let w = Load::Wrench(&loads[6 * i..6 * i + 6]);
        let targets = CompensationTargets {
            q_nominal: &q[7 * i..7 * i + 7],
            load: w,
        };
        let out = CompensationBuffers {
            q: &mut qo,
            rows: &mut ro,
        };
        compensate_in_place(
            &chain,
            &model,
            &truth.compliance,
            targets,
            &opts,
            &mut ws,
            out,
        )
        .unwrap();
        assert_eq!(qo, all.q[7 * i..7 * i + 7]);
        assert_eq!(ro[0], all.rows[i]);
    }
}

/// Bad input fails the whole call with one message naming the row and what is wrong, and
/// writes nothing into the caller's buffers.
#[test]
fn bad_input_names_the_cause() {
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [1e-4; 7];
    let q = [
        0.2, -0.3, 0.1, -2.0, 0.3, 1.8, 0.8, 0.2, -0.3, 0.1, -2.0, 0.3, 1.8, 0.8,
    ];
    let ok = [
        0.0, 0.0, -10.0, 0.0, 0.0, 0.0, 0.0, 0.0, -10.0, 0.0, 0.0, 0.0,
    ];
    let err = |q: &[f64], w: &[f64], c: &[f64]| {
        compensate(&chain, &model, c, q, Load::Wrench(w), &Default::default())
            .unwrap_err()
            .to_string()
    };
    let e = PointMass::new(f64::NAN, [0.0; 3]).unwrap_err().to_string();
    assert!(e.contains("mass") && e.contains("NaN"), "{e}");
    let e = err(&q[..13], &ok, &c);
    assert!(e.contains("q_nominal"), "{e}");
    let e = err(&q, &ok[..6], &c);
    assert!(e.contains("wrench") && e.contains("expected 12"), "{e}");
    let mut qn = q;
    qn[9] = f64::INFINITY;
    let e = err(&qn, &ok, &c);
    assert!(
        e.contains("q") && e.contains("row 1") && e.contains("column 2"),
        "{e}"
    );
    let e = err(&q, &ok, &c[..6]);
    assert!(e.contains("compliance") && e.contains("expected 7"), "{e}");
    let mut nan_w = ok;
    nan_w[7] = f64::NAN;
    let e = err(&q, &nan_w, &c);
    assert!(
        e.contains("wrench") && e.contains("row 1") && e.contains("column 1"),
        "{e}"
    );
    let bad_opts = with_opts(|o| o.max_iterations = 0);
    let e = compensate(&chain, &model, &c, &q, Load::Wrench(&ok), &bad_opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("max_iterations"), "{e}");
    // Nothing written on error.
    let mut ws = CompensationWorkspace::new(&chain, &model).unwrap();
    let mut qo = vec![7.0; 14];
    let blank = CompensatedRow {
        status: CompensationStatus::NotConverged,
        iterations: 99,
        position_error: 1.0,
        rotation_error: 1.0,
        deflection: 1.0,
        rotation_deflection: 1.0,
        inverse_condition: 1.0,
        limit_joint: None,
    };
    let mut ro = vec![blank; 2];
    let r = compensate_in_place(
        &chain,
        &model,
        &c,
        CompensationTargets {
            q_nominal: &q,
            load: Load::Wrench(&nan_w),
        },
        &Default::default(),
        &mut ws,
        CompensationBuffers {
            q: &mut qo,
            rows: &mut ro,
        },
    );
    assert!(r.is_err());
    assert!(qo.iter().all(|x| *x == 7.0));
    assert!(ro.iter().all(|r| *r == blank));
    // A workspace for another model is refused.
    let other = VirtualJointModel::extended(7);
    let mut ws2 = CompensationWorkspace::new(&chain, &other).unwrap();
    let r = compensate_in_place(
        &chain,
        &model,
        &c,
        CompensationTargets {
            q_nominal: &q,
            load: Load::Wrench(&ok),
        },
        &Default::default(),
        &mut ws2,
        CompensationBuffers {
            q: &mut qo,
            rows: &mut ro,
        },
    );
    assert!(r.is_err());
}

/// Through a saved model file: the same targets as with the identification's compliance vector,
/// and a model file is refused for another robot (the flange vs the TCP tip).
#[test]
fn model_file_compensation() {
    use vjm::stiffness_model::{DataSource, StiffnessModel};
    let chain = SerialChain::bundled();
    let truth = extended_truth();
    let campaign = simulate(&chain, &truth, &noise_free(12, 15)).unwrap();
    let ds = &campaign.dataset;
    let model = VirtualJointModel::extended(7);
    let opts = IdentifyOptions::default();
    let id = identify(
        &chain,
        &model,
        Measurements::new(ds.q_flat(), ds.wrench_flat(), ds.displacement_flat()),
        &opts,
    )
    .unwrap();
    let sm = StiffnessModel::from_identification(
        &id,
        &chain,
        &model,
        &opts,
        DataSource::in_memory(ds.len()),
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("hE-compensate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("model.json");
    sm.save(&path).unwrap();
    let loaded = StiffnessModel::load(&path, &chain).unwrap();
    let rows: Vec<usize> = (0..6).collect();
    let (q, w) = rows_of(&campaign, &rows);
    let opts = CompensateOptions::default();
    let a = loaded
        .compensate(&chain, &q, Load::Wrench(&w), &opts)
        .unwrap();
    let b = compensate(
        &chain,
        &model,
        &id.solution.solution,
        &q,
        Load::Wrench(&w),
        &opts,
    )
    .unwrap();
    assert_eq!(a, b);
    // Noise-free data: the identified combinations are the truth's, so is the compensation.
    let ratios = true_ratios(&chain, &truth, &campaign, &rows, &a.q);
    assert!(max(&ratios) <= 0.02, "{ratios:?}");
    let tcp = SerialChain::bundled_with_tip(vjm::BUNDLED_TCP).unwrap();
    let e = loaded
        .compensate(&tcp, &q, Load::Wrench(&w), &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("another robot") && e.contains("tip"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `compensate` runs in fixed-size row blocks on every core: on 600 rows (three blocks) a
/// one-thread and a four-thread pool give the serial `compensate_in_place` bit for bit, and a
/// bad row in the last block is the error reported.
#[test]
fn blocked_compensation_is_the_serial_one_on_any_number_of_threads() {
    use vjm::{compensate_in_place, CompensationWorkspace};
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [2e-4, 1e-4, 2e-4, 1e-4, 3e-4, 3e-4, 5e-4];
    let rows = 600;
    let q = crate::strategies::random_configurations(&chain, rows, 7);
    let w = crate::strategies::random_wrenches(rows, 8);
    let mut opts = CompensateOptions::default();
    opts.check_limits = false;
    let mut ws = CompensationWorkspace::new(&chain, &model).unwrap();
    let mut q_serial = vec![0.0; q.len()];
    let mut rows_serial = compensate(&chain, &model, &c, &q[..7], Load::Wrench(&w[..6]), &opts)
        .unwrap()
        .rows
        .repeat(rows);
    compensate_in_place(
        &chain,
        &model,
        &c,
        CompensationTargets {
            q_nominal: &q,
            load: Load::Wrench(&w),
        },
        &opts,
        &mut ws,
        CompensationBuffers {
            q: &mut q_serial,
            rows: &mut rows_serial,
        },
    )
    .unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for threads in [1, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let out = pool
            .install(|| compensate(&chain, &model, &c, &q, Load::Wrench(&w), &opts))
            .unwrap();
        assert_eq!(bits(&out.q), bits(&q_serial), "{threads} threads: q");
        for (i, (a, b)) in out.rows.iter().zip(&rows_serial).enumerate() {
            assert_eq!(a.status, b.status, "row {i}");
            assert_eq!(a.iterations, b.iterations, "row {i}");
            assert_eq!(
                bits(&[a.position_error, a.deflection, a.inverse_condition]),
                bits(&[b.position_error, b.deflection, b.inverse_condition]),
                "row {i}"
            );
        }
        assert!(out
            .rows
            .iter()
            .any(|r| r.status == CompensationStatus::Converged));
        let mut bad = q.clone();
        bad[7 * 550 + 2] = f64::NAN;
        bad[7 * 590] = f64::NAN;
        let err = pool
            .install(|| compensate(&chain, &model, &c, &bad, Load::Wrench(&w), &opts))
            .unwrap_err();
        assert!(err.to_string().contains("row 550"), "{err}");
    }
}

/// A row's corrected targets do not depend on the rows compensated before it with the same
/// workspace (the K_C deflection starts warm only within a row): the rows in reverse order
/// give the forward order's bits, with and without the complementary stiffness.
#[test]
fn a_row_does_not_depend_on_the_rows_before_it() {
    use vjm::{compensate_in_place, CompensationWorkspace};
    let chain = SerialChain::bundled();
    let truth = extended_truth();
    let model = VirtualJointModel::extended(7);
    let rows = 200;
    let q = crate::strategies::random_configurations(&chain, rows, 21);
    let w = crate::strategies::random_wrenches(rows, 22);
    for with_kc in [true, false] {
        let opts = with_opts(|o| {
            o.with_kc = with_kc;
            o.check_limits = false;
        });
        let mut ws = CompensationWorkspace::new(&chain, &model).unwrap();
        let mut run = |order: Vec<usize>| {
            let mut out = vec![Vec::new(); rows];
            let mut qo = vec![0.0; 7];
            let first = compensate(
                &chain,
                &model,
                &truth.compliance,
                &q[..7],
                Load::Wrench(&w[..6]),
                &opts,
            )
            .unwrap();
            let mut ro = first.rows.clone();
            for i in order {
                compensate_in_place(
                    &chain,
                    &model,
                    &truth.compliance,
                    CompensationTargets {
                        q_nominal: &q[7 * i..7 * i + 7],
                        load: Load::Wrench(&w[6 * i..6 * i + 6]),
                    },
                    &opts,
                    &mut ws,
                    CompensationBuffers {
                        q: &mut qo,
                        rows: &mut ro,
                    },
                )
                .unwrap();
                let mut bits: Vec<u64> = qo.iter().map(|x| x.to_bits()).collect();
                let r = &ro[0];
                for x in [r.position_error, r.deflection, r.rotation_deflection] {
                    bits.push(x.to_bits());
                }
                bits.push(r.iterations as u64);
                out[i] = bits;
            }
            out
        };
        let forward = run((0..rows).collect());
        let backward = run((0..rows).rev().collect());
        for i in 0..rows {
            assert_eq!(forward[i], backward[i], "row {i}, with_kc {with_kc}");
        }
    }
}

/// The reported `inverse_condition` is σ_min/σ_max of the rigid actuated Jacobian's task rows
/// at the corrected targets, as nalgebra's SVD of `jacobian(traditional)` gives it: for a
/// traditional model (whose springs' Jacobian the compensation reuses as the actuated one) and
/// an extended one, for the position and the pose task.
#[test]
fn reported_conditioning_is_that_of_the_corrected_targets() {
    let chain = SerialChain::bundled();
    let rows = 30;
    let q = crate::strategies::random_configurations(&chain, rows, 31);
    let w = crate::strategies::random_wrenches(rows, 32);
    let actuated = VirtualJointModel::traditional(7);
    for (model, c) in [
        (VirtualJointModel::traditional(7), vec![3e-4; 7]),
        (VirtualJointModel::extended(7), extended_truth().compliance),
    ] {
        for pose in [false, true] {
            let opts = with_opts(|o| {
                o.match_orientation = pose;
                o.check_limits = false;
            });
            let out = compensate(&chain, &model, &c, &q, Load::Wrench(&w), &opts).unwrap();
            for i in 0..rows {
                let j = vjm::jacobian(&chain, &actuated, &out.q[7 * i..7 * i + 7]).unwrap();
                let mut task = j.rows(0, if pose { 6 } else { 3 }).into_owned();
                if pose {
                    task.rows_mut(3, 3).scale_mut(opts.length);
                }
                let s = task.singular_values();
                let expected = s.min() / s.max();
                let got = out.rows[i].inverse_condition;
                // The Gram matrix J Jᵀ squares the condition number: its eigenvalues give
                // σ_min/σ_max to about ε/(σ_min/σ_max)² relative.
                let tol = 1e-10 + 20.0 * f64::EPSILON / (expected * expected);
                assert!(
                    (got - expected).abs() <= tol * expected,
                    "{} row {i} pose {pose}: {got} vs {expected}",
                    model.name()
                );
            }
        }
    }
}
