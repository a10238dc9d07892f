//! Lost motion in a gear curve (`GearCurve::lost_motion`, issue 22): the curve by cases, the
//! model file's optional `lost_motion_rad`, `predict`'s first-order term against the
//! definition, the exact equilibrium against a linear equilibrium that knows nothing of curves,
//! `compensate` on the curved equilibrium, and a diagnosed `joint_backlash` as the saved
//! model's lost motion.

use vjm::gear::GearCurve;
use vjm::gravity::{
    deflection_under_gravity, deflection_under_gravity_with_gears, static_equilibrium,
    static_equilibrium_with_gears, Gravity, Loading,
};
use vjm::{CompensateOptions, CompensationStatus, Load, SerialChain, VirtualJointModel};

use super::gear_predict::{panda_model, shoulder_curve};

const B: f64 = 2e-3;

fn bits(d: [f64; 6]) -> [u64; 6] {
    d.map(f64::to_bits)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// θ(T) = c·T + Σ a h(T) + ½ b sign(T) by cases (sign(0) = 0); a curve with lost motion and no
/// knots; b = 0 is `GearCurve::new`; a negative, NaN or infinite b is refused naming the joint
/// and the value; no knots and no lost motion is refused.
#[test]
fn a_gear_curve_with_lost_motion_is_its_definition() {
    let (c, knots, a) = (1.0 / 12e3, [5.0, 15.0], [1.2e-4, -0.4e-4]);
    let curve = GearCurve::with_lost_motion(1, knots.to_vec(), a.to_vec(), B).unwrap();
    assert_eq!(curve.lost_motion(), B);
    let only = GearCurve::with_lost_motion(1, vec![], vec![], B).unwrap();
    for i in -400..=400 {
        let t = 0.1 * i as f64 + if i % 7 == 0 { 0.0 } else { 0.013 };
        let mut by_cases = c * t;
        for k in 0..2 {
            if t > knots[k] {
                by_cases += a[k] * (t - knots[k]);
            } else if t < -knots[k] {
                by_cases += a[k] * (t + knots[k]);
            }
        }
        let lost = if t > 0.0 {
            0.5 * B
        } else if t < 0.0 {
            -0.5 * B
        } else {
            0.0
        };
        let got = curve.deflection(c, t);
        assert!(
            (got - by_cases - lost).abs() <= 1e-15 * (by_cases.abs() + B),
            "T = {t}"
        );
        assert!((only.deflection(c, t) - c * t - lost).abs() <= 1e-18 + 1e-15 * B);
    }
    assert_eq!(curve.deflection(c, 0.0), 0.0);
    assert_eq!(curve.deflection(c, -0.0), 0.0);
    assert_eq!(
        GearCurve::with_lost_motion(1, knots.to_vec(), a.to_vec(), 0.0).unwrap(),
        GearCurve::new(1, knots.to_vec(), a.to_vec()).unwrap()
    );
    for bad in [-1e-4, f64::NAN, f64::INFINITY] {
        let e = GearCurve::with_lost_motion(2, vec![], vec![], bad).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("joint 3")
                && text.contains("lost motion")
                && text.contains(&format!("{bad}")),
            "{text}"
        );
    }
    assert!(GearCurve::with_lost_motion(2, vec![], vec![], 0.0).is_err());
    assert!(GearCurve::with_lost_motion(2, vec![1.0], vec![], B).is_err());
}

/// The model file: a curve without lost motion writes no `lost_motion_rad` (the text and content
/// hash of the file written before lost motion existed, which reads back to the same hash); a
/// lost motion round-trips; a negative or NaN one in the file is refused naming the field and
/// the joint.
#[test]
fn the_model_file_records_lost_motion_only_when_there_is_some() {
    use vjm::StiffnessModel;
    let (_, sm, _) = panda_model();
    let old = sm.clone().with_gear_curves(&[shoulder_curve()]).unwrap();
    let old_text = old.to_json();
    assert!(!old_text.contains("lost_motion"));
    // The file as written before: the same text and hash again after a read.
    let reread = StiffnessModel::from_json(&old_text, "old.json").unwrap();
    assert_eq!(reread.to_json(), old_text);
    assert_eq!(reread.content_sha256(), old.content_sha256());
    let zero = GearCurve::with_lost_motion(1, vec![5.0, 15.0], vec![1e-4, -0.5e-4], 0.0).unwrap();
    let z = sm.clone().with_gear_curves(&[zero]).unwrap();
    assert_eq!(z.to_json(), old_text);
    assert_eq!(z.content_sha256(), old.content_sha256());
    // Round trips: with knots, and lost motion alone.
    for curve in [
        GearCurve::with_lost_motion(1, vec![5.0, 15.0], vec![1e-4, -0.5e-4], B).unwrap(),
        GearCurve::with_lost_motion(3, vec![], vec![], 3.25e-4).unwrap(),
    ] {
        let m = sm
            .clone()
            .with_gear_curves(std::slice::from_ref(&curve))
            .unwrap();
        let text = m.to_json();
        assert!(text.contains("\"lost_motion_rad\""), "{text}");
        let back = StiffnessModel::from_json(&text, "m.json").unwrap();
        assert_eq!(back.gear_curves().unwrap(), vec![curve]);
        assert_eq!(back.content_sha256(), m.content_sha256());
        assert_ne!(back.content_sha256(), old.content_sha256());
    }
    // A negative or zero lost motion in the file, re-sealed with the edited content's hash (a
    // NaN cannot be written in JSON; `null` is "absent").
    let m = sm
        .clone()
        .with_gear_curves(&[GearCurve::with_lost_motion(3, vec![], vec![], B).unwrap()])
        .unwrap();
    let good = m.to_json();
    let compact = serde_json::to_string(&m).unwrap();
    assert_eq!(vjm::sha256_hex(compact.as_bytes()), m.content_sha256());
    let field = format!("\"lost_motion_rad\":{B}");
    assert!(compact.contains(&field), "{compact}");
    for (bad, shown) in [("-0.002", "is -0.002 "), ("0.0", "is 0 ")] {
        let edited = compact.replace(&field, &format!("\"lost_motion_rad\":{bad}"));
        let text = good
            .replace(
                &format!("\"lost_motion_rad\": {B}"),
                &format!("\"lost_motion_rad\": {bad}"),
            )
            .replace(&m.content_sha256(), &vjm::sha256_hex(edited.as_bytes()));
        let e = match StiffnessModel::from_json(&text, "bad.json") {
            Err(e) => e.to_string(),
            Ok(_) => panic!("lost_motion_rad {bad} accepted"),
        };
        assert!(
            e.contains("gear_curves[0].lost_motion_rad")
                && e.contains("joint 4")
                && e.contains(shown),
            "{bad}: {e}"
        );
    }
}

/// Weightless `predict`: the lost motion adds `J_2 · ½ b (sign(τ₀ + τ) − sign(τ₀))` with τ₀ = 0
/// and τ = J_2ᵀ W, i.e. `J_2 · ½ b sign(τ)`, with J from `vjm::jacobian`; under gravity the
/// share (curved − linear) is either exactly 0 (the load keeps the preload's sign) or
/// `± b J_2` at the sagged pose, and matches the exact equilibria's share to first order; b = 0
/// predicts as the curve without it, bit for bit.
#[test]
fn predict_adds_the_lost_motion_of_a_sign_change() {
    let (chain, sm, data) = panda_model();
    let model = VirtualJointModel::traditional(7);
    let lost = GearCurve::with_lost_motion(1, vec![], vec![], B).unwrap();
    let curved = sm
        .clone()
        .with_gear_curves(std::slice::from_ref(&lost))
        .unwrap();
    let (mut positive, mut negative) = (0, 0);
    for i in 0..data.len().min(40) {
        let (q, w) = (data.q(i), data.wrench(i));
        let plain = sm.predict(&chain, q, Load::Wrench(&w)).unwrap()[0];
        let bent = curved.predict(&chain, q, Load::Wrench(&w)).unwrap()[0];
        let j = vjm::jacobian(&chain, &model, q).unwrap();
        let tau: f64 = (0..6).map(|r| j[(r, 1)] * w[r]).sum();
        let s = if tau > 0.0 {
            positive += 1;
            1.0
        } else if tau < 0.0 {
            negative += 1;
            -1.0
        } else {
            0.0
        };
        for r in 0..3 {
            let want = plain.deflection[r] + j[(r, 1)] * 0.5 * B * s;
            assert!(
                (bent.deflection[r] - want).abs() <= 1e-12 * want.abs().max(1e-6),
                "row {i} axis {r}: {} vs {want}",
                bent.deflection[r]
            );
        }
    }
    assert!(positive >= 5 && negative >= 5, "{positive} +, {negative} −");
    // Under gravity.
    let c = sm.determined_compliance().unwrap();
    let g = Gravity::default();
    let (mut zero, mut flipped) = (0, 0);
    for i in 0..data.len().min(30) {
        let (q, w) = (data.q(i), data.wrench(i));
        let plain = sm
            .predict_under_gravity(&chain, q, Load::Wrench(&w), &g)
            .unwrap()[0];
        let bent = curved
            .predict_under_gravity(&chain, q, Load::Wrench(&w), &g)
            .unwrap()[0];
        let share: Vec<f64> = (0..3)
            .map(|r| bent.deflection[r] - plain.deflection[r])
            .collect();
        let j = vjm::jacobian(&chain, &model, q).unwrap();
        let lever = norm(&[j[(0, 1)], j[(1, 1)], j[(2, 1)]]);
        let exact_plain = deflection_under_gravity(&chain, &model, &c, q, &w, &g, None).unwrap();
        let loading = vjm::gravity::Loading {
            gravity: Some(g),
            payload: None,
            wrench: Some(w),
        };
        let exact_bent = deflection_under_gravity_with_gears(
            &chain,
            &model,
            &c,
            std::slice::from_ref(&lost),
            q,
            &loading,
        )
        .unwrap();
        let exact: Vec<f64> = (0..3).map(|r| exact_bent[r] - exact_plain[r]).collect();
        if share.iter().all(|&x| x == 0.0) {
            zero += 1;
        } else {
            flipped += 1;
            // ± b J_2 at the sagged pose: within 1 % of b |J_2| at the rigid pose.
            assert!(
                (norm(&share) - B * lever).abs() <= 1e-2 * B * lever,
                "row {i}: {} vs b|J_2| = {}",
                norm(&share),
                B * lever
            );
        }
        let diff: Vec<f64> = share.iter().zip(&exact).map(|(a, b)| a - b).collect();
        assert!(
            norm(&diff) <= 2e-2 * B * lever,
            "row {i}: share {share:?}, exact {exact:?}"
        );
    }
    // The weight's preload keeps the shoulder's sign on most rows of this campaign.
    assert!(zero >= 3 && flipped >= 1, "{zero} kept, {flipped} flipped");
    // b = 0 is the curve without it, bit for bit.
    let with_zero = sm
        .clone()
        .with_gear_curves(&[GearCurve::with_lost_motion(
            1,
            vec![5.0, 15.0],
            vec![1e-4, -0.5e-4],
            0.0,
        )
        .unwrap()])
        .unwrap();
    let without = sm.clone().with_gear_curves(&[shoulder_curve()]).unwrap();
    let rows = data.len().min(20);
    let q = &data.q_flat()[..7 * rows];
    let w = &data.wrench_flat()[..6 * rows];
    let a = with_zero.predict(&chain, q, Load::Wrench(w)).unwrap();
    let b = without.predict(&chain, q, Load::Wrench(w)).unwrap();
    let ag = with_zero
        .predict_under_gravity(&chain, q, Load::Wrench(w), &g)
        .unwrap();
    let bg = without
        .predict_under_gravity(&chain, q, Load::Wrench(w), &g)
        .unwrap();
    for i in 0..rows {
        assert_eq!(bits(a[i].deflection), bits(b[i].deflection), "row {i}");
        assert_eq!(bits(ag[i].deflection), bits(bg[i].deflection), "row {i}");
    }
}

/// The secant compliance `s` with which a linear equilibrium (`static_equilibrium`, which knows
/// nothing of curves) puts spring 1 where the curve does: θ₂ = s τ₂ = θ(τ₂).
fn secant_equilibrium(
    chain: &SerialChain,
    model: &VirtualJointModel,
    c: &[f64],
    curve: &GearCurve,
    q: &[f64],
    loading: &Loading<'_>,
) -> vjm::gravity::Equilibrium {
    let mut s = c[1];
    let mut cs = c.to_vec();
    for _ in 0..80 {
        cs[1] = s;
        let lin = static_equilibrium(chain, model, &cs, q, loading).unwrap();
        let tau = lin.theta[1] / s;
        s = curve.deflection(c[1], tau) / tau;
    }
    cs[1] = s;
    static_equilibrium(chain, model, &cs, q, loading).unwrap()
}

/// The exact equilibrium with lost motion at the shoulder, at poses where the weight's preload
/// keeps the shoulder torque's sign: every spring's θ equals a linear equilibrium with the
/// curve's secant compliance (independent: no curve in it), and the tip moves from the
/// equilibrium without lost motion by the tip motion of ½ b sign(τ₂) at the shoulder,
/// `J_2 ½ b sign(τ₂)`, to first order (3 % of b |J_2|: the weight's stiffness on the shifted
/// pose, measured 1.4 %). A weightless arm under no load carries no torque: the gear sits mid-band (θ = 0).
#[test]
fn the_equilibrium_shifts_a_preloaded_joint_by_half_its_lost_motion() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [2e-4, 1.0 / 5e3, 2e-4, 1.0 / 5e3, 2e-4, 2e-4, 2e-4];
    let curve = GearCurve::with_lost_motion(1, vec![], vec![], B).unwrap();
    let g = Gravity::default();
    let mut signs = [0, 0];
    for q in [
        [0.2, 0.6, -0.1, -1.2, 0.1, 1.6, 0.3],
        [0.0, -0.7, 0.3, -2.0, 0.0, 1.2, 0.0],
        [1.0, 0.9, 0.0, -0.8, 0.4, 1.9, -0.5],
    ] {
        let loading = Loading {
            gravity: Some(g),
            payload: None,
            wrench: Some([5.0, -3.0, -10.0, 0.2, 0.0, 0.1]),
        };
        let plain = static_equilibrium(&panda, &model, &c, &q, &loading).unwrap();
        let eq = static_equilibrium_with_gears(
            &panda,
            &model,
            &c,
            std::slice::from_ref(&curve),
            &q,
            &loading,
        )
        .unwrap();
        let tau2 = plain.theta[1] / c[1];
        let s = tau2.signum();
        signs[usize::from(s > 0.0)] += 1;
        assert!(
            tau2.abs() > 5.0,
            "the weight preloads the shoulder: {tau2} N·m"
        );
        let lin = secant_equilibrium(&panda, &model, &c, &curve, &q, &loading);
        for k in 0..7 {
            assert!(
                (lin.theta[k] - eq.theta[k]).abs() <= 1e-10 * eq.theta[k].abs().max(1e-6),
                "spring {k}: {} vs {}",
                lin.theta[k],
                eq.theta[k]
            );
        }
        let j = vjm::jacobian(&panda, &model, &q).unwrap();
        let moved = (eq.tip.translation.vector - plain.tip.translation.vector).norm();
        let want: Vec<f64> = (0..3).map(|r| j[(r, 1)] * 0.5 * B * s).collect();
        let d: Vec<f64> = (0..3)
            .map(|r| eq.tip.translation.vector[r] - plain.tip.translation.vector[r] - want[r])
            .collect();
        assert!(
            norm(&d) <= 3e-2 * norm(&want),
            "moved {moved} m, want {want:?}, off by {d:?}"
        );
    }
    assert!(signs[0] + signs[1] == 3);
    // No load, no weight: zero torque everywhere, the gear mid-band.
    let none = Loading::default();
    let eq = static_equilibrium_with_gears(
        &panda,
        &model,
        &c,
        std::slice::from_ref(&curve),
        &[0.2, 0.6, -0.1, -1.2, 0.1, 1.6, 0.3],
        &none,
    )
    .unwrap();
    assert!(eq.theta.iter().all(|&t| t == 0.0), "{:?}", eq.theta);
}

/// Compensate with a lost-motion curve under gravity: at the corrected targets the curved
/// equilibrium (the independent evaluation) puts the tip on the nominal pose within 2e-9 m,
/// where targets corrected without the lost motion miss by about b |J_2| / 2.
#[test]
fn compensation_under_gravity_takes_up_the_lost_motion() {
    let curve = GearCurve::with_lost_motion(1, vec![5.0, 15.0], vec![1e-4, -0.5e-4], B).unwrap();
    let misses = super::gear_compensate::curved_compensation_misses(&curve, 1e-4);
    assert!(misses >= 6, "the lost motion matters on only {misses} rows");
}

/// A gear whose torque at the equilibrium without lost motion is nearly zero (1e-4 N·m): its
/// lost motion's ½ b shifts the arm and, through the load's K_C, the torque by far more. Where
/// K_C reverses the torque (one of a wrench W and −W, each tuned so that the shoulder carries
/// 1e-4 N·m without lost motion) the sign never settles and the equilibrium is an error naming
/// the joint, quickly (not a hang); where K_C keeps it, the equilibrium has θ₂ − c τ₂ = ½ b
/// sign(τ₂) at its own torque (the shoulder's torque recovered from a linear equilibrium with
/// the same θ: the secant check).
#[test]
fn a_gear_whose_slack_reverses_its_torque_is_an_error_naming_the_joint() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [2e-4, 1.0 / 5e3, 2e-4, 1.0 / 5e3, 2e-4, 2e-4, 2e-4];
    let q = [0.2, 0.6, -0.1, -1.2, 0.1, 1.6, 0.3];
    let curve = GearCurve::with_lost_motion(1, vec![], vec![], B).unwrap();
    let j = vjm::jacobian(&panda, &model, &q).unwrap();
    // A force direction that loads the shoulder: its Jacobian column's linear part.
    let e = [j[(0, 1)], j[(1, 1)], j[(2, 1)], 0.0, 0.0, 0.0];
    let (mut errors, mut settled) = (0, 0);
    for sign in [1.0, -1.0] {
        let base = [sign * 40.0, sign * -60.0, sign * -80.0, 0.0, 0.0, 0.0];
        let at = |alpha: f64| {
            let w: [f64; 6] = std::array::from_fn(|r| base[r] + alpha * e[r]);
            let loading = Loading {
                gravity: None,
                payload: None,
                wrench: Some(w),
            };
            let plain = static_equilibrium(&panda, &model, &c, &q, &loading).unwrap();
            (plain.theta[1] / c[1], w)
        };
        // Secant iterations on alpha: the shoulder's torque at equilibrium → 1e-4 N·m.
        let (mut a0, mut a1) = (0.0, 1.0);
        let (mut t0, mut t1) = (at(a0).0 - 1e-4, at(a1).0 - 1e-4);
        for _ in 0..30 {
            if t1.abs() < 1e-9 {
                break;
            }
            let a2 = a1 - t1 * (a1 - a0) / (t1 - t0);
            (a0, t0) = (a1, t1);
            a1 = a2;
            t1 = at(a1).0 - 1e-4;
        }
        let (tau2, w) = at(a1);
        assert!((tau2 - 1e-4).abs() < 1e-8, "tuned torque {tau2}");
        let loading = Loading {
            gravity: None,
            payload: None,
            wrench: Some(w),
        };
        match static_equilibrium_with_gears(
            &panda,
            &model,
            &c,
            std::slice::from_ref(&curve),
            &q,
            &loading,
        ) {
            Err(err) => {
                let text = err.to_string();
                assert!(
                    text.contains("joint 2") && text.contains("dead band"),
                    "{text}"
                );
                errors += 1;
            }
            Ok(eq) => {
                // The shoulder rests on a flank of its dead band: θ₂ = c τ₂ ± ½ b with the
                // torque K_C gives it, |c τ₂| ≪ ½ b (K_C ½ b ≈ 0.05 N·m: c τ₂ ≈ 1e-5 rad).
                let flank = (eq.theta[1].abs() - 0.5 * B).abs();
                assert!(
                    flank <= 0.05 * B,
                    "θ₂ = {} rad, ½ b = {}",
                    eq.theta[1],
                    0.5 * B
                );
                settled += 1;
            }
        }
    }
    assert_eq!(errors, 1, "{errors} errors, {settled} settled");
}

/// Weightless without K_C: at the corrected targets q′, FK(q′) + J(q′) θ with θ_k = c_k τ_k
/// and the shoulder's ½ b sign(τ₂) written by cases, τ = J(q′)ᵀ W, is the nominal tip.
#[test]
fn weightless_compensation_takes_up_the_lost_motion_by_cases() {
    let (chain, sm, data) = panda_model();
    let curved = sm
        .clone()
        .with_gear_curves(&[GearCurve::with_lost_motion(1, vec![], vec![], B).unwrap()])
        .unwrap();
    let model = VirtualJointModel::traditional(7);
    let c = sm.determined_compliance().unwrap();
    let mut opts = CompensateOptions::default();
    (opts.with_kc, opts.check_limits) = (false, false);
    let rows = data.len().min(40);
    let q = &data.q_flat()[..7 * rows];
    let w = &data.wrench_flat()[..6 * rows];
    let out = curved
        .compensate(&chain, q, Load::Wrench(w), &opts)
        .unwrap();
    let (mut positive, mut negative) = (0, 0);
    for i in 0..rows {
        assert_eq!(out.rows[i].status, CompensationStatus::Converged, "row {i}");
        let qc = &out.q[7 * i..7 * i + 7];
        let wr = data.wrench(i);
        let j = vjm::jacobian(&chain, &model, qc).unwrap();
        let mut tip = chain.forward_kinematics(qc).unwrap().translation.vector;
        for k in 0..7 {
            let tau: f64 = (0..6).map(|r| j[(r, k)] * wr[r]).sum();
            let mut theta = c[k] * tau;
            if k == 1 {
                if tau > 0.0 {
                    theta += 0.5 * B;
                    positive += 1;
                } else if tau < 0.0 {
                    theta -= 0.5 * B;
                    negative += 1;
                }
            }
            for r in 0..3 {
                tip[r] += j[(r, k)] * theta;
            }
        }
        let target = chain.forward_kinematics(&q[7 * i..7 * i + 7]).unwrap();
        let miss = (tip - target.translation.vector).norm();
        assert!(miss <= 2e-9, "row {i}: misses by {miss} m");
    }
    assert!(positive >= 5 && negative >= 5, "{positive} +, {negative} −");
}
