//! Deflection prediction with and without K_C against the exact nonlinear equilibrium.

use nalgebra::{DMatrix, DVector};
use vjm::Measurements;
use vjm::{
    jacobian, jacobian_deflected, predict_deflection, spring_deflection, SerialChain,
    VirtualJointModel,
};

use crate::strategies::{random_compliances, random_configurations};

/// Without K_C the prediction is J C Jᵀ F (seed eqs. 7–8), computed here independently.
#[test]
fn linear_prediction_is_j_c_jt_f() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let c = random_compliances(21, 1);
    let q = random_configurations(&panda, 1, 2);
    let f = [10.0, -20.0, 30.0, 1.0, -2.0, 0.5];
    let j = jacobian(&panda, &model, &q).unwrap();
    let cx = &j * DMatrix::from_diagonal(&DVector::from_column_slice(&c)) * j.transpose();
    let expect = cx * DVector::from_column_slice(&f);
    let got = predict_deflection(&panda, &model, &c, &q, &f, false).unwrap();
    for r in 0..6 {
        assert!(
            (got[r] - expect[r]).abs() < 1e-15 + 1e-12 * expect.amax(),
            "{got:?} vs {expect}"
        );
    }
}

/// The exact spring equilibrium K_Θ Δθ = J(Δθ)ᵀF (θ-dependent Jacobian), by fixed-point
/// iteration on the slow, independent deflected-kinematics path.
fn exact_equilibrium(
    chain: &SerialChain,
    model: &VirtualJointModel,
    c: &[f64],
    q: &[f64],
    f: &[f64; 6],
) -> DVector<f64> {
    let fv = DVector::from_column_slice(f);
    let mut theta = DVector::zeros(c.len());
    for _ in 0..200 {
        let tau = jacobian_deflected(chain, model, q, theta.as_slice())
            .unwrap()
            .transpose()
            * &fv;
        let next = DVector::from_iterator(c.len(), tau.iter().zip(c).map(|(t, ci)| t * ci));
        if (&next - &theta).amax() < 1e-18 {
            return next;
        }
        theta = next;
    }
    theta
}

/// With K_C, Δθ is the linearisation of the exact equilibrium: its error is O(λ³) in the
/// load scale λ (halving λ divides it by ≈ 8), while without K_C it is O(λ²) (÷ 4).
#[test]
fn kc_captures_the_second_order_equilibrium() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let c: Vec<f64> = random_compliances(21, 3)
        .iter()
        .map(|v| v * 100.0)
        .collect();
    let q = random_configurations(&panda, 1, 4);
    let base = [40.0, -30.0, 50.0, 3.0, -4.0, 2.0];
    let errs = |lambda: f64| {
        let f = base.map(|v| v * lambda);
        let exact = exact_equilibrium(&panda, &model, &c, &q, &f);
        let lin = spring_deflection(&panda, &model, &c, &q, &f, false).unwrap();
        let kc = spring_deflection(&panda, &model, &c, &q, &f, true).unwrap();
        ((&lin - &exact).amax(), (&kc - &exact).amax(), exact.amax())
    };
    let (lin1, kc1, size) = errs(1.0);
    let (lin2, kc2, _) = errs(0.5);
    assert!(size > 1e-4 && size < 1e-1, "deflection scale {size}");
    assert!(kc1 < 0.05 * lin1, "K_C error {kc1:e} vs linear {lin1:e}");
    let (r_lin, r_kc) = (lin1 / lin2, kc1 / kc2);
    assert!((r_lin - 4.0).abs() < 0.4, "linear error ratio {r_lin}");
    assert!((r_kc - 8.0).abs() < 1.0, "K_C error ratio {r_kc}");
}

/// Zero compliance everywhere: no deflection, with or without K_C.
#[test]
fn zero_compliance_no_deflection() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let d = predict_deflection(
        &panda,
        &model,
        &[0.0; 7],
        &[0.0, -0.5, 0.0, -2.0, 0.0, 1.5, 0.0],
        &[1.0; 6],
        true,
    )
    .unwrap();
    assert_eq!(d, [0.0; 6]);
}

/// A noise-free 30-pose campaign on the bundled Panda (nominal true springs; the Panda carries
/// inertials) and `model` identified from it, as a stiffness model with default options.
fn model_from_noise_free_campaign(
    model: &VirtualJointModel,
) -> (
    SerialChain,
    vjm::dataset::Dataset<'static>,
    vjm::StiffnessModel,
) {
    use vjm::testbed::{simulate, CampaignSpec, TrueModel};
    use vjm::{identify, DataSource, IdentifyOptions, StiffnessModel};
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 30,
        noise: false,
        ..Default::default()
    };
    let data = simulate(&chain, &TrueModel::nominal(7), &spec)
        .unwrap()
        .dataset;
    let (q, w, d) = (data.q_flat(), data.wrench_flat(), data.displacement_flat());
    let opts = IdentifyOptions::default();
    let id = identify(&chain, model, Measurements::new(q, w, d), &opts).unwrap();
    let sm = StiffnessModel::from_identification(
        &id,
        &chain,
        model,
        &opts,
        DataSource::in_memory(data.len()),
    )
    .unwrap();
    (chain, data, sm)
}

/// A model identified from noise-free data (traditional springs on the bundled Panda, which
/// carries inertials) predicts the tip's sag under its own weight: equal to the exact static
/// equilibrium with the true compliances (`gravity::gravity_sag`, independent of the file) to
/// the identification's accuracy, flagged identified, with a ceiling mount sagging the other
/// way; a payload adds to it. An extended model identified from the same data has aliased
/// springs that the weight loads differently from any tip wrench: every pose is flagged, not
/// silently predicted (and what would be flagged identified is checked against the truth).
#[test]
fn a_model_predicts_the_sag_under_its_own_weight() {
    use vjm::gravity::{gravity_sag, Gravity};
    use vjm::testbed::TrueModel;
    use vjm::{identify, DataSource, IdentifyOptions, PointMass, StiffnessModel};
    let truth = TrueModel::nominal(7);
    let traditional = VirtualJointModel::traditional(7);
    let (chain, data, sm) = model_from_noise_free_campaign(&traditional);
    let (q, w, d) = (data.q_flat(), data.wrench_flat(), data.displacement_flat());
    let opts = IdentifyOptions::default();
    let c_true: Vec<f64> = (0..7).map(|j| truth.compliance[3 * j]).collect();
    let g = Gravity::default();
    let payload = PointMass::new(3.0, [0.0, 0.0, 0.1]).unwrap();
    let poses = random_configurations(&chain, 5, 11);
    let p = sm.predict_sag(&chain, &poses, &g, None).unwrap();
    let with_payload = sm.predict_sag(&chain, &poses, &g, Some(&payload)).unwrap();
    let up = sm
        .predict_sag(
            &chain,
            &poses,
            &Gravity::new([0.0, 0.0, 9.80665]).unwrap(),
            None,
        )
        .unwrap();
    for (i, qi) in poses.chunks(7).enumerate() {
        let want = gravity_sag(&chain, &traditional, &c_true, qi, &g, None).unwrap();
        let norm = (want[0].powi(2) + want[1].powi(2) + want[2].powi(2)).sqrt();
        assert!(
            norm > 1e-4,
            "a Panda sags by more than 0.1 mm, got {norm:e}"
        );
        for k in 0..3 {
            assert!(
                (p[i].deflection[k] - want[k]).abs() <= 1e-7 * norm,
                "pose {i}: {:?} vs {want:?}",
                p[i].deflection
            );
            // Upside down the weight pulls the other way: the same size, to second order.
            assert!(
                (up[i].deflection[k] + want[k]).abs() <= 2e-2 * norm,
                "pose {i}: ceiling {:?}",
                up[i].deflection
            );
        }
        assert!(p[i].identified && p[i].wrench == [0.0; 6]);
        let more = (0..3)
            .map(|k| with_payload[i].deflection[k].powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            more > norm * 1.05,
            "pose {i}: a 3 kg payload adds to the sag ({more:e} vs {norm:e})"
        );
    }
    let extended = VirtualJointModel::extended(7);
    let id = identify(&chain, &extended, Measurements::new(q, w, d), &opts).unwrap();
    assert!(id.rank < 21);
    let sm = StiffnessModel::from_identification(
        &id,
        &chain,
        &extended,
        &opts,
        DataSource::in_memory(data.len()),
    )
    .unwrap();
    let p = sm.predict_sag(&chain, &poses, &g, None).unwrap();
    // What is flagged identified is right whatever the aliased springs are (the truth has no
    // tilts; the stored minimum-norm vector has some).
    let mut identified = 0;
    for (i, qi) in poses.chunks(7).enumerate() {
        if !p[i].identified {
            continue;
        }
        identified += 1;
        let want = gravity_sag(&chain, &traditional, &c_true, qi, &g, None).unwrap();
        for (got, want) in p[i].deflection.iter().zip(&want).take(3) {
            assert!(
                (got - want).abs() <= 1e-6 * want.abs().max(1e-4),
                "pose {i}"
            );
        }
    }
    // A tip wrench loads J1's x tilt and J2's torsion (their axes coincide on the Panda)
    // with the same torque, the weight does not (link 2's mass hangs on J1x's lever, not
    // J2z's): tip-load data cannot determine the extended model's sag, and every pose says so.
    assert_eq!(
        identified, 0,
        "the weight excites the aliased J1x − J2z direction"
    );
}

/// A campaign's pose table repeats each configuration over several rows (one per load); the
/// sag is solved once per run of equal rows and repeated. Whatever the runs (a pose recurring
/// later, runs of every length, rows and columns alike), every row's prediction is bit for bit
/// the one of that configuration predicted alone, and a bad configuration is named by its own
/// row, not by its run's place among the distinct ones.
#[test]
fn a_configuration_repeated_over_rows_sags_as_it_does_alone() {
    use vjm::gravity::Gravity;
    use vjm::{ModelError, VjmError};
    let (chain, _, sm) = model_from_noise_free_campaign(&VirtualJointModel::traditional(7));
    let g = Gravity::default();
    let poses = random_configurations(&chain, 4, 23);
    let pose = |k: usize| &poses[7 * k..7 * k + 7];
    // Runs of 3, 1, 2, 17 (over two lane batches), 1, and pose 0 again after the others.
    let order = [0, 0, 0, 1, 2, 2]
        .into_iter()
        .chain([3; 17])
        .chain([1, 0])
        .collect::<Vec<_>>();
    let q: Vec<f64> = order.iter().flat_map(|&k| pose(k).to_vec()).collect();
    let rows = sm.predict_sag(&chain, &q, &g, None).unwrap();
    let columns = sm.predict_sag_columns(&chain, &q, &g, None).unwrap();
    assert_eq!((rows.len(), columns.rows()), (order.len(), order.len()));
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (i, &k) in order.iter().enumerate() {
        let alone = sm.predict_sag(&chain, pose(k), &g, None).unwrap()[0];
        for got in [rows[i], columns.row(i)] {
            assert_eq!(bits(&got.deflection), bits(&alone.deflection), "row {i}");
            assert_eq!(bits(&got.stddev), bits(&alone.stddev), "row {i}");
            assert_eq!(
                (got.identified, got.excitation.to_bits()),
                (alone.identified, alone.excitation.to_bits()),
                "row {i}"
            );
        }
    }
    // A non-finite configuration repeated over rows 3 and 4, after a run of two.
    let mut bad = [pose(0), pose(0), pose(1), pose(2), pose(2)].concat();
    bad[3 * 7 + 5] = f64::NAN;
    bad[4 * 7 + 5] = f64::NAN;
    for err in [
        sm.predict_sag(&chain, &bad, &g, None).unwrap_err(),
        sm.predict_sag_columns(&chain, &bad, &g, None).unwrap_err(),
    ] {
        match err {
            ModelError::Vjm(VjmError::NonFinite { row, column, .. }) => {
                assert_eq!((row, column), (3, 5), "{err}")
            }
            other => panic!("expected the non-finite q at row 3, got {other}"),
        }
    }
}

/// Under gravity a model predicts what a measurement records (loaded − unloaded, both at rest
/// under the weight): against the exact static equilibrium (`gravity::deflection_under_gravity`,
/// Newton on the deflected chain's torques, another code path than the sag and coupling the
/// prediction uses) with the model's own compliances, to the load's geometric non-linearity
/// (small loads), while the weightless prediction misses by gravity's share.
#[test]
fn a_model_predicts_the_load_deflection_under_its_own_weight() {
    use vjm::gravity::{deflection_under_gravity, Gravity};
    use vjm::testbed::CampaignSpec;
    use vjm::Load;
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 30,
        noise: false,
        ..Default::default()
    };
    let model = VirtualJointModel::traditional(7);
    let sm = crate::strategies::identified_model(&chain, &model, &spec);
    let c = sm.estimate().compliance.clone();
    let g = Gravity::default();
    let poses = random_configurations(&chain, 6, 11);
    let wrench: Vec<f64> = (0..6)
        .flat_map(|i| {
            let s = 1.0 + 0.1 * i as f64;
            [1.5 * s, -s, 2.0 * s, 0.1, -0.2 * s, 0.15]
        })
        .collect();
    // The worst relative error (translation) over the rows at load scale `lambda`.
    let errors = |lambda: f64| {
        let wrench: Vec<f64> = wrench.iter().map(|v| v * lambda).collect();
        let under = sm
            .predict_under_gravity(&chain, &poses, Load::Wrench(&wrench), &g)
            .unwrap();
        let weightless = sm.predict(&chain, &poses, Load::Wrench(&wrench)).unwrap();
        let (mut worst_g, mut worst_w) = (0.0f64, 0.0f64);
        for i in 0..6 {
            let qi = &poses[7 * i..7 * i + 7];
            let wi: [f64; 6] = wrench[6 * i..6 * i + 6].try_into().unwrap();
            let exact = deflection_under_gravity(&chain, &model, &c, qi, &wi, &g, None).unwrap();
            let size = exact[..3].iter().map(|v| v * v).sum::<f64>().sqrt();
            let err = |p: &[f64; 6]| {
                (0..3)
                    .map(|r| (p[r] - exact[r]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    / size
            };
            worst_g = worst_g.max(err(&under[i].deflection));
            worst_w = worst_w.max(err(&weightless[i].deflection));
            // Identified and standard deviations: the weightless regressor's (the
            // identification's row space), so a determined row is not flagged for the weight.
            assert!(under[i].identified && under[i].stddev[0].is_finite());
            assert_eq!(under[i].stddev[..3], weightless[i].stddev[..3]);
        }
        (worst_g, worst_w)
    };
    let (worst_g, worst_w) = errors(1.0);
    let (half_g, half_w) = errors(0.5);
    println!(
        "relative error against the exact equilibrium: under gravity {worst_g:.2e} (half load \
         {half_g:.2e}), weightless {worst_w:.2e} (half load {half_w:.2e})"
    );
    assert!(worst_g < 1e-3, "under gravity {worst_g:e}");
    assert!(
        worst_w > 10.0 * worst_g,
        "weightless {worst_w:e} vs {worst_g:e}"
    );
    // What remains is the load's own non-linearity: it halves with the load, while the
    // weightless prediction's error (gravity's share) does not.
    assert!(
        (1.6..2.4).contains(&(worst_g / half_g)),
        "{worst_g:e} / {half_g:e}"
    );
    assert!(half_w > 0.8 * worst_w, "{half_w:e} vs {worst_w:e}");
}
