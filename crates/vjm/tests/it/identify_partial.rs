//! Partial identification statistics: parts of a campaign merged in any grouping give the
//! single-pass (QR) identification; incompatible parts are refused, naming what differs.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use vjm::Measurements;
use vjm::{
    identify, Identification, IdentificationPartial, IdentifyOptions, SerialChain, SolveMethod,
    VirtualJointModel, VjmError,
};

use crate::identification::synthetic;
use crate::strategies::random_compliances;

/// q, wrenches, displacements, rotations of `count` noisy measurements (1 µm, 1 µrad).
fn campaign(count: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let truth = random_compliances(21, seed);
    let (q, f, mut d, mut r) = synthetic(&panda, &model, &truth, count, seed + 1);
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 2);
    let noise = Normal::new(0.0, 1e-6).unwrap();
    for v in d.iter_mut().chain(r.iter_mut()) {
        *v += noise.sample(&mut rng);
    }
    (q, f, d, r)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

/// Same rank, aliases and equations; estimates, standard errors, base parameters and the
/// residual within `tol` relative.
fn assert_same(a: &Identification, b: &Identification, tol: f64) {
    assert_eq!(a.rank, b.rank);
    assert_eq!(a.aliases, b.aliases);
    assert_eq!(a.n_equations, b.n_equations);
    assert_eq!(a.model, b.model);
    for k in 0..a.n_params {
        match (a.compliance[k], b.compliance[k]) {
            (Some(x), Some(y)) => {
                assert!(rel(x, y) < tol, "param {k}: {x} vs {y}");
                let (sx, sy) = (a.stderr[k].unwrap(), b.stderr[k].unwrap());
                assert!(rel(sx, sy) < tol, "stderr {k}: {sx} vs {sy}");
            }
            (None, None) => {}
            other => panic!("param {k}: {other:?}"),
        }
    }
    for (x, y) in a.combinations.iter().zip(&b.combinations) {
        assert!(
            rel(x.value, y.value) < tol,
            "{}: {} vs {}",
            x.label,
            x.value,
            y.value
        );
    }
    assert!(rel(a.residual_rms, b.residual_rms) < tol);
}

/// Acceptance (issue 12): a campaign split in three parts of unequal sizes (not multiples of
/// the 64-row fold block or the 4096-measurement chunk), merged as (a·b)·c and a·(b·c), equals
/// the single-pass QR identification to 1e-12 relative, with and without rotations.
#[test]
fn three_parts_merged_in_either_grouping_equal_the_single_pass() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let (q, f, d, r) = campaign(9_001, 7);
    for rot in [false, true] {
        let mut opts = IdentifyOptions::default();
        opts.use_rotations = rot;
        opts.method = SolveMethod::Qr;
        let single = identify(
            &panda,
            &model,
            Measurements::new(&q, &f, &d).with_rotation(Some(&r)),
            &opts,
        )
        .unwrap();
        let cuts = [0, 1_234, 5_000, 9_001];
        let parts: Vec<IdentificationPartial> = cuts
            .windows(2)
            .map(|w| {
                let (s, e) = (w[0], w[1]);
                IdentificationPartial::accumulate(
                    &panda,
                    &model,
                    Measurements::new(&q[7 * s..7 * e], &f[6 * s..6 * e], &d[3 * s..3 * e])
                        .with_rotation(Some(&r[3 * s..3 * e])),
                    &opts,
                )
                .unwrap()
            })
            .collect();
        let left = parts[0].merge(&parts[1]).unwrap().merge(&parts[2]).unwrap();
        let right = parts[0].merge(&parts[1].merge(&parts[2]).unwrap()).unwrap();
        assert_eq!(left.measurements(), 9_001);
        for merged in [&left, &right] {
            let id = merged.finish(&panda).unwrap();
            assert_eq!(id.method, SolveMethod::Qr);
            assert_same(&id, &single, 1e-12);
        }
    }
}

/// The empty partial is neutral, and a partial rebuilt from its parts (as after pickling)
/// merges as the original does.
#[test]
fn empty_is_neutral_and_parts_round_trip() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let (q, f, d, _) = campaign(300, 11);
    let opts = IdentifyOptions::default();
    let whole =
        IdentificationPartial::accumulate(&panda, &model, Measurements::new(&q, &f, &d), &opts)
            .unwrap();
    let empty = IdentificationPartial::empty(&panda, &model, &opts).unwrap();
    let id = whole.finish(&panda).unwrap();
    assert_same(
        &empty.merge(&whole).unwrap().finish(&panda).unwrap(),
        &id,
        1e-14,
    );
    assert_same(
        &whole.merge(&empty).unwrap().finish(&panda).unwrap(),
        &id,
        1e-14,
    );
    let factor = whole.factor();
    let rebuilt = IdentificationPartial::from_parts(
        &panda,
        &model,
        &opts,
        factor.r().to_vec(),
        factor.nrows(),
        whole.measurements(),
    )
    .unwrap();
    assert_eq!(rebuilt, whole);
}

/// Parts of another model, other options or another robot are refused, naming what differs;
/// so is finishing on another robot.
#[test]
fn incompatible_parts_are_refused() {
    let panda = SerialChain::bundled();
    let tcp = SerialChain::bundled_with_tip(vjm::BUNDLED_TCP).unwrap();
    let (q, f, d, _) = campaign(200, 3);
    let opts = IdentifyOptions::default();
    let trad = VirtualJointModel::traditional(7);
    let a = IdentificationPartial::accumulate(&panda, &trad, Measurements::new(&q, &f, &d), &opts)
        .unwrap();
    let ext = VirtualJointModel::extended(7);
    let b = IdentificationPartial::accumulate(&panda, &ext, Measurements::new(&q, &f, &d), &opts)
        .unwrap();
    let mut other = opts;
    other.noise_sigma[0] = 2e-5;
    let c = IdentificationPartial::accumulate(&panda, &trad, Measurements::new(&q, &f, &d), &other)
        .unwrap();
    let e = IdentificationPartial::empty(&tcp, &trad, &opts).unwrap();
    for (x, what) in [(&b, "model"), (&c, "options"), (&e, "robot kinematics")] {
        match a.merge(x) {
            Err(VjmError::IncompatiblePartials { what: got, .. }) => assert_eq!(got, what),
            other => panic!("{what}: {other:?}"),
        }
    }
    match a.finish(&tcp) {
        Err(VjmError::IncompatiblePartials { what, .. }) => assert_eq!(what, "robot kinematics"),
        other => panic!("{other:?}"),
    }
    // A factor with a non-finite entry (a corrupted message) is refused at its position.
    let mut r = a.factor().r().to_vec();
    r[9] = f64::NAN;
    match IdentificationPartial::from_parts(&panda, &trad, &opts, r, 600, 200) {
        Err(VjmError::NonFinite { row, column, .. }) => assert_eq!((row, column), (1, 1)),
        other => panic!("{other:?}"),
    }
}
