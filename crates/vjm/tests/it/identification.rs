//! Identification: noise-free recovery, rank on the bundled arm, streaming vs dense.

use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use vjm::Measurements;
use vjm::{
    build_design, identify, identify_dense, predict_deflection, Identification, IdentifyOptions,
    SerialChain, SolveMethod, VirtualJointModel, NORMAL_EQUATIONS_MAX_CONDITION,
    NORMAL_EQUATIONS_RANK_RTOL, NORMAL_EQUATIONS_ROUNDING_FLOOR,
};

use crate::strategies::{
    arb_chain, config, random_compliances, random_configurations, random_wrenches,
};

/// Noise-free data generated with compliances `c`: displacements (N×3) and rotations (N×3).
pub fn synthetic(
    chain: &SerialChain,
    model: &VirtualJointModel,
    c: &[f64],
    count: usize,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = chain.n_joints();
    let q = random_configurations(chain, count, seed);
    let f = random_wrenches(count, seed + 1);
    let mut d = Vec::with_capacity(3 * count);
    let mut r = Vec::with_capacity(3 * count);
    for i in 0..count {
        let mut fi = [0.0; 6];
        fi.copy_from_slice(&f[6 * i..6 * i + 6]);
        // J·diag(c)·Jᵀ·f, i.e. `predict_deflection` without K_C, written out because some tests
        // use negative compliances on purpose (NNLS), which `predict_deflection` refuses.
        let j = vjm::jacobian(chain, model, &q[n * i..n * (i + 1)]).unwrap();
        let tau = j.transpose() * nalgebra::DVector::from_column_slice(&fi);
        let theta =
            nalgebra::DVector::from_iterator(tau.len(), tau.iter().zip(c).map(|(t, c)| t * c));
        let x = j * theta;
        d.extend(x.iter().take(3));
        r.extend(x.iter().skip(3).take(3));
    }
    (q, f, d, r)
}

/// Every base parameter equals the same combination of the true compliances, to `tol`
/// relative to Σ|coefficient·c|; unidentifiable compliances are `None`, identifiable ones exact.
pub fn assert_recovers(id: &Identification, truth: &[f64], tol: f64) {
    assert_eq!(id.combinations.len(), id.rank);
    for comb in &id.combinations {
        let expect: f64 = comb
            .terms
            .iter()
            .map(|t| t.coefficient * truth[t.param])
            .sum();
        let scale: f64 = comb
            .terms
            .iter()
            .map(|t| (t.coefficient * truth[t.param]).abs())
            .sum();
        let err = (comb.value - expect).abs() / scale;
        assert!(
            err < tol,
            "{}: {} vs {} (rel {err:e})",
            comb.label,
            comb.value,
            expect
        );
    }
    for (k, estimate) in id.compliance.iter().enumerate() {
        match *estimate {
            Some(v) => {
                assert!(id.identifiable[k]);
                assert!(
                    ((v - truth[k]) / truth[k]).abs() < tol,
                    "param {k}: {v} vs {}",
                    truth[k]
                );
            }
            None => {
                assert!(!id.identifiable[k]);
                assert!(
                    id.aliases.iter().any(|g| g.contains(&k)),
                    "unidentifiable {k} in no alias group"
                );
            }
        }
    }
}

fn noise_free_panda(use_rotations: bool) -> Identification {
    noise_free_panda_with(use_rotations, SolveMethod::Auto)
}

fn noise_free_panda_with(use_rotations: bool, method: SolveMethod) -> Identification {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = random_compliances(21, 7);
    let (q, f, d, r) = synthetic(&panda, &model, &truth, 300, 100);
    let mut opts = IdentifyOptions::default();
    opts.use_rotations = use_rotations;
    opts.method = method;
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    assert_recovers(&id, &truth, 1e-9);
    id
}

fn groups(wanted: &[&str]) -> Vec<Vec<String>> {
    wanted
        .iter()
        .map(|g| g.split(',').map(str::to_string).collect())
        .collect()
}

/// Rank of the 21-parameter extended model on the bundled Panda (tip: flange), 300
/// random configurations and wrenches.
///
/// Full 6-D measurements: rank 16 = 21 − 5.
/// - Shoulder: joints 1 and 2 share their origin and joint 3's axis passes through it, so
///   their 7 springs are 7 rotations about one point. What the data see of them is the
///   3×3 compliance R₁D₁R₁ᵀ + R₂D₂R₂ᵀ + c₃z·a₃a₃ᵀ; a₃ is fixed in link 2 (it is ±y₂), so J3z
///   acts like J2y, and J1y (the link-1 axis that joint 2 turns about) like J2z. Of the 7
///   springs only 4 combinations are identifiable: loss 3, alias groups {J1y, J2z} and
///   {J1z, J1x, J2x, J2y, J3z}.
/// - Wrist: joints 5 and 6 share their origin: 6 springs, 4 combinations: loss 2, groups
///   {J5y, J6z} and {J5z, J5x, J6x, J6y}.
///
/// Translation only: rank 15: additionally the torsion J7z turns the flange about its own
/// axis, which passes through the tip point, so no tip translation sees it.
#[test]
fn rank_of_extended_model_on_bundled_panda() {
    let id6 = noise_free_panda(true);
    assert_eq!((id6.n_params, id6.rank), (21, 16));
    let expect6 = groups(&[
        "J1z,J1x,J2x,J2y,J3z",
        "J1y,J2z",
        "J5z,J5x,J6x,J6y",
        "J5y,J6z",
    ]);
    assert_eq!(id6.alias_labels, expect6);
    let id3 = noise_free_panda(false);
    assert_eq!((id3.n_params, id3.rank), (21, 15));
    let mut expect3 = expect6.clone();
    expect3.push(vec!["J7z".to_string()]);
    assert_eq!(id3.alias_labels, expect3);
    assert_eq!(id3.compliance[18], None, "J7z");
    assert!(id6.compliance[18].is_some(), "J7z is seen by rotations");
    // The default reduction is the normal equations here (κ ≈ 70): their deficient singular
    // values sit at the √ε floor, far below the cut-off.
    assert_eq!(id3.method, SolveMethod::NormalEquations);
    assert!(id3.singular_values[14] > 1e-3 && id3.singular_values[15] < 1e-7);
    // Through QR the gap is visibly structural: the first deficient singular value is
    // rounding. Same rank, same alias groups, same estimates.
    let qr = noise_free_panda_with(false, SolveMethod::Qr);
    assert_eq!(qr.method, SolveMethod::Qr);
    assert!(qr.singular_values[14] > 1e-3 && qr.singular_values[15] < 1e-12);
    assert_eq!((qr.rank, &qr.alias_labels), (id3.rank, &id3.alias_labels));
    for (a, b) in qr.combinations.iter().zip(&id3.combinations) {
        assert_eq!(a.label, b.label);
        assert!(
            (a.value - b.value).abs() <= 1e-10 * a.value.abs(),
            "{}: {} vs {}",
            a.label,
            a.value,
            b.value
        );
    }
}

/// The traditional model (7 torsions): rank 6 with translations (J7z unseen), 7 with rotations.
#[test]
fn rank_of_traditional_model_on_bundled_panda() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let truth = random_compliances(7, 3);
    let (q, f, d, r) = synthetic(&panda, &model, &truth, 100, 5);
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d),
        &IdentifyOptions::default(),
    )
    .unwrap();
    assert_eq!(id.rank, 6);
    assert_eq!(id.alias_labels, vec![vec!["J7z".to_string()]]);
    assert_recovers(&id, &truth, 1e-9);
    let mut opts = IdentifyOptions::default();
    opts.use_rotations = true;
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    assert_eq!(id.rank, 7);
    assert!(id.aliases.is_empty());
    assert_recovers(&id, &truth, 1e-9);
}

proptest! {
    #![proptest_config(config(24))]

    /// Noise-free recovery on random chains: every base parameter to 1e-9 relative, and
    /// every unidentifiable compliance named (None + in an alias group).
    #[test]
    fn noise_free_recovery_on_random_chains(chain in arb_chain(2..=6), seed in 0u64..1000, rot in any::<bool>()) {
        let model = VirtualJointModel::extended(chain.n_joints());
        let truth = random_compliances(model.n_params(), seed);
        let (q, f, d, r) = synthetic(&chain, &model, &truth, 80, seed + 17);
        let mut opts = IdentifyOptions::default();
        opts.use_rotations = rot;
        let id = identify(&chain, &model, Measurements::new(&q, &f, &d).with_rotation(Some(&r)), &opts).unwrap();
        assert_recovers(&id, &truth, 1e-9);
        // Every parameter is either identifiable or in exactly one alias group.
        let aliased: usize = id.aliases.iter().map(Vec::len).sum();
        prop_assert_eq!(aliased + id.identifiable.iter().filter(|&&b| b).count(), id.n_params);
    }
}

proptest! {
    #![proptest_config(config(24))]

    /// The normal equations and the streaming QR agree on random chains (random axes, spring
    /// offsets, translations or 6-D data) wherever Auto keeps the normal equations: same
    /// rank and alias groups, base parameters within 1000·κ²ε (+1e-13) of their scale. Where the
    /// design is worse conditioned than NORMAL_EQUATIONS_MAX_CONDITION, Auto returns the
    /// QR result itself.
    #[test]
    fn normal_equations_agree_with_qr(chain in arb_chain(2..=7), seed in 0u64..1000, rot in any::<bool>(), offsets in any::<bool>()) {
        let n = chain.n_joints();
        let mut model = VirtualJointModel::extended(n);
        if offsets {
            let o = (0..n).map(|j| nalgebra::Vector3::new(0.02 * j as f64, -0.01, 0.015)).collect();
            model = model.with_offsets(o).unwrap();
        }
        let truth = random_compliances(model.n_params(), seed);
        let (q, f, d, r) = synthetic(&chain, &model, &truth, 203, seed + 5);
        let mut opts = IdentifyOptions::default();
        opts.use_rotations = rot;
        opts.method = SolveMethod::Qr;
        let qr = identify(&chain, &model, Measurements::new(&q, &f, &d).with_rotation(Some(&r)), &opts).unwrap();
        opts.method = SolveMethod::Auto;
        let auto = identify(&chain, &model, Measurements::new(&q, &f, &d).with_rotation(Some(&r)), &opts).unwrap();
        let gray = qr.singular_values[qr.rank..].iter().any(|&s| s > 1e-12 * qr.singular_values[0]);
        if qr.condition_number <= 0.5 * NORMAL_EQUATIONS_MAX_CONDITION && !gray {
            prop_assert_eq!(auto.method, SolveMethod::NormalEquations);
            prop_assert_eq!(auto.rank, qr.rank);
            prop_assert_eq!(&auto.aliases, &qr.aliases);
            // Normal equations: relative error ≲ c·p·κ²ε; c·p = 1000 covers p ≤ 22 with room.
            let tol = 1e3 * qr.condition_number.powi(2) * f64::EPSILON + 1e-13;
            for (a, b) in auto.combinations.iter().zip(&qr.combinations) {
                prop_assert_eq!(&a.label, &b.label);
                let scale: f64 = b.terms.iter().map(|t| (t.coefficient * truth[t.param]).abs()).sum();
                prop_assert!((a.value - b.value).abs() <= tol * scale, "{}: {} vs {} (tol {tol:e})", a.label, a.value, b.value);
            }
        } else if auto.method == SolveMethod::Qr {
            prop_assert_eq!(&auto.compliance, &qr.compliance);
            prop_assert_eq!(auto.rank, qr.rank);
        }
    }
}

/// Auto reads the data again through QR when the normal equations cannot be trusted: all
/// configurations within 0.3 mrad of one pose make the design nearly rank-deficient
/// (κ > 1e4), and the result is then exactly the QR one; forcing the normal equations is
/// still possible and says so.
#[test]
fn auto_falls_back_to_qr_when_ill_conditioned() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = random_compliances(21, 9);
    let (q0, f, _, _) = synthetic(&panda, &model, &truth, 400, 90);
    // Shrink every configuration towards the first one.
    let q: Vec<f64> = q0
        .iter()
        .enumerate()
        .map(|(i, v)| q0[i % 7] + 1e-4 * (v - q0[i % 7]))
        .collect();
    let mut d = Vec::new();
    for i in 0..400 {
        let mut fi = [0.0; 6];
        fi.copy_from_slice(&f[6 * i..6 * i + 6]);
        d.extend(
            &predict_deflection(&panda, &model, &truth, &q[7 * i..7 * i + 7], &fi, false).unwrap()
                [..3],
        );
    }
    let mut opts = IdentifyOptions::default();
    let auto = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    opts.method = SolveMethod::Qr;
    let qr = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    assert!(
        qr.condition_number > NORMAL_EQUATIONS_MAX_CONDITION,
        "κ = {}",
        qr.condition_number
    );
    assert_eq!(auto.method, SolveMethod::Qr);
    assert_eq!(auto.compliance, qr.compliance);
    assert_eq!(auto.singular_values, qr.singular_values);
    opts.method = SolveMethod::NormalEquations;
    let ne = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    assert_eq!(ne.method, SolveMethod::NormalEquations);
    assert!(
        ne.rank <= qr.rank,
        "normal equations rank {} vs QR {}",
        ne.rank,
        qr.rank
    );
}

/// The other fallback: a direction QR resolves but the normal equations cannot. Two joints
/// at one origin whose axes differ by 3e-7 rad: their torsions differ in the data only
/// through that angle, σ₂/σ₁ ≈ 1e-7 — above QR's cut-off (1e-9), below the normal
/// equations' (1e-6) but above their rounding floor. Auto must not report rank 1.
#[test]
fn auto_falls_back_to_qr_for_a_weak_but_real_direction() {
    use nalgebra::{Isometry3, Vector3};
    let delta: f64 = 3e-7;
    let joints = vec![
        (
            "j1".to_string(),
            Isometry3::translation(0.0, 0.0, 0.3),
            Vector3::z(),
            (-3.0, 3.0),
        ),
        (
            "j2".to_string(),
            Isometry3::identity(),
            Vector3::new(delta.sin(), 0.0, delta.cos()),
            (-3.0, 3.0),
        ),
    ];
    let tip = Isometry3::translation(0.4, 0.1, 0.2);
    let chain = SerialChain::from_joints("base", "tip", joints, tip).unwrap();
    let model = VirtualJointModel::traditional(2);
    let truth = [2e-5, 3e-5];
    let (q, f, d, r) = synthetic(&chain, &model, &truth, 500, 3);
    let mut opts = IdentifyOptions::default();
    opts.use_rotations = true;
    opts.method = SolveMethod::Qr;
    let qr = identify(
        &chain,
        &model,
        Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    assert_eq!(qr.rank, 2, "singular values {:?}", qr.singular_values);
    let weak = qr.singular_values[1] / qr.singular_values[0];
    assert!(
        weak > NORMAL_EQUATIONS_ROUNDING_FLOOR && weak < NORMAL_EQUATIONS_RANK_RTOL,
        "{weak:e}"
    );
    opts.method = SolveMethod::NormalEquations;
    assert_eq!(
        identify(
            &chain,
            &model,
            Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
            &opts
        )
        .unwrap()
        .rank,
        1
    );
    opts.method = SolveMethod::Auto;
    let auto = identify(
        &chain,
        &model,
        Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    assert_eq!((auto.method, auto.rank), (SolveMethod::Qr, 2));
}

/// Same data, same bits: the per-chunk Gram matrices are added in chunk order whatever
/// rayon's scheduling, so repeated calls agree exactly (20 003 measurements: 5 chunks).
#[test]
fn repeated_identification_is_bitwise_reproducible() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let (q, f, d, _, _) = noisy_panda(20_003, 1e-6, 41);
    let opts = IdentifyOptions::default();
    let first = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    for _ in 0..4 {
        let again = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
        assert_eq!(again.compliance, first.compliance);
        assert_eq!(again.stderr, first.stderr);
    }
}

/// q, wrenches, displacements, rotations, true compliances.
type NoisyData = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

fn noisy_panda(count: usize, sigma: f64, seed: u64) -> NoisyData {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = random_compliances(21, seed);
    let (q, f, mut d, mut r) = synthetic(&panda, &model, &truth, count, seed + 1);
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 2);
    let noise = Normal::new(0.0, sigma).unwrap();
    for v in d.iter_mut().chain(r.iter_mut()) {
        *v += noise.sample(&mut rng);
    }
    (q, f, d, r, truth)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

/// Acceptance: both streaming paths — normal equations (lane-wise, the default here) and
/// TSQR (rayon threads, blocks of 64 rows, chunks of 4096 measurements) — agree with the
/// dense path (whole design, faer QR) to 1e-10 relative on estimates, standard errors and
/// base parameters, with noisy data, so the residual and σ² are exercised too. (κ ≈ 70 on
/// this design, so the normal equations' κ²ε is ~1e-12.) 20 000 is not a multiple of the
/// lane count or the chunk size, so partial blocks are exercised as well.
#[test]
fn streaming_matches_dense() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    for (rot, method) in [false, true]
        .into_iter()
        .flat_map(|r| [(r, SolveMethod::Auto), (r, SolveMethod::Qr)])
    {
        let (q, f, d, r, _) = noisy_panda(20_003, 1e-6, 40);
        let mut opts = IdentifyOptions::default();
        opts.use_rotations = rot;
        opts.method = method;
        let s = identify(
            &panda,
            &model,
            Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
            &opts,
        )
        .unwrap();
        let expect = if method == SolveMethod::Qr {
            SolveMethod::Qr
        } else {
            SolveMethod::NormalEquations
        };
        assert_eq!(s.method, expect);
        opts.method = SolveMethod::Qr;
        let dn = identify_dense(
            &panda,
            &model,
            Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
            &opts,
        )
        .unwrap();
        assert_eq!(s.rank, dn.rank);
        assert_eq!(s.aliases, dn.aliases);
        assert_eq!(s.n_equations, dn.n_equations);
        for k in 0..21 {
            match (s.compliance[k], dn.compliance[k]) {
                (Some(a), Some(b)) => {
                    assert!(rel(a, b) < 1e-10, "param {k}: {a} vs {b}");
                    assert!(rel(s.stderr[k].unwrap(), dn.stderr[k].unwrap()) < 1e-10);
                }
                (None, None) => {}
                other => panic!("param {k}: {other:?}"),
            }
        }
        for (a, b) in s.combinations.iter().zip(&dn.combinations) {
            assert_eq!(a.terms.len(), b.terms.len());
            assert!(
                rel(a.value, b.value) < 1e-10,
                "{}: {} vs {}",
                a.label,
                a.value,
                b.value
            );
        }
        assert!(rel(s.residual_rms, dn.residual_rms) < 1e-10);
    }
}

/// With the true noise σ given (`noise_scale_known`), standard errors are calibrated:
/// over 200 noisy replicates, E[z²] ≈ 1 and the 95 % intervals cover ≈ 95 %.
#[test]
fn standard_errors_are_calibrated() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let truth = random_compliances(7, 9);
    let sigma = 2e-6;
    let (q, f, d0, _) = synthetic(&panda, &model, &truth, 60, 10);
    let mut opts = IdentifyOptions::default();
    opts.noise_sigma = [sigma; 6];
    opts.noise_scale_known = true;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, sigma).unwrap();
    let (mut z2, mut covered, mut total) = (0.0, 0, 0);
    for _ in 0..200 {
        let d: Vec<f64> = d0.iter().map(|v| v + noise.sample(&mut rng)).collect();
        let id = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
        for (k, &t) in truth.iter().enumerate().take(6) {
            let (c, s) = (id.compliance[k].unwrap(), id.stderr[k].unwrap());
            z2 += ((c - t) / s).powi(2);
            let (lo, hi) = id.ci95[k].unwrap();
            covered += usize::from(lo <= t && t <= hi);
            total += 1;
        }
    }
    let mean_z2 = z2 / total as f64;
    let coverage = covered as f64 / total as f64;
    // 1200 samples: sd of mean z² ≈ 0.04, of coverage ≈ 0.006.
    assert!((mean_z2 - 1.0).abs() < 0.2, "E[z²] = {mean_z2}");
    assert!((coverage - 0.95).abs() < 0.03, "coverage {coverage}");
}

/// With the noise scale unknown, σ² is estimated from the residuals: data with noise
/// 1e-6 m whitened by the default 1e-5 m give σ² ≈ 0.01.
#[test]
fn sigma_estimated_from_residuals() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let (q, f, d, _, _) = noisy_panda(2000, 1e-6, 50);
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d),
        &IdentifyOptions::default(),
    )
    .unwrap();
    let s2 = id.sigma2.unwrap();
    assert!((s2 / 0.01 - 1.0).abs() < 0.1, "σ² = {s2}");
    assert!(
        (id.residual_rms - 0.1).abs() < 0.01,
        "rms {}",
        id.residual_rms
    );
}

/// Non-negative LS: with the constraint inactive (noise-free, positive truth) it equals
/// the unconstrained solution; with data from a negative compliance every identifiable
/// estimate is ≥ 0 and the KKT conditions hold on the whitened design.
#[test]
fn nonnegative_least_squares() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let mut truth = random_compliances(7, 21);
    let (q, f, d, _) = synthetic(&panda, &model, &truth, 40, 22);
    let mut opts = IdentifyOptions::default();
    opts.nonnegative = true;
    let id = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    assert_recovers(&id, &truth, 1e-9);

    // Data from a (non-physical) negative compliance: the constraint must become active.
    truth[5] = -3e-6;
    let (q, f, d, _) = synthetic(&panda, &model, &truth, 40, 23);
    let free = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d),
        &IdentifyOptions::default(),
    )
    .unwrap();
    assert!(free.compliance[5].unwrap() < 0.0);
    let id = identify(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    let x = &id.solution.solution;
    for k in 0..6 {
        assert!(id.compliance[k].unwrap() >= 0.0);
    }
    // KKT on the whitened problem: gradient g = Aᵀ(b − Ax); g_k ≤ 0 where x_k = 0, g_k ≈ 0 where x_k > 0.
    let (a, b) = build_design(&panda, &model, Measurements::new(&q, &f, &d), &opts).unwrap();
    let m = 7;
    let rows = b.len();
    let mut g = vec![0.0; m];
    let mut gscale = 0.0f64;
    for i in 0..rows {
        let ri = b[i] - (0..m).map(|k| a[i * m + k] * x[k]).sum::<f64>();
        for k in 0..m {
            g[k] += a[i * m + k] * ri;
            gscale = gscale.max((a[i * m + k] * b[i]).abs());
        }
    }
    for k in 0..6 {
        if x[k] == 0.0 {
            assert!(g[k] <= 1e-9 * gscale * rows as f64, "g[{k}] = {}", g[k]);
        } else {
            assert!(
                g[k].abs() <= 1e-9 * gscale * rows as f64,
                "g[{k}] = {}",
                g[k]
            );
        }
    }
    assert_eq!(id.compliance[5], Some(0.0));
}

/// The result serialises to the JSON the CLI writes: `null` for unidentifiable compliances.
#[test]
fn json_ready() {
    let id = noise_free_panda(false);
    let json = serde_json::to_value(&id).unwrap();
    assert_eq!(json["rank"], 15);
    assert_eq!(json["parameters"][18]["axis"], "z");
    assert_eq!(json["parameters"][18]["joint"], 7);
    assert!(json["parameters"][18]["compliance"].is_null());
    assert_eq!(json["parameters"][18]["identifiable"], false);
    assert!(json["combinations"][0]["value"].is_number());
}
