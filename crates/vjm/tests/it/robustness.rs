//! Issue 14, Rust side: non-finite robot descriptions are refused at load, naming the joint and
//! the attribute (before the fix a NaN origin made `simulate` spin forever and Python return
//! NaN Jacobians).

use nalgebra::{Isometry3, Vector3};
use vjm::{SerialChain, VjmError};

/// Two revolute joints and a fixed tool joint; `{..}` placeholders are replaced per test.
const TEMPLATE: &str = r#"<robot name="two">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="{J1_XYZ}" rpy="{J1_RPY}"/><axis xyz="{J1_AXIS}"/>
    <limit lower="{J1_LOWER}" upper="{J1_UPPER}" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="continuous">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="l2"/><child link="tool"/>
    <origin xyz="{TOOL_XYZ}" rpy="0 0 0"/>
  </joint>
</robot>"#;

fn urdf(replace: &[(&str, &str)]) -> String {
    let mut s = TEMPLATE.to_string();
    for (k, v) in replace {
        s = s.replace(&format!("{{{k}}}"), v);
    }
    for (k, v) in [
        ("J1_XYZ", "0 0 0.1"),
        ("J1_RPY", "0 0 0"),
        ("J1_AXIS", "0 0 1"),
        ("J1_LOWER", "-2"),
        ("J1_UPPER", "2"),
        ("TOOL_XYZ", "0.2 0 0"),
    ] {
        s = s.replace(&format!("{{{k}}}"), v);
    }
    s
}

fn load(replace: &[(&str, &str)]) -> Result<SerialChain, VjmError> {
    SerialChain::from_urdf_str(&urdf(replace), "base", "tool")
}

#[test]
fn the_template_itself_loads() {
    let chain = load(&[]).unwrap();
    assert_eq!(chain.n_joints(), 2);
}

#[test]
fn non_finite_urdf_numbers_are_refused_naming_joint_and_attribute() {
    let cases: [(&str, &str, &str, &str); 8] = [
        ("J1_XYZ", "nan 0 0", "j1", "origin xyz"),
        ("J1_XYZ", "0 inf 0", "j1", "origin xyz"),
        ("J1_RPY", "0 NaN 0", "j1", "origin rpy"),
        ("J1_AXIS", "nan 0 1", "j1", "axis"),
        ("J1_LOWER", "nan", "j1", "limit lower"),
        ("J1_UPPER", "inf", "j1", "limit upper"),
        ("J1_UPPER", "-3", "j1", "limit"),
        ("TOOL_XYZ", "0 0 -inf", "tool_joint", "origin xyz"),
    ];
    for (key, value, joint, attribute) in cases {
        let err = load(&[(key, value)]).expect_err(&format!("{key}={value} must be refused"));
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("`{joint}`")) && msg.contains(attribute),
            "{key}={value}: {msg}"
        );
        assert!(!msg.contains("::"), "{msg}");
    }
}

#[test]
fn a_zero_length_axis_is_refused() {
    let err = load(&[("J1_AXIS", "0 0 0")]).unwrap_err();
    assert!(
        matches!(err, VjmError::InvalidAxis { ref joint, .. } if joint == "j1"),
        "{err}"
    );
}

#[test]
fn from_joints_refuses_non_finite_origins_and_nan_limits() {
    let good = || {
        (
            "a".to_string(),
            Isometry3::translation(0.0, 0.0, 0.1),
            Vector3::z(),
            (-1.0, 1.0),
        )
    };
    let mut bad_origin = good();
    bad_origin.1 = Isometry3::translation(f64::NAN, 0.0, 0.0);
    let mut bad_limit = good();
    bad_limit.3 = (f64::NAN, 1.0);
    for spec in [bad_origin, bad_limit] {
        let err =
            SerialChain::from_joints("b", "t", vec![spec], Isometry3::identity()).unwrap_err();
        assert!(err.to_string().contains("joint `a`"), "{err}");
    }
    // (-inf, inf) still means a continuous joint.
    let mut continuous = good();
    continuous.3 = (f64::NEG_INFINITY, f64::INFINITY);
    SerialChain::from_joints("b", "t", vec![continuous], Isometry3::identity()).unwrap();
}

// ---------------------------------------------------------------- cancellation

mod cancellation {
    use std::sync::Mutex;
    use std::time::Instant;

    use stiffness_core::{Cancel, Monitor, Progress};
    use vjm::diagnose::{diagnose, diagnose_monitored, DiagnoseError, DiagnoseOptions};
    use vjm::testbed::{simulate, Campaign, CampaignSpec, TrueModel};
    use vjm::SerialChain;

    fn campaign(chain: &SerialChain) -> Campaign {
        let spec = CampaignSpec {
            n_poses: 30,
            wrenches_per_pose: 4,
            seed: 3,
            ..Default::default()
        };
        simulate(chain, &TrueModel::nominal(7), &spec).unwrap()
    }

    #[test]
    fn a_sink_that_cancels_ends_diagnose_with_cancelled_at_once() {
        let chain = SerialChain::bundled();
        let data = campaign(&chain).dataset;
        let cancel = Cancel::new();
        let stages = Mutex::new(Vec::new());
        let sink = |p: Progress| {
            stages.lock().unwrap().push(p.stage);
            if p.stage == "baseline" {
                cancel.cancel();
            }
        };
        let monitor = Monitor::new(cancel.clone()).with_progress(&sink);
        let result = diagnose_monitored(&chain, &data, &DiagnoseOptions::default(), &monitor);
        assert!(
            matches!(result, Err(DiagnoseError::Cancelled(_))),
            "{result:?}"
        );
        // The passes over the rows report too ("pass over the rows"); nothing follows the
        // stage whose report cancelled.
        let stages = stages.lock().unwrap();
        let named: Vec<&str> = stages
            .iter()
            .copied()
            .filter(|s| *s != "pass over the rows")
            .collect();
        assert_eq!(named, ["kinematics", "baseline"]);
        assert!(stages.contains(&"pass over the rows"));
        assert_eq!(stages.last(), Some(&"baseline"));
        assert_eq!(
            DiagnoseError::Cancelled(stiffness_core::Cancelled).to_string(),
            "diagnosis cancelled"
        );
    }

    /// Every pass over the rows counts its own rows from 0: no report of a pass says it is
    /// complete before it ends (a pass that did not reset the count showed `total/total` from
    /// its first report). 10 000 rows, so that the passes run in two parts. With nothing to
    /// find, the rows are read three times: the pre-fit (with the RMS torques), the baseline's
    /// design with its verdict's within-pose factor, and the final predictions.
    #[test]
    fn every_pass_over_the_rows_reports_its_own_progress() {
        let (chain, data) = crate::strategies::nominal_panda_campaign(1000, 10, 8);
        let reports = Mutex::new(Vec::new());
        let sink = |p: Progress| {
            if p.stage == "pass over the rows" {
                reports.lock().unwrap().push((p.done, p.total));
            }
        };
        let monitor = Monitor::new(Cancel::new()).with_progress(&sink);
        diagnose_monitored(&chain, &data, &DiagnoseOptions::default(), &monitor).unwrap();
        let reports = reports.into_inner().unwrap();
        let passes = reports.iter().filter(|(done, _)| *done == 0).count();
        assert_eq!(passes, 4, "{passes} passes reported: {reports:?}");
        for (done, total) in &reports {
            assert_eq!(*total, data.len());
            assert!(done < total, "a pass reported {done}/{total}: {reports:?}");
        }
    }

    #[test]
    fn a_cancelled_token_stops_diagnose_and_an_idle_one_changes_nothing() {
        let chain = SerialChain::bundled();
        let data = campaign(&chain).dataset;
        let opts = DiagnoseOptions::default();
        let start = Instant::now();
        let full = diagnose(&chain, &data, &opts).unwrap();
        let full_time = start.elapsed();
        // Cancelled before it starts: nothing is computed.
        let cancel = Cancel::new();
        cancel.cancel();
        let start = Instant::now();
        let r = diagnose_monitored(&chain, &data, &opts, &Monitor::new(cancel));
        assert!(matches!(r, Err(DiagnoseError::Cancelled(_))));
        assert!(
            start.elapsed() < full_time,
            "{:?} vs {full_time:?}",
            start.elapsed()
        );
        // Not cancelled: the same answer as the plain call.
        let same = diagnose_monitored(&chain, &data, &opts, &Monitor::none()).unwrap();
        assert_eq!(same.to_json(), full.to_json());
    }
}

mod simulation_cancel {
    use stiffness_core::{Cancel, Monitor, Progress};
    use vjm::testbed::{simulate, simulate_monitored, CampaignSpec, TestbedError, TrueModel};
    use vjm::SerialChain;

    #[test]
    fn simulate_reports_progress_and_stops_when_cancelled() {
        let chain = SerialChain::bundled();
        let spec = CampaignSpec {
            n_poses: 600,
            wrenches_per_pose: 4,
            seed: 2,
            ..Default::default()
        };
        let truth = TrueModel::nominal(7);
        let cancel = Cancel::new();
        let reports = std::sync::Mutex::new(Vec::new());
        let sink = |p: Progress| {
            reports.lock().unwrap().push(p.done);
            if p.done >= 1024 {
                cancel.cancel();
            }
        };
        let r = simulate_monitored(
            &chain,
            &truth,
            &spec,
            &Monitor::new(cancel.clone()).with_progress(&sink),
        );
        assert!(
            matches!(r, Err(TestbedError::Cancelled(_))),
            "{:?}",
            r.err()
        );
        assert_eq!(*reports.lock().unwrap(), [0, 1024]);
        // Unmonitored and monitored-but-idle runs agree.
        let a = simulate(&chain, &truth, &spec).unwrap();
        let b = simulate_monitored(&chain, &truth, &spec, &Monitor::none()).unwrap();
        assert_eq!(a.dataset, b.dataset);
    }
}

// ---------------------------------------------------------------- messages

mod messages {
    use vjm::dataset::Dataset;

    #[test]
    fn an_empty_file_says_it_has_no_header() {
        let err = Dataset::from_reader("".as_bytes(), 7).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("no header"), "{msg}");
        assert!(!msg.contains("q1..q0"), "{msg}");
    }

    #[test]
    fn a_header_without_rows_says_no_data_rows() {
        let header = "q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz\n";
        let msg = Dataset::from_reader(header.as_bytes(), 2)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("no data rows"), "{msg}");
    }

    #[test]
    fn a_wrong_joint_count_names_found_and_expected_columns() {
        let text = "fx,fy,fz,mx,my,mz,dx,dy,dz\n1,2,3,4,5,6,1e-4,0,0\n";
        let msg = Dataset::from_reader(text.as_bytes(), 7)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("no joint columns") && msg.contains("q1..q7") && !msg.contains("q1..q0"),
            "{msg}"
        );
        let text = "q1,q2,q3,fx,fy,fz,mx,my,mz,dx,dy,dz\n0,0,0,1,2,3,4,5,6,1e-4,0,0\n";
        let msg = Dataset::from_reader(text.as_bytes(), 7)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("3 joint columns") && msg.contains("q1..q7"),
            "{msg}"
        );
    }
}

// ---------------------------------------------------------------- one validation layer

mod validation {
    use vjm::dataset::{Dataset, DatasetError, MAX_PLAUSIBLE_FORCE};
    use vjm::diagnose::{diagnose, DiagnoseError, DiagnoseOptions};
    use vjm::testbed::{simulate, CampaignSpec, Effect, TestbedError, TrueModel};
    use vjm::{predict_deflection, SerialChain, SpringAxis, VirtualJointModel};

    const HEADER: &str = "q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz";

    fn arrays(wrench: [f64; 6], disp: [f64; 3]) -> Result<Dataset<'static>, DatasetError> {
        Dataset::new(
            2,
            vec![0.1, 0.2],
            wrench.to_vec(),
            disp.to_vec(),
            None,
            None,
            None,
        )
    }

    #[test]
    fn an_implausible_load_cell_is_refused_in_files_and_arrays_alike() {
        let text = format!("{HEADER}\n0,0,1,2,3,0,0,0,1e-4,0,0\n0,0,1e308,2,3,0,0,0,1e-4,0,0\n");
        let file = Dataset::from_reader(text.as_bytes(), 2).unwrap_err();
        let msg = file.to_string();
        assert!(msg.contains("line 3") && msg.contains("'fx'"), "{msg}");
        let arr = arrays([0.0, 0.0, 0.0, 0.0, 2e4, 0.0], [1e-4, 0.0, 0.0]).unwrap_err();
        let msg = arr.to_string();
        assert!(msg.contains("'my'") && msg.contains("N·m"), "{msg}");
        // At the cap itself, accepted.
        arrays(
            [MAX_PLAUSIBLE_FORCE, 0.0, 0.0, 0.0, 0.0, 0.0],
            [1e-4, 0.0, 0.0],
        )
        .unwrap();
    }

    #[test]
    fn data_without_load_or_without_displacement_are_refused() {
        let err = arrays([0.0; 6], [1e-4, 0.0, 0.0]).unwrap_err();
        assert!(matches!(err, DatasetError::NoLoad { rows: 1 }), "{err}");
        assert!(err.to_string().contains("no load"), "{err}");
        let text = format!("{HEADER}\n0,0,1,2,3,0,0,0,0,0,0\n0,0,4,5,6,0,0,0,0,0,0\n");
        let err = Dataset::from_reader(text.as_bytes(), 2).unwrap_err();
        assert!(
            matches!(err, DatasetError::NoDisplacement { rows: 2 }),
            "{err}"
        );
    }

    fn panda_campaign() -> (SerialChain, Dataset<'static>) {
        crate::strategies::nominal_panda_campaign(24, 4, 5)
    }

    fn with_q(data: &Dataset<'_>, row: usize, joint: usize, value: f64) -> Dataset<'static> {
        let mut q = data.q_flat().to_vec();
        q[row * 7 + joint] = value;
        let poses = (0..data.len()).map(|i| data.pose(i).unwrap()).collect();
        Dataset::new(
            7,
            q,
            data.wrench_flat().to_vec(),
            data.displacement_flat().to_vec(),
            None,
            Some(poses),
            None,
        )
        .unwrap()
    }

    #[test]
    fn joint_angles_outside_the_limits_are_refused_unless_allowed() {
        let (chain, data) = panda_campaign();
        // Joint 4 of the Panda lives in [−3.07, −0.07] rad; 1.0 rad is outside (degrees-like
        // values and sign errors land there).
        let bad = with_q(&data, 5, 3, 1.0);
        let err = diagnose(&chain, &bad, &DiagnoseOptions::default()).unwrap_err();
        let msg = err.to_string();
        assert!(
            matches!(
                err,
                DiagnoseError::Dataset(DatasetError::OutsideLimits { line: 7, .. })
            ),
            "{msg}"
        );
        assert!(msg.contains("q4") && msg.contains("panda_joint4"), "{msg}");
        assert!(msg.contains("--allow-outside-limits"), "{msg}");
        let allowed = DiagnoseOptions {
            allow_outside_limits: true,
            ..Default::default()
        };
        diagnose(&chain, &bad, &allowed).unwrap();
    }

    #[test]
    fn rows_with_zero_displacement_do_not_count_as_perfect_predictions() {
        let (chain, data) = panda_campaign();
        // Zero the displacement of the first rows (a tracker dropout written as 0).
        let mut disp = data.displacement_flat().to_vec();
        for v in disp.iter_mut().take(3 * 8) {
            *v = 0.0;
        }
        let poses = (0..data.len()).map(|i| data.pose(i).unwrap()).collect();
        let d = Dataset::new(
            7,
            data.q_flat().to_vec(),
            data.wrench_flat().to_vec(),
            disp,
            None,
            Some(poses),
            None,
        )
        .unwrap();
        let diag = diagnose(&chain, &d, &DiagnoseOptions::default()).unwrap();
        // The mean relative error over held-out rows, recomputed from the per-row report over
        // the rows that have a displacement.
        let rel: Vec<f64> = diag
            .rows
            .iter()
            .filter(|r| r.set == vjm::dataset::SetLabel::Test)
            .filter_map(|r| {
                let n = r.measured.iter().map(|v| v * v).sum::<f64>().sqrt();
                let e = (0..3)
                    .map(|k| (r.measured[k] - r.baseline[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                (n > 0.0).then_some(e / n)
            })
            .collect();
        let zero_test_rows = diag
            .rows
            .iter()
            .filter(|r| r.set == vjm::dataset::SetLabel::Test && r.measured == [0.0; 3])
            .count();
        assert!(
            zero_test_rows > 0,
            "the test needs zeroed rows among the held-out ones"
        );
        let expect = rel.iter().sum::<f64>() / rel.len() as f64;
        let got = diag.baseline.test_mean_rel_error;
        assert!((got - expect).abs() < 1e-12 * expect, "{got} vs {expect}");
    }

    #[test]
    fn negative_compliances_are_refused_by_predict_and_the_testbed() {
        let chain = SerialChain::bundled();
        let model = VirtualJointModel::traditional(7);
        let mut c = [1e-4; 7];
        c[2] = -1e-5;
        let err = predict_deflection(
            &chain,
            &model,
            &c,
            &[0.0; 7],
            &[0.0, 0.0, -10.0, 0.0, 0.0, 0.0],
            false,
        )
        .unwrap_err();
        assert!(err.to_string().contains("J3z"), "{err}");
        let spec = CampaignSpec {
            n_poses: 4,
            wrenches_per_pose: 2,
            ..Default::default()
        };
        let mut truth = TrueModel::nominal(7);
        truth.compliance[4] = -1.0;
        let err = simulate(&chain, &truth, &spec).unwrap_err();
        assert!(matches!(err, TestbedError::InvalidTruth { .. }), "{err}");
        assert!(err.to_string().contains("J2x"), "{err}");
        let tilt = TrueModel::nominal(7).with_effect(Effect::JointTilt {
            joint: 2,
            axis: SpringAxis::X,
            compliance: f64::NAN,
        });
        let msg = simulate(&chain, &tilt, &spec).unwrap_err().to_string();
        assert!(
            msg.contains("joint_tilt at joint 3") && !msg.contains("dx"),
            "{msg}"
        );
    }

    #[test]
    fn an_implausible_campaign_load_blames_the_spec_not_a_file_column() {
        let chain = SerialChain::bundled();
        let spec = CampaignSpec {
            n_poses: 4,
            wrenches_per_pose: 2,
            force_range: (0.0, 1e9),
            ..Default::default()
        };
        let err = simulate(&chain, &TrueModel::nominal(7), &spec).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, TestbedError::InvalidSpec { .. }), "{msg}");
        assert!(!msg.contains("'dx'") && !msg.contains("line"), "{msg}");
        // A huge true compliance: the simulated displacement is implausible, and the error says
        // that the true model is the cause.
        let mut truth = TrueModel::nominal(7);
        truth.compliance[0] = 10.0;
        let msg = simulate(
            &chain,
            &truth,
            &CampaignSpec {
                n_poses: 4,
                wrenches_per_pose: 2,
                ..Default::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(msg.contains("true model") && !msg.contains("line"), "{msg}");
    }

    /// The slice-level checks (used by the Python `identify`, which never builds a Dataset)
    /// give the same verdicts as `Dataset::new` on the same arrays, cell by cell.
    #[test]
    fn slice_checks_agree_with_the_dataset_constructor() {
        let q = vec![0.1, 0.2, 0.3, 0.4];
        let good_w = vec![
            10.0, 0.0, -5.0, 0.1, 0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 0.2, 0.0,
        ];
        let good_d = vec![1e-4, 0.0, -2e-4, 0.0, 3e-4, 0.0];
        let cases: Vec<(Vec<f64>, Vec<f64>)> = vec![
            (good_w.clone(), good_d.clone()),
            (good_w.clone(), good_d.iter().map(|v| v * 1000.0).collect()),
            (
                {
                    let mut w = good_w.clone();
                    w[8] = 1e308;
                    w
                },
                good_d.clone(),
            ),
            (
                {
                    let mut w = good_w.clone();
                    w[4] = f64::NAN;
                    w
                },
                good_d.clone(),
            ),
            (vec![0.0; 12], good_d.clone()),
            (good_w.clone(), vec![0.0; 6]),
        ];
        for (w, d) in cases {
            let a = vjm::dataset::check_values(2, vjm::Measurements::new(&q, &w, &d))
                .map_err(|e| e.to_string());
            let b = Dataset::new(2, q.clone(), w.clone(), d.clone(), None, None, None)
                .map(|_| ())
                .map_err(|e| e.to_string());
            assert_eq!(a, b, "w {w:?} d {d:?}");
        }
    }

    #[test]
    fn slice_joint_limit_check_names_row_column_and_joint() {
        let chain = SerialChain::bundled();
        let mut q = [0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8].repeat(3);
        assert!(vjm::dataset::check_joint_limits(&chain, &q).is_ok());
        q[7 + 3] = 0.5; // row 1, joint 4 in [-3.07, -0.07] rad
        let msg = vjm::dataset::check_joint_limits(&chain, &q)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("q4") && msg.contains("panda_joint4"), "{msg}");
    }
}
