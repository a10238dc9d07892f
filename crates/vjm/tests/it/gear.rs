//! Non-linear gears (`vjm::gear`): the curve against an independent evaluation, and the static
//! equilibrium with a curved spring against the equilibrium's defining equation.

use vjm::gear::{hinge, GearCurve};
use vjm::gravity::{
    gravity_sag, gravity_sag_with_gears, static_equilibrium, static_equilibrium_with_gears,
    Gravity, Loading,
};
use vjm::Measurements;
use vjm::{SerialChain, VirtualJointModel};

/// θ(T) = c·T + Σ a_k h_k(T), written out by cases, against `GearCurve::deflection`; its slope
/// by central differences is the tangent compliance c + Σ_{|T| > t_k} a_k.
#[test]
fn a_gear_curve_is_its_piecewise_linear_definition() {
    let (c, knots, a) = (1.0 / 12e3, [5.0, 15.0], [1.2e-4, -0.4e-4]);
    let curve = GearCurve::new(1, knots.to_vec(), a.to_vec()).unwrap();
    for i in -400..=400 {
        let t = 0.1 * i as f64 + 0.013;
        let mut by_cases = c * t;
        for k in 0..2 {
            if t > knots[k] {
                by_cases += a[k] * (t - knots[k]);
            } else if t < -knots[k] {
                by_cases += a[k] * (t + knots[k]);
            }
        }
        let got = curve.deflection(c, t);
        assert!(
            (got - by_cases).abs() <= 1e-15 * by_cases.abs().max(1e-3),
            "T = {t}"
        );
        let h = 1e-6;
        let slope = (curve.deflection(c, t + h) - curve.deflection(c, t - h)) / (2.0 * h);
        let tangent = c
            + (0..2)
                .filter(|&k| t.abs() > knots[k])
                .map(|k| a[k])
                .sum::<f64>();
        assert!(
            (slope - tangent).abs() <= 1e-6 * tangent.abs(),
            "slope at T = {t}"
        );
    }
    assert_eq!(hinge(-20.0, 15.0), -5.0);
    assert!(GearCurve::new(1, vec![-1.0], vec![0.0]).is_err());
    assert!(GearCurve::new(1, vec![1.0], vec![f64::NAN]).is_err());
    assert!(GearCurve::new(1, vec![1.0, 2.0], vec![0.0]).is_err());
}

/// The equilibrium with a curved shoulder under the Panda's weight: the curved spring's θ is
/// its curve at the torque it carries there (checked through a linear equilibrium with the
/// curve's secant compliance), the others linear; with no curve it is `static_equilibrium` bit
/// for bit, and the sag changes by the curve's excess.
#[test]
fn the_equilibrium_bends_a_curved_spring_by_its_curve() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = [2e-4, 1.0 / 5e3, 2e-4, 1.0 / 5e3, 2e-4, 2e-4, 2e-4];
    let q = [0.2, 0.6, -0.1, -1.2, 0.1, 1.6, 0.3];
    let g = Gravity::default();
    let loading = Loading {
        gravity: Some(g),
        payload: None,
        wrench: Some([10.0, -5.0, -20.0, 0.5, 0.0, 0.2]),
    };
    let plain = static_equilibrium(&panda, &model, &c, &q, &loading).unwrap();
    let none = static_equilibrium_with_gears(&panda, &model, &c, &[], &q, &loading).unwrap();
    assert_eq!(plain.theta, none.theta);
    assert_eq!(plain.tip, none.tip);
    // Hardening: 5 → 12 kN·m/rad beyond 15 N·m.
    let curve = GearCurve::new(1, vec![15.0], vec![1.0 / 12e3 - 1.0 / 5e3]).unwrap();
    let eq = static_equilibrium_with_gears(
        &panda,
        &model,
        &c,
        std::slice::from_ref(&curve),
        &q,
        &loading,
    )
    .unwrap();
    // Independent check of θ₂ = θ(τ₂): a linear equilibrium whose shoulder has the secant
    // compliance θ(τ₂)/τ₂ of the curve at the torque it carries is the same state (the
    // torques depend on the deflections, not on the springs); the secant is found by its own
    // fixed point on `static_equilibrium`, which knows nothing of curves.
    let secant: f64 = {
        let mut s = c[1];
        for _ in 0..50 {
            let mut cs = c;
            cs[1] = s;
            let lin = static_equilibrium(&panda, &model, &cs, &q, &loading).unwrap();
            let tau = lin.theta[1] / s;
            s = curve.deflection(c[1], tau) / tau;
        }
        s
    };
    let mut cs = c;
    cs[1] = secant;
    let lin = static_equilibrium(&panda, &model, &cs, &q, &loading).unwrap();
    for k in 0..7 {
        assert!(
            (lin.theta[k] - eq.theta[k]).abs() <= 1e-10 * eq.theta[k].abs().max(1e-6),
            "spring {k}: {} vs {}",
            lin.theta[k],
            eq.theta[k]
        );
    }
    let tau2 = eq.theta[1] / secant;
    assert!(
        tau2.abs() > 15.0,
        "the shoulder carries {tau2} N·m, beyond the knee"
    );
    let s0 = gravity_sag(&panda, &model, &c, &q, &g, None).unwrap();
    let s1 = gravity_sag_with_gears(&panda, &model, &c, &[curve], &q, &g, None).unwrap();
    let moved: f64 = (0..3).map(|k| (s1[k] - s0[k]).powi(2)).sum::<f64>().sqrt();
    assert!(moved > 1e-5, "the stiffer gear sags less: {moved} m");
}

/// The model file records the curves and reads them back; a model without curves writes what
/// it wrote before (same text, same hash); a curve at a joint without a torsion spring is an
/// error naming the joint; the sag evaluates the curve, and a curve of zero coefficients sags
/// as no curve, bit for bit.
#[test]
fn the_model_file_records_gear_curves() {
    use vjm::testbed::{simulate, CampaignSpec, TrueModel};
    use vjm::{identify, DataSource, IdentifyOptions, StiffnessModel};
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 10,
        noise: false,
        ..Default::default()
    };
    let data = simulate(&chain, &TrueModel::nominal(7), &spec)
        .unwrap()
        .dataset;
    let (model, opts) = (
        VirtualJointModel::traditional(7),
        IdentifyOptions::default(),
    );
    let (q, w, d) = (data.q_flat(), data.wrench_flat(), data.displacement_flat());
    let id = identify(&chain, &model, Measurements::new(q, w, d), &opts).unwrap();
    let sm = StiffnessModel::from_identification(
        &id,
        &chain,
        &model,
        &opts,
        DataSource::in_memory(data.len()),
    )
    .unwrap();
    let plain = sm.to_json();
    assert!(!plain.contains("gear_curves"));
    assert_eq!(sm.clone().with_gear_curves(&[]).unwrap().to_json(), plain);
    let curve = GearCurve::new(1, vec![5.0, 15.0], vec![1e-4, -2e-5]).unwrap();
    let curved = sm
        .clone()
        .with_gear_curves(std::slice::from_ref(&curve))
        .unwrap();
    let text = curved.to_json();
    assert!(text.contains("\"gear_curves\"") && text.contains("N·m"));
    let back = StiffnessModel::from_json(&text, "m.json").unwrap();
    assert_eq!(back.gear_curves().unwrap(), vec![curve.clone()]);
    assert_ne!(back.content_sha256(), sm.content_sha256());
    let tilt_only =
        VirtualJointModel::from_springs(7, vec![vjm::Spring::rotation(0, vjm::SpringAxis::Z)])
            .unwrap();
    let e = vjm::gear::torsion_springs(&tilt_only, std::slice::from_ref(&curve)).unwrap_err();
    assert!(e.to_string().contains("joint 2"), "{e}");
    // The sag: zero coefficients are no curve, bit for bit; the curve moves it.
    let g = Gravity::default();
    let q0 = data.q(0);
    let zero = GearCurve::new(1, vec![5.0, 15.0], vec![0.0, 0.0]).unwrap();
    let base = sm.predict_sag(&chain, q0, &g, None).unwrap();
    let z = sm
        .clone()
        .with_gear_curves(&[zero])
        .unwrap()
        .predict_sag(&chain, q0, &g, None)
        .unwrap();
    let bits = |d: [f64; 6]| d.map(f64::to_bits);
    assert_eq!(bits(base[0].deflection), bits(z[0].deflection));
    let bent = curved.predict_sag(&chain, q0, &g, None).unwrap();
    assert_ne!(base[0].deflection, bent[0].deflection);
}
