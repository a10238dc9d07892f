//! Smoke test of the diagnose study's machinery (the full study is a release binary, not run
//! in CI): the binomial interval against closed forms, and two seeds of a few cells on the
//! bundled Panda, whose counts must be consistent and whose strongest effects must be seen.

use robot_stiffness_tests::study::effects::{named, Hidden};
use robot_stiffness_tests::study::robots::load_robot;
use robot_stiffness_tests::study::run::{run_cell, run_csjm};
use robot_stiffness_tests::study::stats::clopper_pearson;

#[test]
fn clopper_pearson_matches_closed_forms() {
    // k = 0: upper = 1 − (α/2)^(1/n); k = n: lower = (α/2)^(1/n).
    let (lo, hi) = clopper_pearson(0, 50, 0.05);
    assert_eq!(lo, 0.0);
    assert!(
        (hi - (1.0 - 0.025f64.powf(1.0 / 50.0))).abs() < 1e-12,
        "{hi}"
    );
    let (lo, hi) = clopper_pearson(50, 50, 0.05);
    assert_eq!(hi, 1.0);
    assert!((lo - 0.025f64.powf(1.0 / 50.0)).abs() < 1e-12, "{lo}");
    // n = 1, k = 0 and 1 are the same closed form; the interval of k/n = 1/2 is symmetric.
    let (lo, hi) = clopper_pearson(25, 50, 0.05);
    assert!((lo + hi - 1.0).abs() < 1e-12);
    // Published value (e.g. R's binom.test(5, 50)): [0.03327, 0.21813].
    let (lo, hi) = clopper_pearson(5, 50, 0.05);
    assert!(
        (lo - 0.03327).abs() < 5e-5 && (hi - 0.21813).abs() < 5e-5,
        "{lo} {hi}"
    );
    assert_eq!(clopper_pearson(0, 0, 0.05), (0.0, 1.0));
}

#[test]
fn smoke_two_seeds_on_the_panda() {
    let panda = load_robot("panda").unwrap();
    let mut calls = 0;
    for hidden in [
        Hidden::Clean,
        Hidden::Tilt(0.3),
        Hidden::TorsionNonlinear(3.0),
        Hidden::Drift(100.0),
        Hidden::Mount(1e5),
    ] {
        let r = run_cell(&panda, &hidden, 10e-6, 0.01, 20_000, 2, &mut |_| calls += 1).unwrap();
        for (k, c) in r.iter().enumerate() {
            assert_eq!(c.runs, 2);
            assert_eq!(c.noise_given, k == 1);
            assert!(c.detected <= 2 && c.alarm <= 2);
            assert!(c.alarm >= c.any_finding.max(c.unexplained));
            let labels: usize = c.verdicts.values().sum();
            assert!(labels >= c.alarm, "{c:?}");
        }
        // A 100 µm pose drift under 10 µm tracker noise is ~10σ per pose: flagged every time
        // when diagnose knows the noise.
        if hidden == Hidden::Drift(100.0) {
            assert_eq!(r[1].detected, 2, "{:?}", r[1]);
        }
        if hidden == Hidden::Tilt(0.3) {
            assert_eq!(r[1].detected, 2, "{:?}", r[1]);
        }
    }
    assert_eq!(calls, 10);
    let c = run_csjm(10_000, 2).unwrap();
    assert_eq!(c.runs, 2);
    assert!(c.alarm <= 2);
    let _ = named; // re-exported for the binary's users
}

#[test]
fn unknown_robot_is_a_named_error() {
    let e = load_robot("puma").unwrap_err().to_string();
    assert!(e.contains("puma") && e.contains("panda"), "{e}");
}
