//! `dataset::check_arrays` (the one-pass, parallel checks of in-memory arrays) gives the same
//! first error as `check_values` followed by `check_joint_limits`, whichever rows are bad.

use vjm::dataset::{check_arrays, check_joint_limits, check_values, ArraysCheck};
use vjm::Measurements;
use vjm::SerialChain;

use crate::strategies::{random_configurations, random_wrenches};

const ROWS: usize = 40_003; // three parallel tasks and a partial one

fn arrays(chain: &SerialChain) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let q = random_configurations(chain, ROWS, 5);
    let w = random_wrenches(ROWS, 6);
    let d: Vec<f64> = (0..3 * ROWS)
        .map(|i| 1e-4 * ((i % 7) as f64 - 3.0))
        .collect();
    let r: Vec<f64> = (0..3 * ROWS)
        .map(|i| 1e-5 * ((i % 5) as f64 - 2.0))
        .collect();
    (q, w, d, r)
}

/// The sequential reference: values first, then the joint limits.
fn sequential(chain: &SerialChain, q: &[f64], w: &[f64], d: &[f64], r: Option<&[f64]>) -> String {
    match check_values(7, Measurements::new(q, w, d).with_rotation(r))
        .and_then(|_| check_joint_limits(chain, q))
    {
        Ok(()) => "ok".into(),
        Err(e) => e.to_string(),
    }
}

#[test]
fn same_first_error_as_the_sequential_checks() {
    let chain = SerialChain::bundled();
    let (q0, w0, d0, r0) = arrays(&chain);
    assert_eq!(
        check_arrays(
            7,
            Measurements::new(&q0, &w0, &d0).with_rotation(Some(&r0)),
            Some(&chain)
        )
        .unwrap(),
        ArraysCheck::Passed
    );
    type Edit = fn(&mut [f64], &mut [f64], &mut [f64], &mut [f64]);
    let cases: [(&str, Edit); 8] = [
        ("displacement in mm, late row", |_, _, d, _| {
            d[3 * 39_000 + 1] = 2.0
        }),
        ("force too large, early row", |_, w, _, _| {
            w[6 * 17 + 2] = 2e5
        }),
        ("moment too large", |_, w, _, _| w[6 * 20_000 + 4] = 2e4),
        ("rotation too large", |_, _, _, r| r[3 * 33_333] = 0.5),
        ("angle outside limits", |q, _, _, _| q[7 * 25_000 + 3] = 0.5),
        (
            "outside limits before an implausible value",
            |q, _, d, _| {
                q[7 * 10 + 1] = 2.0;
                d[3 * 30_000] = 1.0;
            },
        ),
        (
            "two implausible values, the earlier row wins",
            |_, w, d, _| {
                d[3 * 30_000] = 1.0;
                w[6 * 20_000] = 1e6;
            },
        ),
        ("no load", |_, w, _, _| w.iter_mut().for_each(|v| *v = 0.0)),
    ];
    for (name, edit) in cases {
        let (mut q, mut w, mut d, mut r) = (q0.clone(), w0.clone(), d0.clone(), r0.clone());
        edit(&mut q, &mut w, &mut d, &mut r);
        let expect = sequential(&chain, &q, &w, &d, Some(&r));
        assert_ne!(expect, "ok", "{name}: the edit must break a check");
        let got = check_arrays(
            7,
            Measurements::new(&q, &w, &d).with_rotation(Some(&r)),
            Some(&chain),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(got, expect, "{name}");
    }
    // Without a chain the limits are not checked.
    let mut q = q0.clone();
    q[7 * 25_000 + 3] = 0.5;
    assert_eq!(
        check_arrays(7, Measurements::new(&q, &w0, &d0), None).unwrap(),
        ArraysCheck::Passed
    );
    // A non-finite value anywhere: nothing else is reported (identify names it).
    let mut d = d0.clone();
    d[0] = 1.0; // implausible, but
    d[3 * 40_000 + 2] = f64::NAN; // a NaN further down wins
    assert_eq!(
        check_arrays(7, Measurements::new(&q0, &w0, &d), Some(&chain)).unwrap(),
        ArraysCheck::NonFinite
    );
}

/// The fused row check sees every row exactly once, changes nothing when it passes, and
/// abandons the identification when it fails, for both reductions.
#[test]
fn identify_checking_rows_covers_every_row_once() {
    use std::sync::Mutex;
    use vjm::{identify, identify_checking_rows, IdentifyOptions, SolveMethod, VirtualJointModel};
    let chain = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let (q, w, _, _) = arrays(&chain);
    let c = [1e-4, 1e-4, 1.5e-4, 1.5e-4, 3e-4, 4e-4, 5e-4];
    let mut d = Vec::with_capacity(3 * ROWS);
    for i in 0..ROWS {
        let mut f = [0.0; 6];
        f.copy_from_slice(&w[6 * i..6 * i + 6]);
        let x =
            vjm::predict_deflection(&chain, &model, &c, &q[7 * i..7 * i + 7], &f, false).unwrap();
        d.extend_from_slice(&[x[0] + 1e-6 * ((i % 3) as f64 - 1.0), x[1], x[2]]);
    }
    for method in [SolveMethod::Auto, SolveMethod::Qr] {
        let mut opts = IdentifyOptions::default();
        opts.method = method;
        let seen = Mutex::new(Vec::new());
        let record = |s: usize, e: usize| {
            seen.lock().unwrap().push((s, e));
            true
        };
        let fused = identify_checking_rows(
            &chain,
            &model,
            Measurements::new(&q, &w, &d),
            &opts,
            &record,
        )
        .unwrap()
        .expect("every chunk passed");
        let plain = identify(&chain, &model, Measurements::new(&q, &w, &d), &opts).unwrap();
        assert_eq!(fused.compliance, plain.compliance, "{method:?}");
        assert_eq!(fused.stderr, plain.stderr, "{method:?}");
        let mut ranges = seen.into_inner().unwrap();
        ranges.sort_unstable();
        assert_eq!(ranges.first().map(|r| r.0), Some(0));
        assert_eq!(ranges.last().map(|r| r.1), Some(ROWS));
        assert!(
            ranges.windows(2).all(|p| p[0].1 == p[1].0),
            "{method:?}: gaps or overlaps"
        );
        let refuse_late = |s: usize, e: usize| !(s..e).contains(&39_999);
        assert!(identify_checking_rows(
            &chain,
            &model,
            Measurements::new(&q, &w, &d),
            &opts,
            &refuse_late
        )
        .unwrap()
        .is_none());
    }
}
