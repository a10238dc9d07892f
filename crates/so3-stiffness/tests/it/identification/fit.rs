//! The fit: exact recovery, the connection term against an independent potential, rank
//! revealing, standard errors and the offset.

use nalgebra::{Matrix3, Vector3};
use rand_distr::{Distribution, Normal};
use so3_stiffness::identification::{
    identify, identify_increments, ConnectionTerm, CsjmDataset, CsjmMeasurement, FitOptions,
    FitOrder, IdentificationError,
};
use so3_stiffness::so3;

use super::common::{random_vector, rng, SpringPotential};

fn k_true() -> Matrix3<f64> {
    Matrix3::new(29.4, 1.2, 3.0, 1.2, 30.0, -1.1, 3.0, -1.1, 7.0)
}

fn rel(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

fn options(order: FitOrder, offset: bool) -> FitOptions {
    let mut o = FitOptions::with_order(order);
    o.fit_offset = offset;
    o
}

#[test]
fn exact_linear_data_recovers_k_d_and_k() {
    let tau0 = Vector3::new(-0.06, -3.08, 1.07);
    let k_d = k_true() + 0.5 * so3::hat(&tau0);
    let mut g = rng(1);
    let dz: Vec<_> = (0..12).map(|_| random_vector(&mut g, 0.05)).collect();
    let dt: Vec<_> = dz.iter().map(|z| k_d * z).collect();
    for offset in [false, true] {
        for order in [FitOrder::First, FitOrder::Second] {
            let e = identify_increments(&tau0, &dz, &dt, &options(order, offset)).unwrap();
            assert!((e.k_d - k_d).norm() < 1e-10, "{order:?} offset={offset}");
            assert!((e.k - k_true()).norm() < 1e-10);
            assert!((e.k_l + 0.5 * so3::hat(&tau0)).norm() < 1e-10);
            assert!(e.asymmetry() < 1e-12);
            assert_eq!(e.n, 12);
            assert_eq!(e.order, order.as_u8());
        }
    }
}

#[test]
fn connection_options_differ_by_multiples_of_hat_tau0() {
    let tau0 = Vector3::new(0.4, -3.0, 1.0);
    let mut g = rng(2);
    let dz: Vec<_> = (0..8).map(|_| random_vector(&mut g, 0.05)).collect();
    let dt: Vec<_> = dz.iter().map(|z| k_true() * z).collect();
    let fit = |c: ConnectionTerm| {
        let mut o = FitOptions::default();
        o.connection = c;
        identify_increments(&tau0, &dz, &dt, &o).unwrap().k
    };
    assert!((fit(ConnectionTerm::None) - k_true()).norm() < 1e-10);
    assert!((fit(ConnectionTerm::LeviCivita) - (k_true() - 0.5 * so3::hat(&tau0))).norm() < 1e-10);
    assert!((fit(ConnectionTerm::PaperEq48b) - (k_true() - so3::hat(&tau0))).norm() < 1e-10);
}

/// The central mathematical check: on an independent conservative system, K = K_D − ½hat(τ₀)
/// equals the covariant Hessian of the potential (finite differences of the energy), while the
/// seed's K_D − hat(τ₀) misses it by ½‖hat(τ₀)‖.
#[test]
fn levi_civita_term_gives_the_covariant_hessian_of_a_potential() {
    for seed in 0..4 {
        let pot = SpringPotential::new(seed);
        let mut g = rng(100 + seed);
        let r0 = so3::exp(&random_vector(&mut g, 0.4));
        let tau0 = pot.moment(&r0);
        // The moment formula itself, against finite differences of the energy.
        let h = 1e-6;
        let fd = Vector3::from_fn(|i, _| {
            let e = Vector3::ith(i, h);
            (pot.energy(&(r0 * so3::exp(&e))) - pot.energy(&(r0 * so3::exp(&-e)))) / (2.0 * h)
        });
        assert!(
            (fd - tau0).norm() < 1e-6 * tau0.norm(),
            "moment formula, seed {seed}"
        );
        let hessian = pot.covariant_hessian(&r0);
        assert!(
            tau0.norm() > 0.05 * hessian.norm(),
            "pre-load too small to discriminate: {tau0:?}"
        );

        let dz: Vec<_> = (0..30).map(|_| random_vector(&mut g, 2e-3)).collect();
        let dt: Vec<_> = dz
            .iter()
            .map(|z| pot.moment(&(r0 * so3::exp(z))) - tau0)
            .collect();
        let e = identify_increments(&tau0, &dz, &dt, &FitOptions::with_order(FitOrder::Second))
            .unwrap();
        let scale = hessian.norm();
        assert!(
            (e.k - hessian).norm() < 1e-5 * scale,
            "seed {seed}: K {} vs Hessian {}",
            e.k,
            hessian
        );
        assert!(e.asymmetry() < 1e-5);
        let seed_k = e.k_d - so3::hat(&tau0);
        let miss = (seed_k - hessian).norm();
        assert!((miss - 0.5 * so3::hat(&tau0).norm()).abs() < 1e-5 * scale);
        assert!(miss > 1e3 * (e.k - hessian).norm());
    }
}

#[test]
fn second_order_fit_recovers_curvature_and_removes_its_bias() {
    let tau0 = Vector3::new(0.2, -1.0, 0.5);
    let k_d = k_true() + 0.5 * so3::hat(&tau0);
    let hess = [
        Matrix3::new(40.0, 5.0, -3.0, 5.0, 20.0, 2.0, -3.0, 2.0, 10.0),
        Matrix3::new(-10.0, 2.0, 1.0, 2.0, 35.0, -4.0, 1.0, -4.0, 6.0),
        Matrix3::new(8.0, -1.0, 6.0, -1.0, 12.0, 3.0, 6.0, 3.0, -20.0),
    ];
    let model = |z: &Vector3<f64>| {
        k_d * z + 0.5 * Vector3::from_fn(|i, _| (z.transpose() * hess[i] * z)[0])
    };
    let mut g = rng(3);
    // One-sided, large increments: the worst case for a linear fit.
    let dz: Vec<_> = (0..40).map(|_| random_vector(&mut g, 0.15).abs()).collect();
    let dt: Vec<_> = dz.iter().map(model).collect();
    let second =
        identify_increments(&tau0, &dz, &dt, &FitOptions::with_order(FitOrder::Second)).unwrap();
    assert!((second.k_d - k_d).norm() < 1e-9);
    let h = second.curvature.expect("second order reports curvature");
    for i in 0..3 {
        assert!((h[i] - hess[i]).norm() < 1e-8);
    }
    let first = identify_increments(&tau0, &dz, &dt, &FitOptions::default()).unwrap();
    assert!(first.curvature.is_none());
    assert!(
        rel(&first.k, &k_true()) > 0.05,
        "first-order bias {}",
        rel(&first.k, &k_true())
    );
}

#[test]
fn single_axis_excitation_is_reported_not_inverted() {
    let tau0 = Vector3::zeros();
    let mut g = rng(4);
    let noise = Normal::new(0.0, 1.5e-4).unwrap();
    let dz: Vec<_> = (1..=20)
        .map(|i| Vector3::new(0.005 * i as f64, noise.sample(&mut g), noise.sample(&mut g)))
        .collect();
    let dt: Vec<_> = dz.iter().map(|z| k_true() * z).collect();
    match identify_increments(&tau0, &dz, &dt, &FitOptions::default()) {
        Err(IdentificationError::IllConditioned {
            matrix,
            condition,
            omega_singular_values,
            ..
        }) => {
            assert!(matrix.starts_with('Ω'), "{matrix}");
            assert!(condition > 300.0, "{condition}");
            assert!(
                (condition - omega_singular_values[0] / omega_singular_values[2]).abs()
                    < 1e-9 * condition
            );
        }
        other => panic!("expected IllConditioned, got {other:?}"),
    }
    // Exactly planar excitation: a zero column.
    let dz: Vec<_> = (0..10)
        .map(|_| Vector3::new(1.0, -1.0, 0.0).component_mul(&random_vector(&mut g, 0.05)))
        .collect();
    let dt: Vec<_> = dz.iter().map(|z| k_true() * z).collect();
    assert!(matches!(
        identify_increments(&tau0, &dz, &dt, &FitOptions::default()),
        Err(IdentificationError::IllConditioned { .. })
    ));
}

/// The reported standard errors match the scatter of K over repeated noisy campaigns.
#[test]
fn standard_errors_match_monte_carlo_scatter() {
    let tau0 = Vector3::new(-0.06, -3.08, 1.07);
    let k_d = k_true() + 0.5 * so3::hat(&tau0);
    let mut g = rng(5);
    let dz: Vec<_> = (0..40).map(|_| random_vector(&mut g, 0.04)).collect();
    let sigma = 0.04;
    let noise = Normal::new(0.0, sigma).unwrap();
    for order in [FitOrder::First, FitOrder::Second] {
        let trials = 400;
        let mut sum = Matrix3::zeros();
        let mut sum2 = Matrix3::zeros();
        let mut reported = Matrix3::zeros();
        for _ in 0..trials {
            let t0 = tau0 + Vector3::from_fn(|_, _| noise.sample(&mut g));
            let dt: Vec<_> = dz
                .iter()
                .map(|z| tau0 + k_d * z + Vector3::from_fn(|_, _| noise.sample(&mut g)) - t0)
                .collect();
            let e = identify_increments(&t0, &dz, &dt, &FitOptions::with_order(order)).unwrap();
            sum += e.k;
            sum2 += e.k.component_mul(&e.k);
            reported += e.k_stderr / trials as f64;
        }
        let mean = sum / trials as f64;
        let std = (sum2 / trials as f64 - mean.component_mul(&mean)).map(|v| v.max(0.0).sqrt());
        assert!(rel(&mean, &k_true()) < 0.01, "{order:?}: unbiased");
        for i in 0..3 {
            for j in 0..3 {
                let ratio = reported[(i, j)] / std[(i, j)];
                assert!(
                    (0.8..1.25).contains(&ratio),
                    "{order:?} K[{i}{j}]: reported {} vs scatter {}",
                    reported[(i, j)],
                    std[(i, j)]
                );
            }
        }
    }
}

/// With one-sided increments, the noise of the single reference measurement biases eq. 49;
/// the fitted offset removes it.
#[test]
fn offset_absorbs_reference_noise() {
    let tau0 = Vector3::new(0.5, -2.0, 1.0);
    let k_d = k_true() + 0.5 * so3::hat(&tau0);
    let mut g = rng(6);
    let dz: Vec<_> = (0..60).map(|_| random_vector(&mut g, 0.05).abs()).collect();
    let ref_error = Vector3::new(0.05, -0.05, 0.05);
    let measured_tau0 = tau0 + ref_error;
    let dt: Vec<_> = dz.iter().map(|z| tau0 + k_d * z - measured_tau0).collect();
    let with =
        identify_increments(&measured_tau0, &dz, &dt, &options(FitOrder::First, true)).unwrap();
    let without =
        identify_increments(&measured_tau0, &dz, &dt, &options(FitOrder::First, false)).unwrap();
    // With the offset the noisy reference is one sample among 61; with one-sided increments
    // it is a high-leverage sample, so it still pulls (measured: 0.6 % vs 4.3 %).
    let (bias_with, bias_without) = (rel(&with.k, &k_true()), rel(&without.k, &k_true()));
    assert!(bias_without > 0.02, "no-offset bias {bias_without}");
    assert!(
        bias_with < 0.2 * bias_without,
        "offset bias {bias_with} vs {bias_without}"
    );
    assert!((with.tau0 - tau0).norm() < 0.5 * ref_error.norm());
}

#[test]
fn det_convergence_series_covers_every_prefix() {
    let tau0 = Vector3::new(0.1, 0.2, 0.3);
    let mut g = rng(8);
    let dz: Vec<_> = (0..25).map(|_| random_vector(&mut g, 0.05)).collect();
    let dt: Vec<_> = dz
        .iter()
        .map(|z| (k_true() + 0.5 * so3::hat(&tau0)) * z)
        .collect();
    let e = identify_increments(&tau0, &dz, &dt, &FitOptions::default()).unwrap();
    let ns: Vec<usize> = e.det_convergence.iter().map(|p| p.n).collect();
    assert_eq!(ns, (3..=25).collect::<Vec<_>>());
    for p in &e.det_convergence {
        assert!((p.det - k_true().determinant()).abs() < 1e-8 * k_true().determinant());
    }
    let mut o = FitOptions::default();
    o.convergence_series = false;
    assert!(identify_increments(&tau0, &dz, &dt, &o)
        .unwrap()
        .det_convergence
        .is_empty());
}

#[test]
fn bad_inputs_are_errors() {
    let z = vec![Vector3::new(0.01, 0.0, 0.0); 3];
    let t = vec![Vector3::zeros(); 2];
    assert!(matches!(
        identify_increments(&Vector3::zeros(), &z, &t, &FitOptions::default()),
        Err(IdentificationError::LengthMismatch {
            left: 3,
            right: 2,
            ..
        })
    ));
    let mut g = rng(9);
    let z: Vec<_> = (0..9).map(|_| random_vector(&mut g, 0.05)).collect();
    let t: Vec<_> = z.iter().map(|v| k_true() * v).collect();
    // Second order with offset: 10 coefficients, 9 increments + the reference sample.
    let exact = identify_increments(
        &Vector3::zeros(),
        &z,
        &t,
        &FitOptions::with_order(FitOrder::Second),
    )
    .unwrap();
    assert_eq!(exact.dof, 0);
    assert!(exact.k_stderr.iter().all(|s| s.is_nan()));
    assert!(matches!(
        identify_increments(
            &Vector3::zeros(),
            &z[..8],
            &t[..8],
            &FitOptions::with_order(FitOrder::Second)
        ),
        Err(IdentificationError::TooFewMeasurements {
            usable: 8,
            required: 9,
            ..
        })
    ));
    let mut o = FitOptions::with_order(FitOrder::Second);
    o.fit_offset = false;
    assert!(matches!(
        identify_increments(&Vector3::zeros(), &z[..8], &t[..8], &o),
        Err(IdentificationError::TooFewMeasurements {
            usable: 8,
            required: 9,
            ..
        })
    ));
    let mut t_bad = t.clone();
    t_bad[4].y = f64::NAN;
    assert!(matches!(
        identify_increments(&Vector3::zeros(), &z, &t_bad, &FitOptions::default()),
        Err(IdentificationError::NonFiniteInput { .. })
    ));
}

#[test]
fn identify_uses_the_dataset_reference() {
    let r0 = so3::exp(&Vector3::new(0.3, -0.1, 0.2));
    let tau0 = Vector3::new(-0.06, -3.08, 1.07);
    let k_d = k_true() + 0.5 * so3::hat(&tau0);
    let mut g = rng(10);
    let loaded = (0..10)
        .map(|_| {
            let z = random_vector(&mut g, 0.03);
            CsjmMeasurement::new(r0 * so3::exp(&z), tau0 + k_d * z)
        })
        .collect();
    let data = CsjmDataset::new(CsjmMeasurement::new(r0, tau0), loaded).unwrap();
    let e = identify(&data, &FitOptions::default()).unwrap();
    assert!(rel(&e.k, &k_true()) < 1e-12);
    assert!((e.tau0 - tau0).norm() < 1e-12);
}

#[test]
fn det_convergence_series_is_capped_on_large_data() {
    let tau0 = Vector3::zeros();
    let mut g = rng(12);
    let dz: Vec<_> = (0..1000).map(|_| random_vector(&mut g, 0.05)).collect();
    let dt: Vec<_> = dz.iter().map(|z| k_true() * z).collect();
    let e = identify_increments(&tau0, &dz, &dt, &FitOptions::default()).unwrap();
    let ns: Vec<usize> = e.det_convergence.iter().map(|p| p.n).collect();
    assert_eq!(
        ns.len(),
        so3_stiffness::identification::fit::MAX_CONVERGENCE_POINTS
    );
    assert_eq!((ns[0], ns[ns.len() - 1]), (3, 1000));
    assert!(ns.windows(2).all(|w| w[1] > w[0]));
}
