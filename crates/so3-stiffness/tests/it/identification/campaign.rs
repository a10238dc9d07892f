//! The virtual campaign (issue 4 item 6) and the acceptance numbers. Every figure asserted
//! here is printed (run with `--nocapture` to see them).

use nalgebra::Matrix3;
use so3_stiffness::csjm::PointLoad;
use so3_stiffness::identification::campaign::{
    prototype_simulator, simulate_campaign, Campaign, CampaignConfig, GravityRecording,
    LoadPattern, MomentNoise, TrackerNoise,
};
use so3_stiffness::identification::{
    identify, ConnectionTerm, FitOptions, FitOrder, IdentificationError,
};

const SEEDS: [u64; 4] = [1, 2, 3, 4];

fn rel(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

fn campaign(config: &CampaignConfig) -> Campaign {
    simulate_campaign(&prototype_simulator().unwrap(), config).unwrap()
}

fn error_of(c: &Campaign, order: FitOrder) -> f64 {
    let e = identify(&c.dataset, &FitOptions::with_order(order)).unwrap();
    rel(&e.k, &c.true_stiffness.covariant)
}

#[test]
fn noise_free_small_increments_recover_the_true_covariant_stiffness() {
    let mut config = CampaignConfig::with_seed(9);
    config.schedule.tracker = TrackerNoise::none();
    config.schedule.moment_noise = MomentNoise::none();
    config.schedule.max_increment = 0.01;
    config.schedule.increments = 30;
    let c = campaign(&config);
    let k_true = c.true_stiffness.covariant;
    let e = identify(&c.dataset, &FitOptions::with_order(FitOrder::Second)).unwrap();
    println!(
        "noise-free: rel error K {:.2e}, K_D {:.2e}",
        rel(&e.k, &k_true),
        rel(&e.k_d, &c.true_stiffness.euclidean)
    );
    assert!(rel(&e.k, &k_true) < 1e-6);
    assert!(rel(&e.k_d, &c.true_stiffness.euclidean) < 1e-6);
    assert!((e.tau0 - c.true_tau0).norm() < 1e-9);
    // The seed's connection term misses the symmetric truth by ½‖hat τ₀‖.
    let mut seed = FitOptions::with_order(FitOrder::Second);
    seed.connection = ConnectionTerm::PaperEq48b;
    let e_seed = identify(&c.dataset, &seed).unwrap();
    println!(
        "noise-free: seed eq. 48b rel error {:.3}, asymmetry {:.3}",
        rel(&e_seed.k, &k_true),
        e_seed.asymmetry()
    );
    assert!(rel(&e_seed.k, &k_true) > 0.03);
}

#[test]
fn first_order_fit_within_3_percent_for_1_nm_increments() {
    for seed in SEEDS {
        let c = campaign(&CampaignConfig::with_seed(seed));
        let err = error_of(&c, FitOrder::First);
        println!(
            "seed {seed}: 85 increments ≤ 1 N·m, first-order rel. Frobenius error {:.4}",
            err
        );
        assert!(err < 0.03, "seed {seed}: {err}");
    }
}

/// Increments up to 3 N·m, symmetric loading (the default): the second-order fit stays within
/// 3 %. (So does the first-order fit on this prototype: with loads in both senses the even
/// curvature cancels; see the one-sided test below and docs/csjm-identification.md.)
#[test]
fn second_order_fit_within_3_percent_for_3_nm_increments() {
    for seed in SEEDS {
        let mut config = CampaignConfig::with_seed(seed);
        config.schedule.max_increment = 3.0;
        let c = campaign(&config);
        let first = error_of(&c, FitOrder::First);
        let second = error_of(&c, FitOrder::Second);
        println!("seed {seed}: symmetric increments ≤ 3 N·m: first-order {first:.4}, second-order {second:.4}");
        assert!(second < 0.03, "seed {seed}: second {second}");
    }
}

/// One-sided loading (counterweights), noise-free so that only the model bias remains: the
/// first-order bias grows with the increment size and the second-order fit removes it.
#[test]
fn second_order_fit_removes_the_curvature_bias_of_one_sided_loading() {
    for seed in SEEDS {
        let bias = |m: f64, order: FitOrder| {
            let mut config = CampaignConfig::with_seed(seed);
            config.schedule.pattern = LoadPattern::OneSided;
            config.schedule.max_increment = m;
            config.schedule.tracker = TrackerNoise::none();
            config.schedule.moment_noise = MomentNoise::none();
            error_of(&campaign(&config), order)
        };
        let (first_1, first_3) = (bias(1.0, FitOrder::First), bias(3.0, FitOrder::First));
        let (second_1, second_3) = (bias(1.0, FitOrder::Second), bias(3.0, FitOrder::Second));
        println!(
            "seed {seed}: one-sided, noise-free bias: first-order {first_1:.4} (≤1 N·m) {first_3:.4} (≤3 N·m); \
             second-order {second_1:.4} {second_3:.4}"
        );
        assert!(
            first_3 > 2.5 * first_1,
            "first-order bias grows with the increments"
        );
        assert!(first_3 > 0.01);
        assert!(second_3 < 0.25 * first_3 && second_3 < 0.005);
        assert!(second_1 < 0.25 * first_1);
    }
}

/// Fig. 5: det(K) against N settles as N grows.
#[test]
fn det_k_converges_with_the_number_of_measurements() {
    for seed in SEEDS {
        let c = campaign(&CampaignConfig::with_seed(seed));
        let e = identify(&c.dataset, &FitOptions::default()).unwrap();
        let dets: Vec<f64> = e.det_convergence.iter().map(|p| p.det).collect();
        assert_eq!(e.det_convergence.last().map(|p| p.n), Some(85));
        let quarter = dets.len() / 4;
        let spread = |s: &[f64]| {
            s.iter().cloned().fold(f64::MIN, f64::max) - s.iter().cloned().fold(f64::MAX, f64::min)
        };
        let (first, last) = (
            spread(&dets[..quarter]),
            spread(&dets[dets.len() - quarter..]),
        );
        let det_true = c.true_stiffness.covariant.determinant();
        println!(
            "seed {seed}: det K spread first quarter {first:.1}, last quarter {last:.1}; final {:.1} vs true {det_true:.1}",
            dets[dets.len() - 1]
        );
        assert!(last < 0.25 * first, "seed {seed}");
        assert!((dets[dets.len() - 1] - det_true).abs() < 0.1 * det_true);
    }
}

/// Verification (eqs. 61–65) on simulated poses: measured A-frame increments follow K_D, so
/// predicting with K_D (what `StiffnessEstimate::predict_pose` does) beats eq. 61's K⁻¹.
#[test]
fn predictions_from_k_d_match_the_true_poses_better_than_k() {
    let mut config = CampaignConfig::with_seed(8);
    config.schedule.tracker = TrackerNoise::none();
    config.schedule.moment_noise = MomentNoise::none();
    config.schedule.max_increment = 0.3;
    config.schedule.increments = 30;
    let c = campaign(&config);
    let e = identify(&c.dataset, &FitOptions::with_order(FitOrder::Second)).unwrap();
    let r0 = c.dataset.reference().orientation;
    let (mut worst_kd, mut best_k) = (0.0f64, f64::MAX);
    for (m, r_true) in c.dataset.measurements().iter().zip(&c.true_poses) {
        let dtau = m.moment - c.dataset.reference().moment;
        let with_kd = e.verify(&r0, &dtau, r_true).unwrap().e_theta;
        let with_k = so3_stiffness::identification::verify(&r0, &e.k, &dtau, r_true)
            .unwrap()
            .e_theta;
        let angle = so3_stiffness::so3::distance(&r0, r_true);
        worst_kd = worst_kd.max(with_kd / angle);
        best_k = best_k.min(with_k / angle);
    }
    println!("verification: E_θ/‖Δζ‖ worst with K_D {worst_kd:.2e}, best with K {best_k:.2e}");
    assert!(worst_kd < 0.01);
    assert!(worst_kd < best_k);
}

#[test]
fn recorded_gravity_is_harmless_and_omitted_gravity_biases_k() {
    let weight = PointLoad::prototype_gravity();
    let mut recorded = CampaignConfig::with_seed(5);
    recorded.gravity = GravityRecording::Recorded(weight);
    recorded.schedule.tracker = TrackerNoise::none();
    recorded.schedule.moment_noise = MomentNoise::none();
    recorded.schedule.max_increment = 0.05;
    let mut omitted = recorded;
    omitted.gravity = GravityRecording::Omitted(weight);
    let (c_rec, c_omit) = (campaign(&recorded), campaign(&omitted));
    let (e_rec, e_omit) = (
        error_of(&c_rec, FitOrder::Second),
        error_of(&c_omit, FitOrder::Second),
    );
    println!("gravity recorded: rel error {e_rec:.2e}; omitted: {e_omit:.4}");
    assert!(e_rec < 1e-4);
    assert!(e_omit > 100.0 * e_rec && e_omit > 3e-3);
}

#[test]
fn cable_hysteresis_biases_k() {
    let mut config = CampaignConfig::with_seed(6);
    config.schedule.tracker = TrackerNoise::none();
    config.schedule.moment_noise = MomentNoise::none();
    let clean = error_of(&campaign(&config), FitOrder::First);
    config.hysteresis_moment = 0.05;
    let with = error_of(&campaign(&config), FitOrder::First);
    println!("hysteresis 0.05 N·m: rel error {with:.4} (none: {clean:.4})");
    assert!(with > clean + 0.01);
}

#[test]
fn campaigns_are_reproducible_and_symmetric_pattern_is_available() {
    let a = campaign(&CampaignConfig::with_seed(3));
    let b = campaign(&CampaignConfig::with_seed(3));
    assert_eq!(a.dataset, b.dataset);
    let c = campaign(&CampaignConfig::with_seed(4));
    assert_ne!(a.dataset, c.dataset);
    for (pattern, lowest) in [
        (LoadPattern::Symmetric, -1.0),
        (LoadPattern::OneSided, -0.25),
    ] {
        let mut config = CampaignConfig::with_seed(3);
        config.schedule.pattern = pattern;
        let c = campaign(&config);
        let d: Vec<_> = c
            .applied
            .iter()
            .map(|t| t - config.schedule.preload)
            .collect();
        assert!(d.iter().all(|v| v.norm() <= 1.0 + 1e-12));
        let min = d
            .iter()
            .flat_map(|v| v.iter().copied())
            .fold(f64::MAX, f64::min);
        assert!(
            min >= lowest - 1e-12 && min < lowest + 0.2,
            "{pattern:?}: {min}"
        );
    }
    // The written file reads back to the same identification.
    let mut bytes = Vec::new();
    a.dataset.write_csv(&mut bytes).unwrap();
    let back = so3_stiffness::identification::CsjmDataset::from_csv_reader(
        bytes.as_slice(),
        &Default::default(),
    )
    .unwrap();
    let k1 = identify(&a.dataset, &FitOptions::default()).unwrap().k;
    let k2 = identify(&back, &FitOptions::default()).unwrap().k;
    assert!((k1 - k2).norm() < 1e-9 * k1.norm());
}

#[test]
fn invalid_settings_are_named() {
    let sim = prototype_simulator().unwrap();
    let mut config = CampaignConfig::default();
    config.schedule.max_increment = -1.0;
    assert!(matches!(
        simulate_campaign(&sim, &config),
        Err(IdentificationError::InvalidSetting {
            field: "max_increment",
            ..
        })
    ));
    let mut config = CampaignConfig::default();
    config.schedule.increments = 2;
    assert!(matches!(
        simulate_campaign(&sim, &config),
        Err(IdentificationError::InvalidSetting {
            field: "increments",
            ..
        })
    ));
    let mut config = CampaignConfig::default();
    config.hysteresis_moment = f64::NAN;
    assert!(matches!(
        simulate_campaign(&sim, &config),
        Err(IdentificationError::InvalidSetting {
            field: "hysteresis_moment",
            ..
        })
    ));
}

/// Both campaign specs hold one schedule, checked once: a schedule the identification campaign
/// refuses, the diagnosis testbed refuses with the same field and message (the two specs used
/// to copy the fields and check them apart: the testbed capped `max_increment` at 100 N·m and
/// the identification campaign did not; only the latter checked the instruments' noise).
#[test]
fn both_campaign_specs_refuse_a_schedule_alike() {
    use so3_stiffness::identification::campaign::CampaignSchedule;
    use so3_stiffness::testbed::{self, CsjmCampaignSpec, CsjmEffects};
    let sim = prototype_simulator().unwrap();
    type Spoil = fn(&mut CampaignSchedule);
    let cases: [(&str, Spoil); 6] = [
        ("max_increment", |s| s.max_increment = 150.0),
        ("max_increment", |s| s.max_increment = f64::NAN),
        ("increments", |s| s.increments = 2),
        ("tracker", |s| s.tracker.constant = -1e-6),
        ("moment_noise", |s| {
            s.moment_noise.full_scale = f64::INFINITY
        }),
        ("preload", |s| s.preload.x = f64::NAN),
    ];
    for (field, spoil) in cases {
        let mut config = CampaignConfig::with_seed(1);
        spoil(&mut config.schedule);
        let mut spec = CsjmCampaignSpec::new(CsjmEffects::none(), 1);
        spoil(&mut spec.schedule);
        let refusals = (
            simulate_campaign(&sim, &config).err(),
            testbed::simulate_campaign(&spec).err(),
        );
        match refusals {
            (
                Some(IdentificationError::InvalidSetting {
                    field: a,
                    message: ma,
                }),
                Some(IdentificationError::InvalidSetting {
                    field: b,
                    message: mb,
                }),
            ) => {
                assert_eq!((a, b), (field, field));
                assert_eq!(ma, mb, "{field}");
            }
            other => panic!("{field}: not refused alike: {other:?}"),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Seed-like campaign: the prototype posed at the seed's R₀ under Table 3's pre-load, tilt
// stiffness calibrated to Table 3, one-sided increments in the sense of Table 4 (issue 4,
// "second-order fit … where the first-order fit does not"). See docs/csjm-identification.md.

mod paper_like {
    use super::*;
    use nalgebra::Vector3;
    use so3_stiffness::csjm::{stiffness_at, CsjmGeometry};
    use so3_stiffness::identification::campaign::{
        paper_like_simulator, paper_reference_pose, PAPER_LIKE_TILT_STIFFNESS,
        PAPER_TABLE3_PRELOAD, PAPER_TABLE3_R0, PAPER_TABLE4_DIRECTION,
    };
    use so3_stiffness::so3;

    /// The acceptance threshold of issue 4 (relative Frobenius error).
    const ACCEPTANCE: f64 = 0.03;

    fn paper_like(max_increment: f64, seed: u64, noisy: bool) -> Campaign {
        let mut config = CampaignConfig::paper_like(max_increment, seed);
        if !noisy {
            config.schedule.tracker = TrackerNoise::none();
            config.schedule.moment_noise = MomentNoise::none();
        }
        simulate_campaign(&paper_like_simulator().unwrap(), &config).unwrap()
    }

    #[test]
    fn simulator_is_posed_and_calibrated_as_table_3() {
        let sim = paper_like_simulator().unwrap();
        let r0 = paper_reference_pose();
        // The projection stays within print precision of Table 3's R₀ (r₃₂ = −0.300).
        let printed = nalgebra::Matrix3::from_fn(|i, j| PAPER_TABLE3_R0[i][j]);
        assert!((r0.matrix() - printed).amax() < 2e-3);
        let preload = Vector3::from(PAPER_TABLE3_PRELOAD);
        // The seed's R₀ is an equilibrium under the seed's pre-load.
        assert!((sim.holding_moment(&r0).unwrap() - preload).norm() < 1e-9);
        let c = paper_like(1.0, 1, false);
        assert!(so3::distance(&c.true_r0, &r0) < 1e-9);
        let k = c.true_stiffness.covariant;
        println!("seed-like K at R₀ (N·m/rad):\n{k:.3}");
        assert!((0.5 * (k[(0, 0)] + k[(1, 1)]) - PAPER_LIKE_TILT_STIFFNESS).abs() < 1e-6);
        assert!((k - k.transpose()).norm() < 1e-9 * k.norm());
        // Torsion stays above the geometric floor (7.93 N·m/rad at zero tension): Table 3's
        // 7 N·m/rad is out of reach of the printed dimensions.
        assert!(k[(2, 2)] > 7.9 && k[(2, 2)] < 20.0, "K_zz = {}", k[(2, 2)]);
        // Table 4's increments all point into the (+x, −y, +z) octant.
        assert!((Vector3::from(PAPER_TABLE4_DIRECTION).norm() - 1.0).abs() < 1e-3);
        let d: Vec<_> = c.applied.iter().map(|t| t - preload).collect();
        assert!(d
            .iter()
            .all(|v| v.x >= 0.0 && v.y <= 0.0 && v.z >= 0.0 && v.norm() <= 1.0 + 1e-12));
    }

    /// The torsion floor quoted in the docs: at home with equal tensions t, calibrating k so
    /// that K_xx = 29.675 N·m/rad leaves K_zz = 7.93 + 0.139 t.
    #[test]
    fn torsional_stiffness_floor_of_the_printed_geometry() {
        let g = CsjmGeometry::prototype();
        let home = nalgebra::Rotation3::identity();
        for t in [0.5, 20.0, 80.0] {
            let at = |k: f64| {
                stiffness_at(&g, &home, &[t; 6], &[k; 6], &[])
                    .unwrap()
                    .covariant
            };
            let (k1, k2) = (at(1.0), at(2.0));
            let k = 1.0 + (PAPER_LIKE_TILT_STIFFNESS - k1[(0, 0)]) / (k2[(0, 0)] - k1[(0, 0)]);
            let kzz = at(k)[(2, 2)];
            println!("home, t = {t} N: k = {k:.0} N/m, K_zz = {kzz:.3} N·m/rad");
            assert!(
                (kzz - (7.93 + 0.139 * t)).abs() < 0.02 + 0.002 * t,
                "t = {t}: {kzz}"
            );
        }
    }

    /// Noise-free (model bias only): the first-order bias grows about linearly with the
    /// increment size and stays below the 3 % acceptance at 3 N·m; the second-order fit
    /// removes ≥ 90 % of it.
    #[test]
    fn curvature_bias_of_counterweight_loading() {
        for seed in SEEDS {
            let bias = |m: f64, order| error_of(&paper_like(m, seed, false), order);
            let (first_1, first_3) = (bias(1.0, FitOrder::First), bias(3.0, FitOrder::First));
            let (second_1, second_3) = (bias(1.0, FitOrder::Second), bias(3.0, FitOrder::Second));
            println!(
                "seed {seed}: seed-like, noise-free: first-order {first_1:.4} (≤1 N·m) {first_3:.4} (≤3 N·m); \
                 second-order {second_1:.4} {second_3:.4}"
            );
            assert!(first_3 > 2.5 * first_1 && first_3 > 0.015);
            assert!(first_3 < ACCEPTANCE, "seed {seed}: {first_3}");
            assert!(second_3 < 0.1 * first_3 && second_1 < 0.1 * first_1);
        }
    }

    /// With the Table 1–2 noise at 3 N·m, the acceptance's claim does not show: the
    /// second-order fit's variance (one-sided loads make u and u² nearly collinear) outweighs
    /// the bias it removes. Both numbers are printed; the comparison is pinned on the mean over
    /// the seeds, and the reported standard errors say the same.
    #[test]
    fn noisy_counterweight_campaign_first_versus_second_order_at_3_nm() {
        let (mut first_sum, mut second_sum) = (0.0, 0.0);
        for seed in SEEDS {
            let c = paper_like(3.0, seed, true);
            let k_true = c.true_stiffness.covariant;
            let first = identify(&c.dataset, &FitOptions::with_order(FitOrder::First)).unwrap();
            let second = identify(&c.dataset, &FitOptions::with_order(FitOrder::Second)).unwrap();
            let (e1, e2) = (rel(&first.k, &k_true), rel(&second.k, &k_true));
            let (s1, s2) = (first.k_stderr.norm(), second.k_stderr.norm());
            println!(
                "seed {seed}: seed-like, noisy, ≤ 3 N·m: first-order {e1:.4} (‖stderr‖ {s1:.3}), \
                 second-order {e2:.4} (‖stderr‖ {s2:.3}); acceptance {ACCEPTANCE}"
            );
            assert!(s2 > 3.0 * s1, "seed {seed}");
            first_sum += e1;
            second_sum += e2;
        }
        let n = SEEDS.len() as f64;
        let (first_mean, second_mean) = (first_sum / n, second_sum / n);
        println!("mean over seeds: first-order {first_mean:.4}, second-order {second_mean:.4}");
        assert!(second_mean > first_mean);
        assert!(second_mean > ACCEPTANCE);
    }

    /// An independent second-order estimator with the structure of a conservative joint, to
    /// check that the crate's unconstrained second-order fit does not lose only for lack of
    /// constraints. In normal coordinates ζ at R₀, f(ζ) = Φ(R₀ exp ζ) has ∇f = J_r(ζ)ᵀτ(ζ),
    /// so with ∇f = τ₀ + Kζ + ½T(ζ, ζ) (K symmetric, T a symmetric 3-tensor) and
    /// J_r(ζ)⁻ᵀ = I − ½hat ζ + (1/12)hat²ζ + O(ζ³):
    /// Δτ + ½ζ×τ₀ − (1/12)ζ×(ζ×τ₀) = c + Kζ − ½ζ×(Kζ) + ½T(ζ, ζ) + O(ζ³):
    /// 19 coefficients (c, 6 of K, 10 of T) in one stacked least-squares fit, instead of the
    /// crate's 3 × 10. Only K is returned.
    fn conservative_second_order_k(c: &Campaign) -> Matrix3<f64> {
        use nalgebra::{DMatrix, DVector};
        let mut sym = Vec::new();
        for a in 0..3 {
            for b in a..3 {
                let mut m = Matrix3::zeros();
                m[(a, b)] = 1.0;
                m[(b, a)] = 1.0;
                sym.push(m);
            }
        }
        let mut tensors = Vec::new();
        for i in 0..3 {
            for j in i..3 {
                for k in j..3 {
                    let mut t = [[[0.0; 3]; 3]; 3];
                    for (a, b, d) in [
                        (i, j, k),
                        (i, k, j),
                        (j, i, k),
                        (j, k, i),
                        (k, i, j),
                        (k, j, i),
                    ] {
                        t[a][b][d] = 1.0;
                    }
                    tensors.push(t);
                }
            }
        }
        let (dzeta, dtau) = c.dataset.increments();
        let tau0 = c.dataset.reference().moment;
        // The reference row is a sample at ζ = 0 (as the crate's offset fit treats it).
        let samples: Vec<(Vector3<f64>, Vector3<f64>)> =
            std::iter::once((Vector3::zeros(), Vector3::zeros()))
                .chain(dzeta.iter().copied().zip(dtau.iter().copied()))
                .collect();
        let (rows, cols) = (3 * samples.len(), 3 + sym.len() + tensors.len());
        let (mut x, mut y) = (DMatrix::zeros(rows, cols), DVector::zeros(rows));
        for (r, (z, t)) in samples.iter().enumerate() {
            let target = t + 0.5 * z.cross(&tau0) - z.cross(&z.cross(&tau0)) / 12.0;
            for i in 0..3 {
                y[3 * r + i] = target[i];
                x[(3 * r + i, i)] = 1.0;
            }
            for (q, b) in sym.iter().enumerate() {
                let column = b * z - 0.5 * z.cross(&(b * z));
                for i in 0..3 {
                    x[(3 * r + i, 3 + q)] = column[i];
                }
            }
            for (q, t3) in tensors.iter().enumerate() {
                for i in 0..3 {
                    let mut quadratic = 0.0;
                    for j in 0..3 {
                        for k in 0..3 {
                            quadratic += t3[i][j][k] * z[j] * z[k];
                        }
                    }
                    x[(3 * r + i, 3 + sym.len() + q)] = 0.5 * quadratic;
                }
            }
        }
        let beta = x.svd(true, true).solve(&y, 1e-12).unwrap();
        sym.iter()
            .enumerate()
            .fold(Matrix3::zeros(), |k, (q, b)| k + b * beta[3 + q])
    }

    /// Noise-free, the constrained model removes the curvature bias like the crate's
    /// second-order fit (which checks its derivation); with the seed's noise at 3 N·m it is
    /// still above 3 % on average: constraints do not rescue the second-order option here.
    #[test]
    fn conservative_second_order_fit_does_not_rescue_it_either() {
        let (mut first_sum, mut constrained_sum) = (0.0, 0.0);
        for seed in SEEDS {
            let clean = paper_like(3.0, seed, false);
            let k_true = clean.true_stiffness.covariant;
            let bias = rel(&conservative_second_order_k(&clean), &k_true);
            let first_bias = error_of(&clean, FitOrder::First);
            assert!(
                bias < 0.15 * first_bias,
                "seed {seed}: {bias} vs {first_bias}"
            );
            let noisy = paper_like(3.0, seed, true);
            let constrained = rel(&conservative_second_order_k(&noisy), &k_true);
            let first = error_of(&noisy, FitOrder::First);
            println!(
                "seed {seed}: seed-like ≤ 3 N·m: constrained second order noise-free {bias:.4}, \
                 noisy {constrained:.4}; first order noisy {first:.4}"
            );
            first_sum += first;
            constrained_sum += constrained;
        }
        let n = SEEDS.len() as f64;
        println!(
            "mean over seeds: first-order {:.4}, constrained second-order {:.4}",
            first_sum / n,
            constrained_sum / n
        );
        assert!(constrained_sum / n > ACCEPTANCE);
        assert!(constrained_sum > first_sum);
    }
}
