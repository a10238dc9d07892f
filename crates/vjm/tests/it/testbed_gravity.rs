//! The virtual testbed under gravity: weightless campaigns unchanged, the springs' response at
//! the total torque against the crate's exact equilibrium under the weight
//! ([`deflection_under_gravity`]) and against a gear curve evaluated by hand.

use nalgebra::{DMatrix, DVector};
use vjm::gravity::{deflection_under_gravity, gravity_stiffness, gravity_torques, Gravity};
use vjm::testbed::{
    simulate, simulate_at, Campaign, CampaignSpec, Effect, HarmonicDriveSpring, TestbedError,
    TrueModel,
};
use vjm::{jacobian_deflected, SerialChain, VirtualJointModel};

/// Small loads (the geometric non-linearity of the load itself stays far below gravity's effect),
/// no noise.
fn spec(gravity: Option<Gravity>) -> CampaignSpec {
    CampaignSpec {
        n_poses: 12,
        wrenches_per_pose: 3,
        force_range: (5.0, 10.0),
        moment_max: 0.5,
        noise: false,
        seed: 31,
        gravity,
        ..Default::default()
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn gap(a: &[f64; 3], b: &[f64]) -> f64 {
    norm(&[a[0] - b[0], a[1] - b[1], a[2] - b[2]])
}

#[test]
fn a_weightless_campaign_is_the_weightless_truth_row_by_row() {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::Backlash {
        joint: 0,
        lost_motion: 1e-4,
    });
    let c = simulate(&chain, &truth, &spec(None)).unwrap();
    for i in 0..c.dataset.len() {
        let (d, tip) = truth.displacement(&chain, c.dataset.q(i), &c.applied_wrench[i]);
        assert_eq!(c.true_displacement[i], [d.x, d.y, d.z]);
        assert_eq!(c.tip[i], [tip.x, tip.y, tip.z]);
    }
    // The spec serialises as before: no gravity key for a weightless campaign ...
    let v = serde_json::to_value(spec(None)).unwrap();
    assert!(v.get("gravity").is_none(), "{v}");
    // ... and the vector used when there is one.
    let g = Gravity::new([0.0, -9.8, 0.0]).unwrap();
    let v = serde_json::to_value(spec(Some(g))).unwrap();
    assert_eq!(v["gravity"], serde_json::json!([0.0, -9.8, 0.0]));
    // Zero gravity takes the gravity path and gives the weightless data, backlash at joint 1
    // (no gravity torque: the reference stays in the middle of the band) included.
    let zero = simulate(&chain, &truth, &spec(Some(Gravity::new([0.0; 3]).unwrap()))).unwrap();
    assert_eq!(zero.dataset.q_flat(), c.dataset.q_flat());
    for i in 0..c.dataset.len() {
        let d = zero.true_displacement[i];
        assert!(
            gap(&d, &c.true_displacement[i]) <= 1e-15 * norm(&d),
            "row {i}"
        );
    }
}

/// Largest relative gap of the campaign's rows to the exact equilibrium under the weight.
fn gaps_to_exact(chain: &SerialChain, truth: &TrueModel, c: &Campaign, g: &Gravity) -> Vec<f64> {
    let model = VirtualJointModel::extended(7);
    (0..c.dataset.len())
        .map(|i| {
            let exact = deflection_under_gravity(
                chain,
                &model,
                &truth.compliance,
                c.dataset.q(i),
                &c.applied_wrench[i],
                g,
                None,
            )
            .unwrap();
            gap(&c.true_displacement[i], &exact[..3]) / norm(&exact[..3])
        })
        .collect()
}

#[test]
fn springs_under_gravity_agree_with_the_exact_equilibrium() {
    let chain = SerialChain::bundled();
    let g = Gravity::default();
    let max = |v: Vec<f64>| v.into_iter().fold(0.0, f64::max);
    let min = |v: Vec<f64>| v.into_iter().fold(f64::INFINITY, f64::min);
    // With the geometric effect (deflected Jacobian, exact tips) the testbed is the exact
    // equilibrium up to gravity's linearisation τ_g + K_G θ: measured ≤ 3.5e-5 relative over
    // these 36 rows ...
    let geometric = TrueModel::nominal(7).with_effect(Effect::GeometricNonlinearity);
    let geo = simulate(&chain, &geometric, &spec(Some(g))).unwrap();
    let geo_gap = max(gaps_to_exact(&chain, &geometric, &geo, &g));
    assert!(geo_gap < 5e-5, "{geo_gap}");
    // ... while the weightless campaign (same poses and loads) is ≥ 1.28e-3 away on every row:
    // the comparison tells gravity from no gravity.
    let weightless = simulate(&chain, &geometric, &spec(None)).unwrap();
    assert_eq!(geo.dataset.q_flat(), weightless.dataset.q_flat());
    assert_eq!(geo.applied_wrench, weightless.applied_wrench);
    let weightless_gap = min(gaps_to_exact(&chain, &geometric, &weightless, &g));
    assert!(
        weightless_gap > 10.0 * geo_gap,
        "{weightless_gap} vs {geo_gap}"
    );
    // The unloaded tip is the sagged one, not the rigid forward kinematics.
    let sag = gap(&geo.tip[0], &weightless.tip[0]);
    assert!(sag > 1e-4, "{sag}");

    // The linear springs alone are the first-order model under gravity about the sagged pose,
    // d = J_t(θ₀) (I − C K_G)⁻¹ C J(θ₀)ᵀ W with θ₀ = (I − C K_G)⁻¹ C τ_g (written out here with
    // the crate's slow deflected Jacobian and K_G) ...
    let linear = TrueModel::nominal(7);
    let lin = simulate(&chain, &linear, &spec(Some(g))).unwrap();
    let model = VirtualJointModel::extended(7);
    let c = DMatrix::from_diagonal(&DVector::from_column_slice(&linear.compliance));
    for i in 0..lin.dataset.len() {
        let q = lin.dataset.q(i);
        let kg = gravity_stiffness(&chain, &model, q, &g, None).unwrap();
        let tau_g = gravity_torques(&chain, &model, q, &g, None).unwrap();
        let a = DMatrix::identity(21, 21) - &c * kg;
        let theta0 = a
            .clone()
            .lu()
            .solve(&(&c * DVector::from_vec(tau_g)))
            .unwrap();
        let j = jacobian_deflected(&chain, &model, q, theta0.as_slice()).unwrap();
        let rhs = &c * j.transpose() * DVector::from_column_slice(&lin.applied_wrench[i]);
        let expected = j.rows(0, 3) * a.lu().solve(&rhs).unwrap();
        let err = gap(&lin.true_displacement[i], expected.as_slice());
        assert!(err < 1e-12 * expected.norm(), "row {i}: {err}");
    }
    // ... which leaves out the load's own geometric non-linearity (and gravity's second order):
    // measured ≤ 7.6e-4 from the exact equilibrium over these rows (about the undeflected pose
    // instead it was 1.08e-2, as far off as the weightless campaign).
    let linear_gap = max(gaps_to_exact(&chain, &linear, &lin, &g));
    assert!(linear_gap < 1e-3, "{linear_gap}");
}

#[test]
fn a_gear_preloaded_by_gravity_responds_on_its_curve_at_the_total_torque() {
    // Joint 2 (the shoulder) carries the arm: its gear sits on its stiff segment under the
    // weight alone, and a load moves it along that segment, not along the soft one at zero.
    let chain = SerialChain::bundled();
    let g = Gravity::default();
    let model = VirtualJointModel::extended(7);
    let q = [0.2, 0.6, -0.3, -1.4, 0.4, 1.7, 0.3];
    let w = [6.0, -4.0, 8.0, 0.3, -0.2, 0.4];
    let s = 3; // J2z
    let gear = HarmonicDriveSpring::stiffening(2e-4, 2.4, 15.0, 60.0);
    let truth = TrueModel::nominal(7).with_effect(Effect::TorsionNonlinear {
        joint: 1,
        spring: gear,
    });
    let c = simulate_at(&chain, &truth, &q, &[w], &[0], &spec(Some(g))).unwrap();
    let d = c.true_displacement[0];

    // By hand: the linear springs L deflect by θ_L = C_L (τ_g + K_G θ + τ_w)_L given the gear's
    // θ_s (a linear solve), and θ_s = f((τ_g + K_G θ + τ_w)_s) is one equation in θ_s, solved
    // by bisection: no fixed point shared with the testbed.
    let tau_g = gravity_torques(&chain, &model, &q, &g, None).unwrap();
    let kg = gravity_stiffness(&chain, &model, &q, &g, None).unwrap();
    assert!(
        tau_g[s].abs() > 20.0,
        "gravity should preload the shoulder beyond the first segment: {}",
        tau_g[s]
    );
    let c_lin: Vec<f64> = (0..21)
        .map(|k| if k == s { 0.0 } else { truth.compliance[k] })
        .collect();
    let solve = |load: &DVector<f64>| -> DVector<f64> {
        let theta_given = |ts: f64| {
            // (I − C_L K_G) θ = C_L (τ_g + load + K_G[:, s] θ_s) with θ_s fixed.
            let mut a = nalgebra::DMatrix::identity(21, 21);
            let mut b = DVector::zeros(21);
            for k in 0..21 {
                if k == s {
                    b[k] = ts;
                    continue;
                }
                for i in 0..21 {
                    if i != s {
                        a[(k, i)] -= c_lin[k] * kg[(k, i)];
                    }
                }
                b[k] = c_lin[k] * (tau_g[k] + load[k] + kg[(k, s)] * ts);
            }
            a.lu().solve(&b).unwrap()
        };
        let residual = |ts: f64| {
            let th = theta_given(ts);
            let tau = tau_g[s] + load[s] + (0..21).map(|i| kg[(s, i)] * th[i]).sum::<f64>();
            gear.deflection(tau) - ts
        };
        let (mut lo, mut hi) = (-0.1, 0.1);
        assert!(residual(lo) > 0.0 && residual(hi) < 0.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if residual(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        theta_given(0.5 * (lo + hi))
    };
    let rest = solve(&DVector::zeros(21));
    // The load acts through the Jacobian of the sagged pose, where the reference was taken.
    let j = jacobian_deflected(&chain, &model, &q, rest.as_slice()).unwrap();
    let tau_w = j.transpose() * DVector::from_column_slice(&w);
    let loaded = solve(&tau_w);
    let expected = j.rows(0, 3) * (&loaded - &rest);
    let err = gap(&d, expected.as_slice());
    assert!(err < 1e-9 * expected.norm(), "{err} vs {}", expected.norm());

    // The gear's part is J_t[:, s]·(f(τ_g,s + τ_s) − f(τ_g,s)) at the springs' total torques,
    // on its stiff segment: the weightless simulation (soft segment at zero torque) differs by
    // far more than the agreement above.
    let weightless = simulate_at(&chain, &truth, &q, &[w], &[0], &spec(None)).unwrap();
    let diff = gap(&d, &weightless.true_displacement[0]);
    assert!(diff > 1e-3 * expected.norm(), "{diff}");
}

#[test]
fn a_chain_without_masses_is_refused_naming_the_link() {
    let xml = r#"<robot name="r"><link name="base"/>
      <link name="l1"><inertial><mass value="2"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="l2"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0.3"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
    </robot>"#;
    let chain = SerialChain::from_urdf_str(xml, "base", "l2").unwrap();
    let truth = TrueModel::nominal(2);
    let w = [[10.0, 0.0, 5.0, 1.0, 2.0, 3.0]];
    let q = [0.1, 0.4];
    let err = simulate_at(
        &chain,
        &truth,
        &q,
        &w,
        &[0],
        &spec(Some(Gravity::default())),
    )
    .unwrap_err();
    assert!(
        matches!(&err, TestbedError::Gravity { message } if message.contains("l2")),
        "{err}"
    );
    // Weightless, the same chain simulates.
    simulate_at(&chain, &truth, &q, &w, &[0], &spec(None)).unwrap();
}

#[test]
fn springs_too_soft_to_hold_the_arm_are_an_error_not_a_value() {
    let chain = SerialChain::bundled();
    // 1000× the nominal compliance at the shoulder: ‖C K_G‖ ≈ 10, the arm falls over.
    let mut truth = TrueModel::nominal(7);
    truth.compliance[3] *= 1e3;
    let err = simulate(&chain, &truth, &spec(Some(Gravity::default()))).unwrap_err();
    assert!(
        matches!(&err, TestbedError::Gravity { message }
            if message.contains("did not settle") && message.contains("(pose ")),
        "{err}"
    );
}

#[test]
fn a_backlash_gravity_does_not_load_keeps_the_weightless_reference() {
    // Joint 1 of the floor-mounted arm turns about the vertical: gravity applies no torque
    // there (up to rounding), so its gear's unloaded reference stays in the middle of the band
    // and a load moves it by ½·b·sign(τ), as without gravity.
    let chain = SerialChain::bundled();
    let g = Gravity::default();
    let model = VirtualJointModel::extended(7);
    let b = 2e-4;
    let plain = TrueModel::nominal(7);
    let geared = plain.clone().with_effect(Effect::Backlash {
        joint: 0,
        lost_motion: b,
    });
    for (k, q) in [
        [0.2, 0.6, -0.3, -1.4, 0.4, 1.7, 0.3],
        [-1.1, -0.4, 0.9, -2.0, -0.7, 2.2, -0.5],
        [2.0, 1.1, 1.5, -0.8, 1.9, 0.9, 1.2],
    ]
    .iter()
    .enumerate()
    {
        // K_G's row of that spring is rounding noise (~1e-15 N·m/rad, not 0): the testbed
        // must not let it pick a side of the band.
        let rest = geared.rest_under_gravity(&chain, q, &g).unwrap();
        assert_eq!(rest.gravity_torques()[0], 0.0, "pose {k}");
        assert_eq!(rest.theta()[0], 0.0, "pose {k}");
        let plain_rest = plain.rest_under_gravity(&chain, q, &g).unwrap();
        let w = [5.0, -8.0, 3.0, 0.2, 0.1, -0.4];
        let (d, _) = geared
            .displacement_under_gravity(&chain, q, &w, &rest)
            .unwrap();
        let (d0, _) = plain
            .displacement_under_gravity(&chain, q, &w, &plain_rest)
            .unwrap();
        let j = jacobian_deflected(&chain, &model, q, rest.theta()).unwrap();
        let tau = (j.transpose() * DVector::from_column_slice(&w))[0];
        let lost = 0.5 * b * tau.signum();
        for r in 0..3 {
            let expected = d0[r] + j[(r, 0)] * lost;
            assert!(
                (d[r] - expected).abs() < 1e-12 * d.norm(),
                "pose {k} axis {r}: {} vs {expected}",
                d[r]
            );
        }
    }
}
