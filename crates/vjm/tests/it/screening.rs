//! Issue 21, silent wrong answers: the checks `identify` runs, applied to the poses and loads of
//! a prediction (`dataset::check_poses`, `PointMass::new`, the pose table), the floor under the
//! loads, and the warnings of `vjm::screening` (outlier rows, compliance scale, negative
//! compliances), with the simulated campaigns on which none may fire.

use vjm::dataset::{check_poses, ArraysCheck, DatasetError};
use vjm::screening::{outlier_rows, review, DataWarning, Quantity};
use vjm::stiffness_model::{PointMass, PoseTable};
use vjm::testbed::{simulate, CampaignSpec, TrueModel};
use vjm::Measurements;
use vjm::{identify, IdentifyOptions, SerialChain, VirtualJointModel};

const Q: [f64; 7] = [0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8];

fn poses(rows: usize) -> (Vec<f64>, Vec<f64>) {
    let q: Vec<f64> = (0..rows).flat_map(|_| Q).collect();
    let w: Vec<f64> = (0..rows)
        .flat_map(|i| [10.0 + i as f64, 0.0, -20.0, 0.0, 1.0, 0.0])
        .collect();
    (q, w)
}

fn refused(q: &[f64], w: Option<&[f64]>, limits: bool) -> String {
    let chain = SerialChain::bundled();
    match check_poses(7, q, w, limits.then_some(&chain)) {
        Err(e) => e.to_string(),
        Ok(c) => panic!("accepted ({c:?})"),
    }
}

#[test]
fn predict_inputs_get_identifys_checks() {
    let chain = SerialChain::bundled();
    let (q, w) = poses(4);
    assert_eq!(
        check_poses(7, &q, Some(&w), Some(&chain)).unwrap(),
        ArraysCheck::Passed
    );
    // Degrees (q = -135) and 1e300: implausible, named by line (row + 2) and column.
    let mut deg = q.clone();
    deg[7 + 3] = -135.0;
    let e = refused(&deg, Some(&w), false);
    assert!(
        e.contains("line 3, column 'q4'") && e.contains("degrees"),
        "{e}"
    );
    let mut huge = q.clone();
    huge[2 * 7] = 1e300;
    assert!(refused(&huge, None, false).contains("line 4, column 'q1'"));
    // 1e9 N (a 40 km deflection) and 1e308 (inf once multiplied): refused, not predicted.
    for (k, v) in [(0usize, 1e9), (6 * 3, 1e308), (6 + 4, 1e5)] {
        let mut big = w.clone();
        big[k] = v;
        let e = refused(&q, Some(&big), false);
        assert!(e.contains("larger than physically plausible"), "{e}");
    }
    // Outside the URDF limits: refused unless the caller opts out (limits = None).
    let mut outside = q.clone();
    outside[7] = 3.0;
    let e = refused(&outside, Some(&w), true);
    assert!(
        e.contains("line 3, column 'q1'") && e.contains("allow-outside-limits"),
        "{e}"
    );
    assert_eq!(
        check_poses(7, &outside, Some(&w), None).unwrap(),
        ArraysCheck::Passed
    );
    // Non-finite: left to the core's own check, which names the array, row and column.
    let mut nan = q;
    nan[5] = f64::NAN;
    assert_eq!(
        check_poses(7, &nan, None, None).unwrap(),
        ArraysCheck::NonFinite
    );
}

#[test]
fn a_payload_beyond_the_load_caps_is_refused() {
    assert!(PointMass::new(5.0, [0.0, 0.0, 0.1]).is_ok());
    for (mass, centre, what) in [
        (1e6, [0.0; 3], "weighs"),
        (1e308, [0.0; 3], "weighs"),
        (100.0, [0.0, 0.0, 1e3], "N·m"),
    ] {
        let e = PointMass::new(mass, centre).unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("plausible"), "{e}");
    }
}

#[test]
fn the_pose_table_refuses_what_a_measurement_file_refuses() {
    let dir = std::env::temp_dir().join(format!("vjm-it-{}-screening", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (cell, column) in [("q4", "-135"), ("fx", "1e9"), ("mz", "1e308")] {
        let head = "q1,q2,q3,q4,q5,q6,q7,fx,fy,fz,mx,my,mz";
        let mut row: Vec<String> = Q.iter().map(|v| v.to_string()).collect();
        row.extend(["10", "0", "0", "0", "0", "0"].map(String::from));
        let k = head.split(',').position(|c| c == cell).unwrap();
        let ok = row.join(",");
        row[k] = column.to_string();
        let path = dir.join("poses.csv");
        std::fs::write(&path, format!("{head}\n{ok}\n{}\n", row.join(","))).unwrap();
        let e = PoseTable::read_csv(&path, 7).unwrap_err().to_string();
        assert!(
            e.contains(&format!("line 3, column '{cell}'")) && e.contains("plausible"),
            "{e}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_pose_table_reads_pose_ids_when_given_and_refuses_a_fractional_one() {
    let row: Vec<String> = Q.iter().map(|v| v.to_string()).collect();
    let q = row.join(",");
    let head = "pose,q1,q2,q3,q4,q5,q6,q7,fx,fy,fz,mx,my,mz,dx";
    let text = format!("{head}\n4,{q},10,0,0,0,0,0,\n9,{q},0,10,0,0,0,0,\n");
    let t = PoseTable::from_reader(text.as_bytes(), 7).unwrap();
    assert_eq!(t.pose, Some(vec![4, 9]));
    assert_eq!(t.wrench.as_deref().map(|w| w[7]), Some(10.0));
    let without = format!("q1,q2,q3,q4,q5,q6,q7\n{q}\n");
    assert_eq!(
        PoseTable::from_reader(without.as_bytes(), 7).unwrap().pose,
        None
    );
    let bad = format!("{head}\n4.5,{q},10,0,0,0,0,0,\n");
    let e = PoseTable::from_reader(bad.as_bytes(), 7)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("pose"), "{e}");
}

#[test]
fn loads_scaled_to_nothing_are_an_error_not_rank_0() {
    let (q, mut w) = poses(6);
    let d = vec![1e-4; 18];
    for v in &mut w {
        *v *= 1e-300;
    }
    let e = vjm::dataset::check_values(7, Measurements::new(&q, &w, &d)).unwrap_err();
    assert!(
        matches!(e, DatasetError::NegligibleLoad { rows: 6, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("carry no information"), "{e}");
}

/// A simulated campaign (no noise-free shortcut: the default instruments).
fn campaign(seed: u64, force_max: Option<f64>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let chain = SerialChain::bundled();
    let mut spec = CampaignSpec {
        n_poses: 15,
        seed,
        ..Default::default()
    };
    if let Some(f) = force_max {
        spec.force_range = (spec.force_range.0.min(f), f);
    }
    let ds = simulate(&chain, &TrueModel::nominal(7), &spec)
        .unwrap()
        .dataset;
    (
        ds.q_flat().to_vec(),
        ds.wrench_flat().to_vec(),
        ds.displacement_flat().to_vec(),
    )
}

fn warnings_of(q: &[f64], w: &[f64], d: &[f64], model: &VirtualJointModel) -> Vec<DataWarning> {
    let chain = SerialChain::bundled();
    let id = identify(
        &chain,
        model,
        Measurements::new(q, w, d),
        &IdentifyOptions::default(),
    )
    .unwrap();
    review(&id, w, d)
}

#[test]
fn clean_campaigns_give_no_warning() {
    for seed in 0..6 {
        let (q, w, d) = campaign(seed, None);
        for model in [
            VirtualJointModel::traditional(7),
            VirtualJointModel::extended(7),
        ] {
            let found = warnings_of(&q, &w, &d, &model);
            assert!(found.is_empty(), "seed {seed}: {found:?}");
        }
    }
}

#[test]
fn one_row_in_another_unit_is_named_with_the_negative_compliances_it_causes() {
    // The case: one 5e4 N row among 60 N rows (seed 1 turns J5z and J6z negative).
    let (q, mut w, d) = campaign(1, Some(60.0));
    let row = 7;
    let f = (w[6 * row].powi(2) + w[6 * row + 1].powi(2) + w[6 * row + 2].powi(2)).sqrt();
    for k in 0..3 {
        w[6 * row + k] *= 5e4 / f;
    }
    let found = warnings_of(&q, &w, &d, &VirtualJointModel::traditional(7));
    let text: Vec<String> = found.iter().map(|w| w.to_string()).collect();
    assert!(
        matches!(&found[0], DataWarning::Outliers { quantity: Quantity::Load, rows, .. } if rows == &[row]),
        "{text:?}"
    );
    assert!(text[0].contains("line 9"), "{}", text[0]);
    assert!(
        found.iter().any(|w| matches!(
            w,
            DataWarning::NegativeCompliance {
                after_outliers: true,
                ..
            }
        )),
        "{text:?}"
    );
    // A displacement in mm on one row is an outlier of the displacements (a campaign under
    // light loads, so that the row stays below the 5 cm cap).
    let (_, mut w, mut d) = campaign(2, None);
    w.iter_mut().chain(d.iter_mut()).for_each(|v| *v *= 0.01);
    for k in 0..3 {
        d[3 * 4 + k] *= 1e3;
    }
    let found = outlier_rows(&w, &d);
    assert!(
        matches!(&found[..], [DataWarning::Outliers { quantity: Quantity::Displacement, rows, .. }] if rows == &[4]),
        "{found:?}"
    );
}

#[test]
fn wrenches_in_kn_or_displacements_in_mm_are_a_compliance_scale_warning() {
    let (q, w, d) = campaign(3, None);
    let kn: Vec<f64> = w.iter().map(|v| v * 1e-3).collect();
    // Displacements in mm: under light loads (a few N at most), so that they stay below the 5 cm
    // cap and pass every check.
    let scale = 0.04e-3 / d.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let light: Vec<f64> = w.iter().map(|v| v * scale).collect();
    let mm: Vec<f64> = d.iter().map(|v| v * scale * 1e3).collect();
    for (name, wrench, disp) in [("kN", &kn, &d), ("mm", &light, &mm)] {
        vjm::dataset::check_values(7, Measurements::new(&q, wrench, disp)).unwrap();
        let found = warnings_of(&q, wrench, disp, &VirtualJointModel::traditional(7));
        assert!(
            found
                .iter()
                .any(|w| matches!(w, DataWarning::ComplianceScale { .. })),
            "{name}: {found:?}"
        );
        let text = found.iter().map(|w| w.to_string()).collect::<Vec<_>>();
        assert!(
            text.iter().any(|t| t.contains("kN") && t.contains("mm")),
            "{text:?}"
        );
    }
}
