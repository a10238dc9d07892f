//! Experiment design: dexterity (seed Table I's measure) and greedy selection.

use vjm::Measurements;
use vjm::{dexterity, identify, select_configurations, Measured, SerialChain, VirtualJointModel};

use crate::strategies::{random_compliances, random_configurations, random_wrenches};

/// κ_F⁻¹ is 0 at the stretched-out zero pose (singular, as the seed's pose 11), in (0, 1]
/// elsewhere, and independent of joint 1 (a rotation of the whole arm about the base z).
#[test]
fn dexterity_index() {
    let panda = SerialChain::bundled();
    assert_eq!(dexterity(&panda, &[0.0; 7], 0.5).unwrap(), 0.0);
    let q = [0.0, -0.4, 0.3, -2.0, 0.5, 1.7, 0.2];
    let k = dexterity(&panda, &q, 0.5).unwrap();
    assert!(k > 0.0 && k <= 1.0, "{k}");
    let mut q2 = q;
    q2[0] = 1.3;
    assert!((dexterity(&panda, &q2, 0.5).unwrap() - k).abs() < 1e-12);
    assert!(dexterity(&panda, &q, 0.0)
        .unwrap_err()
        .to_string()
        .contains("length"));
}

/// Greedy D-optimal selection reaches the pool's identifiable subspace with few
/// configurations, better conditioned than the same number taken in pool order, and
/// identification from the selected subset recovers the base parameters.
#[test]
fn greedy_selection_is_well_conditioned() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let pool = random_configurations(&panda, 200, 31);
    let wrenches: Vec<[f64; 6]> = random_wrenches(2, 32)
        .chunks(6)
        .map(|c| c.try_into().unwrap())
        .collect();
    let sel =
        select_configurations(&panda, &model, &pool, &wrenches, Measured::Translation, 12).unwrap();
    assert_eq!(
        sel.rank, 15,
        "the translational rank of the Panda (see identification.rs)"
    );
    assert_eq!(sel.indices.len(), 12);
    let mut uniq = sel.indices.clone();
    uniq.sort();
    uniq.dedup();
    assert_eq!(uniq.len(), 12);
    let last = *sel.condition_numbers.last().unwrap();
    assert!(last.is_finite());
    assert!(sel.pool_condition_number.is_finite());
    // The first 12 of the pool, scored the same way, are worse conditioned.
    let first: Vec<f64> = pool[..12 * 7].to_vec();
    let naive = select_configurations(&panda, &model, &first, &wrenches, Measured::Translation, 12)
        .unwrap();
    let naive_cond = *naive.condition_numbers.last().unwrap();
    println!(
        "selected 12/200: cond {last:.1}; first 12: cond {naive_cond:.1}; pool: {:.1}",
        sel.pool_condition_number
    );
    assert!(
        naive.rank < 15 || naive_cond > last,
        "{naive_cond} vs {last}"
    );
    // Identification from the selected configurations (each under both wrenches).
    let truth = random_compliances(21, 33);
    let mut q = Vec::new();
    let mut f = Vec::new();
    for &i in &sel.indices {
        for w in &wrenches {
            q.extend_from_slice(&pool[7 * i..7 * i + 7]);
            f.extend_from_slice(w);
        }
    }
    let mut d = Vec::new();
    for i in 0..q.len() / 7 {
        let w: [f64; 6] = f[6 * i..6 * i + 6].try_into().unwrap();
        let x = vjm::predict_deflection(&panda, &model, &truth, &q[7 * i..7 * i + 7], &w, false)
            .unwrap();
        d.extend_from_slice(&x[..3]);
    }
    let id = identify(
        &panda,
        &model,
        Measurements::new(&q, &f, &d),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(id.rank, 15);
    crate::identification::assert_recovers(&id, &truth, 1e-9);
}

#[test]
fn selection_errors() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let err = select_configurations(&panda, &model, &[0.0; 14], &[[1.0; 6]], Measured::Full, 3)
        .unwrap_err();
    assert!(
        err.to_string().contains("count") && err.to_string().contains("1..=2"),
        "{err}"
    );
    let err = select_configurations(&panda, &model, &[0.0; 13], &[[1.0; 6]], Measured::Full, 1)
        .unwrap_err();
    assert!(err.to_string().contains("pool"), "{err}");
    let err =
        select_configurations(&panda, &model, &[0.0; 14], &[], Measured::Full, 1).unwrap_err();
    assert!(err.to_string().contains("wrenches"), "{err}");
}
