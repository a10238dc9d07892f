//! The VJM measurement file: round trip, split, and one clear error per kind of bad input.

use vjm::dataset::{Dataset, DatasetError, SetLabel};

const HEADER: &str = "q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz";

fn read(text: &str) -> Result<Dataset<'static>, DatasetError> {
    Dataset::from_reader(text.as_bytes(), 2)
}

fn good_rows() -> String {
    format!(
        "{HEADER}\n0.1,0.2,10,0,0,0,0,1,0.0001,0.0002,-0.0003\n0.3,-0.4,0,20,0,0,1,0,2e-4,1e-4,0\n"
    )
}

#[test]
fn reads_values_in_any_column_order() {
    let text = "dz,dy,dx,mz,my,mx,fz,fy,fx,q2,q1\n3e-4,2e-4,1e-4,6,5,4,3,2,1,-0.5,0.5\n";
    let d = read(text).unwrap();
    assert_eq!(d.len(), 1);
    assert_eq!(d.q(0), &[0.5, -0.5]);
    assert_eq!(d.wrench(0), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(d.displacement(0), [1e-4, 2e-4, 3e-4]);
    assert_eq!(d.pose(0), None);
    assert_eq!(d.set(0), None);
}

#[test]
fn write_then_read_round_trips_bit_for_bit() {
    let d = Dataset::new(
        2,
        vec![0.1, 1.0 / 3.0, -2.5, 0.7],
        vec![
            1.0, 2.0, 3.0, 0.1, 0.2, 0.3, -1.0, -2.0, -3.0, 0.0, 0.0, 1e-3,
        ],
        vec![1.234_567_890_123e-4, 0.0, -7e-6, 1e-5, 2e-5, 3e-5],
        Some(vec![1e-5, 2e-5, 3e-5, 0.0, 0.0, -1e-4]),
        Some(vec![4, 9]),
        Some(vec![SetLabel::Train, SetLabel::Test]),
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("vjm-dataset-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("campaign.csv");
    d.write_csv(&path).unwrap();
    let back = Dataset::read_csv(&path, 2).unwrap();
    assert_eq!(back, d);
    // No temporary file is left next to the output.
    let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(leftovers.len(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn split_holds_out_whole_poses_reproducibly() {
    let mut q = Vec::new();
    let mut w = Vec::new();
    let mut dsp = Vec::new();
    let mut pose = Vec::new();
    for p in 0..20 {
        for k in 0..3 {
            q.extend([p as f64 * 0.1, 0.2]);
            w.extend([10.0 + k as f64, 0.0, 0.0, 0.0, 0.0, 0.0]);
            dsp.extend([1e-4, 0.0, 0.0]);
            pose.push(100 + p);
        }
    }
    let d = Dataset::new(2, q, w, dsp, None, Some(pose), None).unwrap();
    let a = d.split(0.25, 7).unwrap();
    let b = d.split(0.25, 7).unwrap();
    assert_eq!(a, b);
    let n_test = a.iter().filter(|l| **l == SetLabel::Test).count();
    assert_eq!(n_test, 5 * 3); // 5 of 20 poses, 3 rows each
    for p in 0..20 {
        let labels: Vec<_> = (0..3).map(|k| a[3 * p + k]).collect();
        assert!(labels.iter().all(|l| *l == labels[0]), "pose {p} was split");
    }
    let c = d.split(0.25, 8).unwrap();
    assert_ne!(a, c, "another seed should hold out other poses");
}

fn expect_err(text: &str) -> (DatasetError, String) {
    match read(text) {
        Ok(_) => panic!("accepted bad input:\n{text}"),
        Err(e) => {
            let msg = e.to_string();
            (e, msg)
        }
    }
}

#[test]
fn missing_column_is_named() {
    let text = "q1,q2,fx,fy,fz,mx,my,dx,dy,dz\n0,0,1,1,1,0,0,0,0,0\n";
    let (e, msg) = expect_err(text);
    assert!(matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "mz"));
    assert!(msg.contains("'mz'"), "{msg}");
}

#[test]
fn nan_and_inf_name_line_and_column() {
    let text = format!("{}0.5,0.5,1,1,1,0,0,0,NaN,0,0\n", good_rows());
    let (e, msg) = expect_err(&text);
    assert!(matches!(e, DatasetError::NonFinite { line: 4, ref column, .. } if column == "dx"));
    assert!(msg.contains("line 4") && msg.contains("'dx'"), "{msg}");
    let text = format!("{HEADER}\n0.5,0.5,1,inf,1,0,0,0,0,0,0\n");
    let (e, _) = expect_err(&text);
    assert!(matches!(e, DatasetError::NonFinite { line: 2, ref column, .. } if column == "fy"));
}

#[test]
fn millimetres_are_flagged() {
    let text = format!("{HEADER}\n0.5,0.5,10,0,0,0,0,0,0.12,0.3,-1.5\n");
    let (e, msg) = expect_err(&text);
    assert!(matches!(e, DatasetError::Implausible { line: 2, ref column, .. } if column == "dx"));
    assert!(msg.contains("looks like mm, expected m"), "{msg}");
}

#[test]
fn degrees_are_flagged() {
    let text = format!("{HEADER}\n45,30,10,0,0,0,0,0,1e-4,0,0\n");
    let (e, msg) = expect_err(&text);
    assert!(matches!(e, DatasetError::Implausible { ref column, .. } if column == "q1"));
    assert!(msg.contains("degrees"), "{msg}");
}

#[test]
fn wrong_joint_count_is_reported() {
    let text = "q1,q2,q3,fx,fy,fz,mx,my,mz,dx,dy,dz\n0,0,0,1,1,1,0,0,0,0,0,0\n";
    let (e, msg) = expect_err(text);
    assert!(matches!(
        e,
        DatasetError::JointCount {
            found: 3,
            expected: 2
        }
    ));
    assert!(
        msg.contains("3 joint columns") && msg.contains("2 actuated joints"),
        "{msg}"
    );
    // q1, q3 but no q2.
    let text = "q1,q3,fx,fy,fz,mx,my,mz,dx,dy,dz\n0,0,1,1,1,0,0,0,0,0,0\n";
    let (e, _) = expect_err(text);
    assert!(matches!(e, DatasetError::MissingColumn { ref column, .. } if column == "q2"));
}

#[test]
fn unknown_set_label_is_reported() {
    let text =
        format!("{HEADER},set\n0,0,1,1,1,0,0,0,0,0,0,train\n0,0,1,1,1,0,0,0,0,0,0,validation\n");
    let (e, msg) = expect_err(&text);
    assert!(matches!(e, DatasetError::UnknownSet { line: 3, ref label } if label == "validation"));
    assert!(msg.contains("'validation'"), "{msg}");
}

#[test]
fn other_structural_errors() {
    // Unparseable number.
    let text = format!("{HEADER}\n0,0,1,1,abc,0,0,0,0,0,0\n");
    assert!(
        matches!(expect_err(&text).0, DatasetError::Parse { line: 2, ref column, .. } if column == "fz")
    );
    // Non-integer pose.
    let text = format!("{HEADER},pose\n0,0,1,1,1,0,0,0,0,0,0,1.5\n");
    assert!(
        matches!(expect_err(&text).0, DatasetError::Parse { ref column, .. } if column == "pose")
    );
    // Row with a missing field.
    let text = format!("{HEADER}\n0,0,1,1,1,0,0,0,0,0\n");
    assert!(matches!(expect_err(&text).0, DatasetError::Csv { .. }));
    // Unknown and duplicate columns, partial rotation, empty file.
    let text = format!("{HEADER},temperature\n0,0,1,1,1,0,0,0,0,0,0,20\n");
    assert!(
        matches!(expect_err(&text).0, DatasetError::UnknownColumn { ref column } if column == "temperature")
    );
    let text = format!("{HEADER},dx\n0,0,1,1,1,0,0,0,0,0,0,0\n");
    assert!(matches!(
        expect_err(&text).0,
        DatasetError::DuplicateColumn { .. }
    ));
    let text = format!("{HEADER},rx\n0,0,1,1,1,0,0,0,0,0,0,0\n");
    assert!(matches!(
        expect_err(&text).0,
        DatasetError::PartialRotation { .. }
    ));
    assert!(matches!(
        expect_err(&format!("{HEADER}\n")).0,
        DatasetError::Empty
    ));
    // A set column with only training rows cannot be split.
    let text = format!("{HEADER},set\n0,0,1,1,1,0,0,0,1e-4,0,0,train\n");
    let d = read(&text).unwrap();
    assert!(matches!(
        d.split(0.25, 0),
        Err(DatasetError::EmptySplit {
            which: SetLabel::Test
        })
    ));
}

#[test]
fn in_memory_shapes_are_checked() {
    let e = Dataset::new(
        2,
        vec![0.0; 5],
        vec![0.0; 12],
        vec![0.0; 6],
        None,
        None,
        None,
    )
    .unwrap_err();
    assert!(matches!(e, DatasetError::Shape { name: "q", .. }), "{e}");
    let e = Dataset::new(
        2,
        vec![0.0; 6],
        vec![0.0; 12],
        vec![0.0; 6],
        None,
        None,
        None,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            DatasetError::JointCount {
                found: 3,
                expected: 2
            }
        ),
        "{e}"
    );
    let e = Dataset::new(
        2,
        vec![0.0; 4],
        vec![0.0; 11],
        vec![0.0; 6],
        None,
        None,
        None,
    )
    .unwrap_err();
    assert!(
        matches!(e, DatasetError::Shape { name: "wrench", .. }),
        "{e}"
    );
}

#[test]
fn a_failed_write_leaves_nothing_behind() {
    let d = read(&good_rows()).unwrap();
    let dir = std::env::temp_dir().join(format!("vjm-nodir-{}", std::process::id()));
    let path = dir.join("sub").join("out.csv");
    assert!(matches!(d.write_csv(&path), Err(DatasetError::Io { .. })));
    assert!(!path.exists());
}

/// A campaign over borrowed columns (the Python package's numpy arrays, not copied) is the same
/// dataset as its owned copy, diagnoses identically, and is validated the same way.
#[test]
fn borrowed_columns_are_the_same_dataset_as_owned_ones() {
    use std::borrow::Cow;
    use vjm::diagnose::{diagnose, DiagnoseOptions};

    let (chain, owned) = crate::strategies::nominal_panda_campaign(24, 4, 5);
    let n = owned.len();
    let rotation: Option<Vec<f64>> = (0..n)
        .map(|i| owned.rotation(i))
        .collect::<Option<Vec<[f64; 3]>>>()
        .map(|r| r.concat());
    let pose: Vec<i64> = (0..n).map(|i| owned.pose(i).unwrap()).collect();
    let set: Option<Vec<SetLabel>> = (0..n).map(|i| owned.set(i)).collect();
    let borrowed = Dataset::from_columns(
        7,
        Cow::Borrowed(owned.q_flat()),
        Cow::Borrowed(owned.wrench_flat()),
        Cow::Borrowed(owned.displacement_flat()),
        rotation.as_deref().map(Cow::Borrowed),
        Some(Cow::Borrowed(&pose[..])),
        set,
    )
    .unwrap();
    assert_eq!(borrowed, owned);
    assert_eq!(borrowed.clone().into_owned(), owned);
    let opts = DiagnoseOptions::default();
    let a = diagnose(&chain, &owned, &opts).unwrap();
    let b = diagnose(&chain, &borrowed, &opts).unwrap();
    assert_eq!(format!("{a:?}"), format!("{b:?}"));

    // A NaN in a borrowed column is named by line and column, as in a file.
    let mut q = owned.q_flat().to_vec();
    q[3 * 7 + 2] = f64::NAN;
    let e = Dataset::from_columns(
        7,
        Cow::Borrowed(&q[..]),
        Cow::Borrowed(owned.wrench_flat()),
        Cow::Borrowed(owned.displacement_flat()),
        None,
        None,
        None,
    )
    .unwrap_err();
    assert!(
        matches!(&e, DatasetError::NonFinite { line: 5, column, .. } if column == "q3"),
        "{e}"
    );
}
