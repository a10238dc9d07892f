//! The seed paper's Table I study (Hu, Wang, Pan): the two error metrics pinned by hand, the
//! truth calibrated to the seed's torsion share, and the study's figures next to the seed's.

use vjm::testbed::{
    magnitude_error, paper_link_compliances, paper_link_share, paper_structural_link_share,
    paper_structural_truth, paper_study, paper_tilt_ratio, paper_torsion_share, paper_truth,
    vector_error, Effect, PaperStudy, TrueModel, NOMINAL_TORSION, PAPER_FIGURES,
    PAPER_TORSION_SHARE,
};
use vjm::SerialChain;
use vjm::{spring_axes, SpringAxis};

#[test]
fn the_two_metrics_by_hand() {
    // meas = (3, 4, 0): ‖meas‖ = 5.
    let meas = [3.0, 4.0, 0.0];
    // pred = (0, 5, 0): same length, other direction. Magnitude |5 − 5|/5 = 0;
    // vector ‖(−3, 1, 0)‖/5 = √10/5 = 0.632455532...
    let pred = [0.0, 5.0, 0.0];
    assert_eq!(magnitude_error(&pred, &meas), 0.0);
    assert!((vector_error(&pred, &meas) - 0.632_455_532_033_675_9).abs() < 1e-15);
    // pred = (3, 4, 12): ‖pred‖ = 13. Magnitude |13 − 5|/5 = 1.6;
    // vector ‖(0, 0, 12)‖/5 = 2.4.
    let pred = [3.0, 4.0, 12.0];
    assert!((magnitude_error(&pred, &meas) - 1.6).abs() < 1e-15);
    assert!((vector_error(&pred, &meas) - 2.4).abs() < 1e-15);
    // pred = 0.9 · meas: both metrics are 0.1.
    let pred = [2.7, 3.6, 0.0];
    assert!((magnitude_error(&pred, &meas) - 0.1).abs() < 1e-15);
    assert!((vector_error(&pred, &meas) - 0.1).abs() < 1e-15);
}

fn print(name: &str, s: &PaperStudy) {
    for (model, e) in [
        ("traditional", &s.traditional),
        ("extended", &s.extended),
        ("full", &s.full),
    ] {
        for (metric, m) in [("magnitude", &e.magnitude), ("vector", &e.vector)] {
            println!(
                "seed study ({name}) {model:11} {metric:9}: identification {:6.2} %, verification {:6.2} %, \
                 all 26 {:6.2} %, verification max {:6.2} % at test {}",
                100.0 * m.identification,
                100.0 * m.verification,
                100.0 * m.all,
                100.0 * m.verification_max,
                m.verification_max_test
            );
        }
    }
    println!(
        "seed study ({name}): torsion share {:.2} %, link share {:.2} %, extended rank {}, full \
         rank {}, {} angles clipped (seed, magnitude: all 26 {:.2} % → {:.2} %, verification max \
         extended {:.1} % at test {})",
        100.0 * s.torsion_share,
        100.0 * s.link_share,
        s.extended_rank,
        s.full_rank,
        s.clipped.len(),
        100.0 * s.paper.traditional_all,
        100.0 * s.paper.extended_all,
        100.0 * s.paper.extended_verification_max,
        s.paper.extended_verification_max_test
    );
}

#[test]
fn paper_study_reports_both_metrics_per_row_and_as_means() {
    let chain = SerialChain::bundled();
    let (truth, ratio) = paper_truth(&chain).unwrap();
    println!("calibrated tilt ratio {ratio:.6}");
    let quiet = paper_study(&chain, &truth, false, 0).unwrap();
    let noisy = paper_study(&chain, &truth, true, 0).unwrap();
    print("noise-free", &quiet);
    print("noisy", &noisy);
    for s in [&quiet, &noisy] {
        assert_eq!(s.rows.len(), 26);
        for (i, r) in s.rows.iter().enumerate() {
            // The seed's numbering: configuration c under load l is test 2(c − 1) + l.
            assert_eq!(r.test, i + 1);
            assert_eq!(r.test, 2 * (r.configuration - 1) + r.load);
            assert_eq!(r.identification, r.configuration <= 8);
            // Per-row errors are the metrics of the row's vectors; |‖a‖−‖b‖| ≤ ‖a−b‖.
            assert_eq!(
                r.traditional_magnitude_error,
                magnitude_error(&r.traditional, &r.measured)
            );
            assert_eq!(
                r.extended_vector_error,
                vector_error(&r.extended, &r.measured)
            );
            assert!(r.traditional_magnitude_error <= r.traditional_vector_error + 1e-15);
            assert!(r.extended_magnitude_error <= r.extended_vector_error + 1e-15);
        }
        // The summaries are means / maxima of the per-row values.
        let mean = |keep: fn(usize) -> bool| {
            let e: Vec<f64> = s
                .rows
                .iter()
                .filter(|r| keep(r.test))
                .map(|r| r.traditional_magnitude_error)
                .collect();
            e.iter().sum::<f64>() / e.len() as f64
        };
        let m = &s.traditional.magnitude;
        assert!((m.identification - mean(|t| t <= 16)).abs() < 1e-15);
        assert!((m.verification - mean(|t| t > 16)).abs() < 1e-15);
        assert!((m.all - mean(|_| true)).abs() < 1e-15);
        let worst = s.rows[16..]
            .iter()
            .max_by(|a, b| a.extended_vector_error.total_cmp(&b.extended_vector_error))
            .unwrap();
        assert_eq!(s.extended.vector.verification_max_test, worst.test);
        assert_eq!(
            s.extended.vector.verification_max,
            worst.extended_vector_error
        );
        assert!(s.extended.vector.verification_max_test > 16);
    }
    // Noise-free, the extended model contains the truth: exact on every row.
    assert!(quiet.extended.vector.all < 1e-9);
    assert!(quiet.traditional.magnitude.all > 0.02);
    assert!(noisy.extended.magnitude.all < noisy.traditional.magnitude.all);
    assert!(noisy.extended.vector.all < noisy.traditional.vector.all);
    // The magnitude hides the error of direction: well below the vector error.
    assert!(quiet.traditional.magnitude.all < 0.8 * quiet.traditional.vector.all);
    assert!((quiet.torsion_share - PAPER_TORSION_SHARE).abs() < 1e-3);
    assert!(
        !quiet.clipped.is_empty(),
        "Table I exceeds the Panda's joint 4/6 limits"
    );
}

#[test]
fn the_truth_is_calibrated_to_the_seed_torsion_share() {
    let chain = SerialChain::bundled();
    let (truth, ratio) = paper_truth(&chain).unwrap();
    let share = paper_torsion_share(&chain, &truth).unwrap();
    assert!((share - 0.765).abs() < 1e-3, "share {share}");
    assert!(ratio > 0.0);
    // The share is the seed's: over the 13 configurations under the Section IV-B load.
    let torsion_only = TrueModel::torsion_only(&NOMINAL_TORSION);
    assert_eq!(paper_torsion_share(&chain, &torsion_only).unwrap(), 1.0);
    // The study's former fixed ratio 0.3 does not give the seed's share (the check can fail).
    let fixed = TrueModel::with_tilts(&NOMINAL_TORSION, 0.3);
    let fixed_share = paper_torsion_share(&chain, &fixed).unwrap();
    println!(
        "torsion share at tilt ratio 0.3: {:.2} %",
        100.0 * fixed_share
    );
    assert!((fixed_share - 0.765).abs() > 0.01);
    // Other targets are reached too, and bad targets are refused by name.
    let r = paper_tilt_ratio(&chain, &NOMINAL_TORSION, 0.6).unwrap();
    let s = paper_torsion_share(&chain, &TrueModel::with_tilts(&NOMINAL_TORSION, r)).unwrap();
    assert!((s - 0.6).abs() < 1e-6);
    for bad in [0.0, 1.0, f64::NAN, -0.2] {
        let e = paper_tilt_ratio(&chain, &NOMINAL_TORSION, bad).unwrap_err();
        assert!(e.to_string().contains("share"), "{e}");
    }
    assert!(paper_tilt_ratio(&chain, &NOMINAL_TORSION[..6], 0.7).is_err());
}

#[test]
fn a_link_translation_moves_the_tip_along_its_axis_by_the_force_it_carries() {
    // Independent path: the axis from the chain's own joint frames and the convention's spring
    // axes, against the testbed's displacement (which takes it from the deflected Jacobian).
    let chain = SerialChain::bundled();
    let q = [0.3, -0.4, 0.2, -1.9, 0.5, 1.6, -0.7];
    let wrench = [12.0, -30.0, 21.0, 1.5, -2.0, 0.7];
    let f = nalgebra::Vector3::new(wrench[0], wrench[1], wrench[2]);
    let frames = chain.joint_frames(&q).unwrap();
    for (joint, axis) in [(1, SpringAxis::X), (3, SpringAxis::Z), (5, SpringAxis::Y)] {
        let c = 2.5e-7;
        let truth = TrueModel {
            compliance: vec![0.0; 21],
            effects: vec![Effect::LinkTranslation {
                joint,
                axis,
                compliance: c,
            }],
        };
        let a = frames[joint].rotation * spring_axes(chain.joints()[joint].axis())[axis.index()];
        let expected = a * (c * a.dot(&f));
        let (d, _) = truth.displacement(&chain, &q, &wrench);
        assert!(
            (d - expected).norm() <= 1e-15 + 1e-12 * expected.norm(),
            "J{}{axis}: {d:?} vs {expected:?}",
            joint + 1
        );
        // The moment does not load a translation: a pure moment moves nothing.
        let (d_m, _) = truth.displacement(&chain, &q, &[0.0, 0.0, 0.0, 3.0, -1.0, 2.0]);
        assert_eq!(d_m.norm(), 0.0);
    }
}

#[test]
fn link_compliances_are_cantilevers_across_the_link() {
    let chain = SerialChain::bundled();
    let c = paper_link_compliances(&chain, 2.0e-6);
    // The Panda's longest link runs from joint 4 to joint 5: (−0.0825, 0.384, 0) m in joint
    // 4's frame, whose spring axes are [z, x, y]. Across it: the full scale on z (⊥ to the
    // link), scale·(1 − (0.0825/L)²) on x and scale·(1 − (0.384/L)²) on y.
    let l2 = 0.0825_f64.powi(2) + 0.384_f64.powi(2);
    assert!((c[3][0] - 2.0e-6).abs() < 1e-18, "{:?}", c[3]);
    assert!((c[3][1] - 2.0e-6 * (1.0 - 0.0825 * 0.0825 / l2)).abs() < 1e-18);
    assert!((c[3][2] - 2.0e-6 * (1.0 - 0.384 * 0.384 / l2)).abs() < 1e-18);
    // Coincident joint origins (joints 1–2, 5–6) make rigid links.
    assert_eq!(c[0], [0.0; 3]);
    assert_eq!(c[4], [0.0; 3]);
    // Joint 2 → 3 is 0.316 m along joint 2's −y: (0.316/L₄)³ of the scale across, 0 along.
    let r = (0.316_f64 / l2.sqrt()).powi(3) * 2.0e-6;
    assert!((c[1][0] - r).abs() < 1e-18 && (c[1][1] - r).abs() < 1e-18 && c[1][2] == 0.0);
}

#[test]
fn the_structural_truth_has_the_seed_torsion_share_and_the_asked_link_share() {
    let chain = SerialChain::bundled();
    for share in [0.03, 0.1] {
        let t = paper_structural_truth(&chain, share).unwrap();
        let torsion = paper_torsion_share(&chain, &t.truth).unwrap();
        let links = paper_link_share(&chain, &t.truth).unwrap();
        assert!((torsion - PAPER_TORSION_SHARE).abs() < 1e-6, "{torsion}");
        assert!((links - share).abs() < 1e-6, "{links}");
        // The links take part of what the tilts carried without them.
        let (_, plain) = paper_truth(&chain).unwrap();
        assert!(t.tilt_ratio < plain && t.tilt_ratio > 0.0);
    }
    // A joints-only truth has no link share; impossible targets are refused by name.
    let (plain, _) = paper_truth(&chain).unwrap();
    assert_eq!(paper_link_share(&chain, &plain).unwrap(), 0.0);
    for bad in [0.0, 1.0, f64::NAN] {
        let e = paper_structural_truth(&chain, bad).unwrap_err();
        assert!(e.to_string().contains("link share"), "{e}");
    }
    let e = paper_structural_truth(&chain, 0.9).unwrap_err();
    assert!(e.to_string().contains("the most is"), "{e}");
}

#[test]
fn with_compliant_links_the_full_model_recovers_what_the_extended_model_misses() {
    let chain = SerialChain::bundled();
    let share = paper_structural_link_share(&chain).unwrap();
    let t = paper_structural_truth(&chain, share).unwrap();
    println!(
        "structural truth: link share {:.2} %, tilt ratio {:.4}, link scale {:.3e} m/N",
        100.0 * share,
        t.tilt_ratio,
        t.link_scale
    );
    let quiet = paper_study(&chain, &t.truth, false, 0).unwrap();
    let noisy = paper_study(&chain, &t.truth, true, 0).unwrap();
    print("links, noise-free", &quiet);
    print("links, noisy", &noisy);
    // Calibrated: the extended model keeps the seed's 3.74 % on noise-free data.
    assert!((quiet.extended.magnitude.all - PAPER_FIGURES.extended_all).abs() < 1e-5);
    // The full model contains the truth: exact without noise, and the better model with it.
    assert!(quiet.full.vector.all < 1e-9, "{}", quiet.full.vector.all);
    assert!(noisy.full.vector.all < noisy.extended.vector.all);
    assert!(noisy.full.magnitude.verification < noisy.extended.magnitude.verification);
    // Identifiable directions: 14 rotations, and translations add rank (≤ 42).
    assert_eq!(quiet.extended_rank, 14);
    assert!(quiet.full_rank > quiet.extended_rank && quiet.full_rank <= 42);
    // The structure beyond the joints is what the extended model misses: with joint springs
    // only it is exact (the previous test), here it is not.
    assert!(quiet.extended.vector.all > 0.01);
    // Not calibrated: the traditional model's error lands near the seed's 7.75 % (within 1.5
    // points), a check of the truth's structure rather than a target.
    assert!(
        (quiet.traditional.magnitude.all - PAPER_FIGURES.traditional_all).abs() < 0.015,
        "{}",
        quiet.traditional.magnitude.all
    );
}
