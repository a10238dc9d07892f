//! Gravity: the bodies read from URDF inertials, the torques of gravity on the virtual
//! springs and their stiffness K_G, each against an independent computation (finite
//! differences of the potential on the deflected chain, hand sums of masses and moments).

use nalgebra::{DMatrix, Vector3};
use proptest::prelude::*;
use vjm::gravity::{
    gravity_potential_deflected, gravity_stiffness, gravity_torques, Body, Gravity, MassModel,
};
use vjm::stiffness_model::PointMass;
use vjm::Measurements;
use vjm::{SerialChain, VirtualJointModel, VjmError};

use crate::strategies::{arb_chain_and_q, config};

/// Random bodies: 0.2–5 kg, centres within 0.3 m of their joint.
fn arb_bodies(n: usize) -> impl Strategy<Value = MassModel> {
    prop::collection::vec((0.2f64..5.0, prop::array::uniform3(-0.3f64..0.3)), n).prop_map(|bs| {
        MassModel::new(
            bs.into_iter()
                .map(|(mass, c)| Body {
                    mass,
                    com: Vector3::from(c),
                })
                .collect(),
        )
        .expect("valid bodies")
    })
}

fn arb_gravity() -> impl Strategy<Value = Gravity> {
    prop_oneof![
        Just(Gravity::default()),
        prop::array::uniform3(-10.0f64..10.0).prop_map(|g| Gravity::new(g).expect("finite")),
    ]
}

/// A chain with masses, a configuration, gravity, and an optional payload.
fn arb_case() -> impl Strategy<Value = (SerialChain, Vec<f64>, Gravity, Option<PointMass>)> {
    arb_chain_and_q(1..=5).prop_flat_map(|(chain, q)| {
        let n = chain.n_joints();
        (
            Just(chain),
            Just(q),
            arb_bodies(n),
            arb_gravity(),
            prop::option::of((0.1f64..3.0, prop::array::uniform3(-0.2f64..0.2))),
        )
            .prop_map(|(chain, q, masses, g, p)| {
                let payload = p.map(|(m, c)| PointMass::new(m, c).expect("valid payload"));
                (
                    chain.with_masses(masses).expect("one body per joint"),
                    q,
                    g,
                    payload,
                )
            })
    })
}

fn potential(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    theta: &[f64],
    g: &Gravity,
    p: Option<&PointMass>,
) -> f64 {
    gravity_potential_deflected(chain, model, q, theta, g, p).expect("valid inputs")
}

/// Central differences of U along each spring (h = 1e-5 rad), negated: τ = −∂U/∂θ.
fn torques_fd(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    g: &Gravity,
    p: Option<&PointMass>,
) -> Vec<f64> {
    let m = model.n_params();
    let h = 1e-5;
    (0..m)
        .map(|k| {
            let mut t = vec![0.0; m];
            t[k] = h;
            let up = potential(chain, model, q, &t, g, p);
            t[k] = -h;
            let down = potential(chain, model, q, &t, g, p);
            -(up - down) / (2.0 * h)
        })
        .collect()
}

/// K_G = −∂²U/∂θ² by central second differences (h = 1e-4 rad).
fn stiffness_fd(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    g: &Gravity,
    p: Option<&PointMass>,
) -> DMatrix<f64> {
    let m = model.n_params();
    let h = 1e-4;
    let mut out = DMatrix::zeros(m, m);
    for i in 0..m {
        for k in 0..m {
            let mut sum = 0.0;
            for (si, sk, sign) in [(h, h, 1.0), (h, -h, -1.0), (-h, h, -1.0), (-h, -h, 1.0)] {
                let mut t = vec![0.0; m];
                t[i] += si;
                t[k] += sk;
                sum += sign * potential(chain, model, q, &t, g, p);
            }
            out[(i, k)] = -sum / (4.0 * h * h);
        }
    }
    out
}

/// The scale of the weights' moments: Σ m |g| (|x| + 1 m), an upper bound of every torque.
fn moment_scale(chain: &SerialChain, g: &Gravity, p: Option<&PointMass>) -> f64 {
    let masses = chain.mass_model().expect("masses set");
    let m: f64 = masses.total_mass() + p.map_or(0.0, |p| p.mass());
    m * g.vector().norm() * (chain.n_joints() as f64 + 1.0)
}

proptest! {
    #![proptest_config(config(48))]

    /// τ_g is minus the gradient of the potential evaluated on the deflected chain.
    #[test]
    fn torques_are_minus_the_gradient_of_the_potential((chain, q, g, p) in arb_case(), which in 0..3usize) {
        let n = chain.n_joints();
        let model = match which {
            0 => VirtualJointModel::traditional(n),
            1 => VirtualJointModel::extended(n),
            _ => VirtualJointModel::full(n),
        };
        let tau = gravity_torques(&chain, &model, &q, &g, p.as_ref()).unwrap();
        let fd = torques_fd(&chain, &model, &q, &g, p.as_ref());
        let scale = moment_scale(&chain, &g, p.as_ref());
        for k in 0..model.n_params() {
            prop_assert!((tau[k] - fd[k]).abs() <= 1e-7 * scale, "spring {k}: {} vs {}", tau[k], fd[k]);
        }
    }

    /// K_G is the Hessian of −U on the deflected chain, and symmetric.
    #[test]
    fn stiffness_is_minus_the_hessian_of_the_potential((chain, q, g, p) in arb_case(), full in any::<bool>()) {
        let n = chain.n_joints();
        // `full`: translations too (N and N/m entries; the differences step 1e-4 m).
        let model = if full { VirtualJointModel::full(n) } else { VirtualJointModel::extended(n) };
        let kg = gravity_stiffness(&chain, &model, &q, &g, p.as_ref()).unwrap();
        let fd = stiffness_fd(&chain, &model, &q, &g, p.as_ref());
        let scale = moment_scale(&chain, &g, p.as_ref());
        for i in 0..model.n_params() {
            for k in 0..model.n_params() {
                prop_assert!((kg[(i, k)] - fd[(i, k)]).abs() <= 1e-5 * scale,
                    "K_G[{i},{k}] = {} vs differences {}", kg[(i, k)], fd[(i, k)]);
                prop_assert_eq!(kg[(i, k)], kg[(k, i)]);
            }
        }
    }
}

/// A pendulum by hand: one link of mass m with its centre at distance r from a joint with a
/// horizontal axis, at angle q from the horizontal: τ = m g r cos q and K_G = −m g r sin q
/// … with the signs of the chosen frames.
#[test]
fn a_pendulum_by_hand() {
    use nalgebra::Isometry3;
    let (m, r) = (3.0, 0.4);
    let chain = SerialChain::from_joints(
        "base",
        "tip",
        vec![(
            "j1".into(),
            Isometry3::identity(),
            Vector3::y(),
            (-3.0, 3.0),
        )],
        Isometry3::identity(),
    )
    .unwrap()
    .with_masses(
        MassModel::new(vec![Body {
            mass: m,
            com: Vector3::new(r, 0.0, 0.0),
        }])
        .unwrap(),
    )
    .unwrap();
    let model = VirtualJointModel::traditional(1);
    let g = 9.80665;
    for q in [-1.0, -0.3, 0.0, 0.5, 1.2] {
        // A rotation q about +y takes x̂ to (cos q, 0, −sin q); the weight (0, 0, −m g) at
        // r(cos q, 0, −sin q) has the moment r(cos q, 0, −sin q) × (0, 0, −m g) = m g r cos q ŷ.
        let tau = gravity_torques(&chain, &model, &[q], &Gravity::default(), None).unwrap();
        assert!((tau[0] - m * g * r * f64::cos(q)).abs() < 1e-12, "q = {q}");
        // dτ/dq = −m g r sin q.
        let kg = gravity_stiffness(&chain, &model, &[q], &Gravity::default(), None).unwrap();
        assert!(
            (kg[(0, 0)] + m * g * r * f64::sin(q)).abs() < 1e-12,
            "q = {q}"
        );
    }
    // Upside down (ceiling-mounted): the torque flips.
    let up = Gravity::new([0.0, 0.0, g]).unwrap();
    let tau = gravity_torques(&chain, &model, &[0.0], &up, None).unwrap();
    assert!((tau[0] + m * g * r).abs() < 1e-12);
}

/// A URDF with a fixed child on the chain, a branch off it (a camera), a prismatic finger off
/// the chain (frozen at 0), a massless flange frame and a hand beyond the tip.
const BRANCHED: &str = r#"<robot name="branched">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0 0 0.1"/><mass value="2"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l1b"><inertial><origin xyz="0.1 0 0"/><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="camera"><inertial><mass value="0.5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="1.5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="flange"/>
  <link name="hand"><inertial><origin xyz="0 0 0.05"/><mass value="0.7"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>
  <link name="finger"><inertial><mass value="0.1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="f1" type="fixed"><parent link="l1"/><child link="l1b"/><origin xyz="0 0 0.3"/></joint>
  <joint name="cam" type="fixed"><parent link="l1"/><child link="camera"/><origin xyz="0 0.2 0"/></joint>
  <joint name="j2" type="revolute"><parent link="l1b"/><child link="l2"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="fl" type="fixed"><parent link="l2"/><child link="flange"/><origin xyz="0.4 0 0"/></joint>
  <joint name="h" type="fixed"><parent link="flange"/><child link="hand"/><origin xyz="0 0 0.02" rpy="0 1.5707963267948966 0"/></joint>
  <joint name="fi" type="prismatic"><parent link="hand"/><child link="finger"/><origin xyz="0 0.03 0.1"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
</robot>"#;

#[test]
fn bodies_collect_fixed_children_branches_and_what_lies_beyond_the_tip() {
    let chain = SerialChain::from_urdf_str(BRANCHED, "base", "flange").unwrap();
    let bodies = chain.mass_model().unwrap().bodies().to_vec();
    assert_eq!(bodies.len(), 2);
    // Joint 1 carries l1 (2 kg at (0,0,0.1)), l1b (1 kg at (0.1,0,0.3)), camera (0.5 kg at (0,0.2,0)).
    let m1 = 3.5;
    let c1 = (Vector3::new(0.0, 0.0, 0.1) * 2.0
        + Vector3::new(0.1, 0.0, 0.3) * 1.0
        + Vector3::new(0.0, 0.2, 0.0) * 0.5)
        / m1;
    assert!((bodies[0].mass - m1).abs() < 1e-12);
    assert!(
        (bodies[0].com - c1).norm() < 1e-12,
        "{:?} vs {c1:?}",
        bodies[0].com
    );
    // Joint 2 carries l2 (1.5 kg at (0.2,0,0)), the hand beyond the tip: its frame is at
    // (0.4,0,0.02) rotated +90° about y, so its centre (0,0,0.05) lands at (0.45,0,0.02); and
    // the finger at the hand's (0,0.03,0.1) -> (0.5,0.03,0.02).
    let m2 = 1.5 + 0.7 + 0.1;
    let c2 = (Vector3::new(0.2, 0.0, 0.0) * 1.5
        + Vector3::new(0.45, 0.0, 0.02) * 0.7
        + Vector3::new(0.5, 0.03, 0.02) * 0.1)
        / m2;
    assert!((bodies[1].mass - m2).abs() < 1e-12);
    assert!(
        (bodies[1].com - c2).norm() < 1e-12,
        "{:?} vs {c2:?}",
        bodies[1].com
    );
}

#[test]
fn a_link_with_a_shape_and_no_inertial_is_named() {
    let xml = BRANCHED.replace(
        r#"<link name="camera"><inertial><mass value="0.5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        r#"<link name="camera"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>"#,
    );
    assert_ne!(xml, BRANCHED);
    let chain = SerialChain::from_urdf_str(&xml, "base", "flange").unwrap();
    let err = chain.mass_model().unwrap_err();
    assert!(
        matches!(&err, VjmError::InvalidInertial { link, .. } if link == "camera"),
        "{err}"
    );
    assert!(err.to_string().contains("no <inertial>"), "{err}");
    // An explicit zero mass is a massless link, not a missing one (UR's `ee_link`) ...
    let zero = BRANCHED.replace(
        r#"<link name="camera"><inertial><mass value="0.5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        r#"<link name="camera"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual><inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
    );
    assert_ne!(zero, BRANCHED);
    let bodies = SerialChain::from_urdf_str(&zero, "base", "flange")
        .unwrap()
        .mass_model()
        .unwrap()
        .bodies()
        .to_vec();
    assert!((bodies[0].mass - 3.0).abs() < 1e-12);
    // ... and an <inertial> inside a comment is no inertial.
    let commented = xml.replace(
        r#"<visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>"#,
        r#"<visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual><!-- <inertial><mass value="1"/></inertial> --></link>"#,
    );
    assert_ne!(commented, xml);
    let err = SerialChain::from_urdf_str(&commented, "base", "flange")
        .unwrap()
        .mass_model()
        .unwrap_err();
    assert!(
        matches!(&err, VjmError::InvalidInertial { link, .. } if link == "camera"),
        "{err}"
    );
    // A URDF without any inertial weighs nothing: refused, not zero sag.
    let bare = r#"<robot name="bare"><link name="base"/><link name="l1"/><link name="l2"/>
      <joint name="j1" type="continuous"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint>
      <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/></joint>
    </robot>"#;
    let err = SerialChain::from_urdf_str(bare, "base", "l2")
        .unwrap()
        .mass_model()
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("no link the chain carries has a mass"),
        "{err}"
    );
    // The bundled Panda carries franka_description's masses: seven links, the hand and two
    // fingers.
    let total = SerialChain::bundled().mass_model().unwrap().total_mass();
    let expected = 4.970684
        + 0.646926
        + 3.228604
        + 3.587895
        + 1.225946
        + 1.666555
        + 0.735522
        + 0.73
        + 2.0 * 0.015;
    assert!((total - expected).abs() < 1e-12, "{total} vs {expected}");
    // The kinematics do not need masses.
    assert!(chain.forward_kinematics(&[0.1, 0.2]).is_ok());
    // A negative mass is refused, naming the link.
    let xml = BRANCHED.replace(r#"<mass value="1.5"/>"#, r#"<mass value="-1.5"/>"#);
    let err = SerialChain::from_urdf_str(&xml, "base", "flange")
        .unwrap()
        .mass_model()
        .unwrap_err();
    assert!(
        matches!(&err, VjmError::InvalidInertial { link, .. } if link == "l2"),
        "{err}"
    );
}

#[test]
fn a_chain_without_a_urdf_has_no_masses_until_given() {
    use nalgebra::Isometry3;
    let chain = SerialChain::from_joints(
        "b",
        "t",
        vec![("j".into(), Isometry3::identity(), Vector3::z(), (-1.0, 1.0))],
        Isometry3::identity(),
    )
    .unwrap();
    assert!(chain.mass_model().is_err());
    let two = MassModel::new(vec![
        Body {
            mass: 1.0,
            com: Vector3::zeros(),
        };
        2
    ])
    .unwrap();
    assert!(matches!(
        chain.clone().with_masses(two),
        Err(VjmError::ShapeMismatch { .. })
    ));
    assert!(MassModel::new(vec![Body {
        mass: f64::NAN,
        com: Vector3::zeros()
    }])
    .is_err());
    assert!(Gravity::new([0.0, f64::INFINITY, 0.0]).is_err());
}

/// Panda-class compliances for a chain's extended model: torsions 1e-4..5e-4 rad/(N·m), tilts 3× stiffer.
fn arm_compliances(n: usize) -> Vec<f64> {
    (0..n)
        .flat_map(|j| {
            let cz = 1e-4 * (1.0 + (j % 5) as f64);
            [cz, cz / 3.0, cz / 3.0]
        })
        .collect()
}

proptest! {
    #![proptest_config(config(24))]

    /// At the equilibrium under gravity the total potential ½θᵀKθ + U_g(θ) is stationary:
    /// K θ* equals −∂U_g/∂θ at θ*, by differences of the potential on the deflected chain.
    #[test]
    fn the_equilibrium_under_weight_is_a_stationary_point_of_the_potential((chain, q, g, p) in arb_case(), full in any::<bool>()) {
        use vjm::gravity::{static_equilibrium, Loading};
        let n = chain.n_joints();
        let (model, c) = if full {
            // Links of 10 N/µm beside the Panda-class rotations.
            let c: Vec<f64> = arm_compliances(n)
                .chunks(3)
                .flat_map(|r| [r[0], r[1], r[2], 1e-7, 1e-7, 1e-7])
                .collect();
            (VirtualJointModel::full(n), c)
        } else {
            (VirtualJointModel::extended(n), arm_compliances(n))
        };
        let loading = Loading { gravity: Some(g), payload: p.as_ref(), wrench: None };
        let eq = static_equilibrium(&chain, &model, &c, &q, &loading).unwrap();
        let h = 1e-6;
        let scale = moment_scale(&chain, &g, p.as_ref());
        for k in 0..model.n_params() {
            let mut t = eq.theta.clone();
            t[k] += h;
            let up = potential(&chain, &model, &q, &t, &g, p.as_ref());
            t[k] -= 2.0 * h;
            let down = potential(&chain, &model, &q, &t, &g, p.as_ref());
            let tau = -(up - down) / (2.0 * h);
            prop_assert!((eq.theta[k] / c[k] - tau).abs() <= 1e-6 * scale,
                "spring {k}: K θ = {} vs τ_g(θ*) = {tau}", eq.theta[k] / c[k]);
        }
    }
}

/// With no weight and a small wrench the equilibrium is the linear model's deflection, to
/// the geometric non-linearity; and it converges in a few chord steps.
#[test]
fn a_small_load_without_weight_gives_the_linear_deflection() {
    use vjm::gravity::{static_equilibrium, Loading};
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let c = arm_compliances(7);
    let q = [0.3, -0.5, 0.2, -2.0, 0.1, 1.7, 0.6];
    let w = [0.5, -0.3, 0.4, 0.02, -0.03, 0.01];
    let loading = Loading {
        wrench: Some(w),
        ..Default::default()
    };
    let eq = static_equilibrium(&panda, &model, &c, &q, &loading).unwrap();
    assert!(eq.iterations <= 6, "{} iterations", eq.iterations);
    let rigid = panda.forward_kinematics(&q).unwrap();
    let d = eq.tip.translation.vector - rigid.translation.vector;
    let lin = vjm::predict_deflection(&panda, &model, &c, &q, &w, false).unwrap();
    let lin = Vector3::new(lin[0], lin[1], lin[2]);
    assert!((d - lin).norm() <= 1e-3 * lin.norm(), "{d:?} vs {lin:?}");
    assert!((d - lin).norm() > 0.0);
}

#[test]
fn bad_compliances_and_runaway_loads_are_errors_not_hangs() {
    use vjm::gravity::{static_equilibrium, Loading};
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let q = [0.3, -0.5, 0.2, -2.0, 0.1, 1.7, 0.6];
    let loading = Loading {
        wrench: Some([50.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ..Default::default()
    };
    let short = vec![1e-4; 20];
    assert!(matches!(
        static_equilibrium(&panda, &model, &short, &q, &loading),
        Err(VjmError::ShapeMismatch { .. })
    ));
    // A negative entry (an aliased family's minimum-norm member stores some) is the same fixed
    // point θ = C·τ(θ): accepted, and the spring's deflection has the sign of its compliance
    // times the torque, opposite to the positive member's.
    let mut negative = arm_compliances(7);
    negative[4] = -1e-4;
    let neg = static_equilibrium(&panda, &model, &negative, &q, &loading).unwrap();
    negative[4] = 1e-4;
    let pos = static_equilibrium(&panda, &model, &negative, &q, &loading).unwrap();
    assert!(
        neg.theta[4] * pos.theta[4] < 0.0 && pos.theta[4].abs() > 1e-6,
        "{:?}",
        (neg.theta[4], pos.theta[4])
    );
    let mut nan = arm_compliances(7);
    nan[4] = f64::NAN;
    let err = static_equilibrium(&panda, &model, &nan, &q, &loading).unwrap_err();
    assert!(err.to_string().contains("compliance"), "{err}");
    // Compliances of a rubber arm: 50 N would turn the springs by radians.
    let rubber = vec![1.0; 21];
    let err = static_equilibrium(&panda, &model, &rubber, &q, &loading).unwrap_err();
    assert!(matches!(err, VjmError::Numerical { .. }), "{err}");
    // Gravity on a chain without masses is refused.
    let massless = SerialChain::from_joints(
        "b",
        "t",
        vec![(
            "j".into(),
            nalgebra::Isometry3::identity(),
            Vector3::y(),
            (-1.0, 1.0),
        )],
        nalgebra::Isometry3::translation(0.5, 0.0, 0.0),
    )
    .unwrap();
    let weighing = Loading {
        gravity: Some(Gravity::default()),
        ..Default::default()
    };
    assert!(matches!(
        static_equilibrium(
            &massless,
            &VirtualJointModel::traditional(1),
            &[1e-4],
            &[0.0],
            &weighing
        ),
        Err(VjmError::InvalidInertial { .. })
    ));
}

/// The bundled URDF gained inertials with the same kinematics: a model saved against the
/// earlier revision (a file of the fuzz corpus, written before) still loads; one whose
/// recorded hash is any other still gets the changed-URDF error.
#[test]
fn a_model_saved_against_the_bundled_urdf_before_its_inertials_still_loads() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/fuzz/corpus/model/valid-panda.json"
    );
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains("97135d0b29577346c1becc93f40679498936456ef8a94bf24b109e208be8cd4c"));
    let chain = SerialChain::bundled();
    let model = vjm::StiffnessModel::from_json(&text, "valid-panda.json").unwrap();
    model.check_robot(&chain, "valid-panda.json").unwrap();
    // Another recorded hash (content hash made valid again) is refused.
    let forged = text.replace(
        "97135d0b29577346c1becc93f40679498936456ef8a94bf24b109e208be8cd4c",
        "17135d0b29577346c1becc93f40679498936456ef8a94bf24b109e208be8cd4c",
    );
    let mut doc: serde_json::Value = serde_json::from_str(&forged).unwrap();
    let inner: vjm::StiffnessModel = serde_json::from_value(doc["model"].clone()).unwrap();
    doc["content_sha256"] = serde_json::Value::String(inner.content_sha256());
    let m = vjm::StiffnessModel::from_json(&doc.to_string(), "forged.json").unwrap();
    let err = m.check_robot(&chain, "forged.json").unwrap_err();
    assert!(err.to_string().contains("URDF content"), "{err}");
}

/// Noise-free measurements of the bundled Panda under gravity by the exact equilibrium
/// ([`deflection_under_gravity`](vjm::gravity::deflection_under_gravity): the deflected chain,
/// no linearisation — a code path independent of `identify`'s): `count` random poses, each
/// loaded by forces up to `force` N and moments up to `force`/10 N·m, and with `paired` also
/// by the opposite wrench (the load's second-order geometric non-linearity then cancels in
/// the fit). Returns q, wrenches, displacements, rotations.
fn panda_under_gravity(
    c: &[f64],
    count: usize,
    force: f64,
    paired: bool,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    use rand::{Rng, SeedableRng};
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let base_q = crate::strategies::random_configurations(&panda, count, seed);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 1);
    let (mut q, mut w, mut d, mut r) = (vec![], vec![], vec![], vec![]);
    for qi in base_q.chunks_exact(7) {
        let mut wi = [0.0; 6];
        for (k, v) in wi.iter_mut().enumerate() {
            let s = if k < 3 { force } else { force / 10.0 };
            *v = rng.random_range(-s..s);
        }
        let loads = if paired {
            vec![wi, wi.map(|x| -x)]
        } else {
            vec![wi]
        };
        for load in loads {
            let dev = vjm::gravity::deflection_under_gravity(
                &panda,
                &model,
                c,
                qi,
                &load,
                &Gravity::default(),
                None,
            )
            .unwrap();
            q.extend_from_slice(qi);
            w.extend_from_slice(&load);
            d.extend_from_slice(&dev[..3]);
            r.extend_from_slice(&dev[3..]);
        }
    }
    (q, w, d, r)
}

/// The largest relative error of the identified compliances (without rotations the Panda's
/// last torsion turns the flange about its own axis and is not identifiable: the first six).
fn worst_relative_error(id: &vjm::Identification, truth: &[f64]) -> f64 {
    let known = if id.rank == 7 { 7 } else { 6 };
    id.compliance[..known]
        .iter()
        .zip(truth)
        .map(|(c, t)| (c.expect("identifiable") - t).abs() / t)
        .fold(0.0, f64::max)
}

/// Panda-class torsion compliances, 1e-4 … 5e-4 rad/(N·m) (joint stiffness 2–10 kN·m/rad).
const PANDA_TORSIONS: [f64; 7] = [1e-4, 2e-4, 1.5e-4, 3e-4, 5e-4, 4e-4, 2.5e-4];

/// `identify` under gravity recovers the springs from (loaded − unloaded) measurements taken
/// at the exact static equilibrium under the Panda's weight; the weightless fit of the same
/// data is biased by gravity's stiffness and the sag (≈ 2 %). Measured (60 poses, worst of
/// the six identifiable torsions): with paired loads (± W: the load's second-order geometric
/// non-linearity cancels) 1.3e-4 under gravity at 20 N and at 5 N alike against 2.2e-2
/// weightless — what remains is second order in the weight (it scales with C², 8e-6 at C/4:
/// gravity's stiffness is taken at the unsagged pose); single loads of ≤ 5 N (moments ≤ 0.5
/// N·m) add the load's non-linearity, 6.5e-4 (2.8e-3 at 20 N, 1.6e-4 at 1 N).
#[test]
fn identify_under_gravity_recovers_the_springs_of_the_exact_equilibrium() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = PANDA_TORSIONS;
    let weightless = vjm::IdentifyOptions::default();
    let mut under_gravity = weightless;
    under_gravity.gravity = Some(Gravity::default());
    for (force, paired, bound) in [(20.0, true, 2e-4), (5.0, false, 1e-3)] {
        let (q, w, d, _) = panda_under_gravity(&c, 60, force, paired, 3);
        let with = vjm::identify(
            &panda,
            &model,
            Measurements::new(&q, &w, &d),
            &under_gravity,
        )
        .unwrap();
        let without =
            vjm::identify(&panda, &model, Measurements::new(&q, &w, &d), &weightless).unwrap();
        let (e_with, e_without) = (
            worst_relative_error(&with, &c),
            worst_relative_error(&without, &c),
        );
        eprintln!(
            "loads ≤ {force} N (paired: {paired}): worst relative error {e_with:.2e} under \
             gravity in {} refits, {e_without:.2e} weightless",
            with.gravity_iterations
        );
        assert!(e_with <= bound, "under gravity: {e_with:e}");
        assert!(e_without >= 10.0 * e_with, "{e_without:e} vs {e_with:e}");
        assert!(with.gravity_iterations >= 2 && with.gravity_iterations <= vjm::MAX_GRAVITY_REFITS);
        assert_eq!(without.gravity_iterations, 0);
        // The dense path refits the same way.
        let dense = vjm::identify_dense(
            &panda,
            &model,
            Measurements::new(&q, &w, &d),
            &under_gravity,
        )
        .unwrap();
        assert_eq!(dense.rank, with.rank);
        for (a, b) in dense.compliance[..6].iter().zip(&with.compliance) {
            let (a, b) = (a.unwrap(), b.unwrap());
            assert!((a - b).abs() <= 1e-9 * b, "{a} vs {b}");
        }
    }
}

/// `nonnegative` under gravity settles on a rank-deficient model: the extended model (21
/// springs, tilts aliased) fitted to data from torsions alone, where the tilts' bounds are
/// active. Refitting non-negative least squares never settled (every such fit failed after 20
/// refits: its minimiser jumps between vertices from one refit to the next); the refits now
/// run unconstrained and the bound is applied once at their fixed point: every compliance is
/// ≥ 0 and the fit explains the data as the unconstrained one does.
#[test]
fn nonnegative_fits_settle_under_gravity() {
    let panda = SerialChain::bundled();
    let extended = VirtualJointModel::extended(7);
    let c = PANDA_TORSIONS;
    let (q, w, d, _) = panda_under_gravity(&c, 60, 20.0, true, 11);
    let mut opts = vjm::IdentifyOptions::default();
    opts.gravity = Some(Gravity::default());
    let free = vjm::identify(&panda, &extended, Measurements::new(&q, &w, &d), &opts).unwrap();
    opts.nonnegative = true;
    let fit = vjm::identify(&panda, &extended, Measurements::new(&q, &w, &d), &opts).unwrap();
    assert!(fit.gravity_iterations >= 2 && fit.gravity_iterations <= vjm::MAX_GRAVITY_REFITS);
    assert!(
        fit.solution.solution.iter().all(|x| *x >= 0.0),
        "{:?}",
        fit.solution.solution
    );
    // The constraint costs the fit (almost) nothing on data from non-negative springs.
    let (rss, rss_free) = (fit.solution.rss, free.solution.rss);
    assert!(rss <= rss_free * 1.01 + 1e-30, "{rss:e} vs {rss_free:e}");
    // What the data determine — the identifiable combinations — is the free fit's, to the
    // size of the tilts the bound sets to zero (±1e-7 rad/(N·m) of second-order effects here,
    // against torsions of 1e-4 … 5e-4).
    let (a, b) = (&fit.solution.combinations, &free.solution.combinations);
    assert_eq!(a.len(), b.len());
    assert!(a.len() >= 14, "rank {}", a.len());
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.terms.len(), y.terms.len());
        assert!((x.value - y.value).abs() <= 1e-6, "{:?} vs {:?}", x, y);
    }
}

/// With measured rotations (six rows a measurement) the refits correct the rotations too.
#[test]
fn identify_under_gravity_with_rotations() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let c = PANDA_TORSIONS;
    let (q, w, d, r) = panda_under_gravity(&c, 40, 20.0, true, 5);
    let mut opts = vjm::IdentifyOptions::default();
    opts.use_rotations = true;
    opts.noise_sigma = [1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5];
    let without = vjm::identify(
        &panda,
        &model,
        Measurements::new(&q, &w, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    opts.gravity = Some(Gravity::default());
    let with = vjm::identify(
        &panda,
        &model,
        Measurements::new(&q, &w, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    let (e_with, e_without) = (
        worst_relative_error(&with, &c),
        worst_relative_error(&without, &c),
    );
    eprintln!("with rotations: {e_with:.2e} under gravity, {e_without:.2e} weightless");
    assert!(
        e_with <= 1e-4 && e_without >= 10.0 * e_with,
        "{e_with:e}, {e_without:e}"
    );
}

/// `gravity: None` is today's weightless identification (no refit), and a zero gravity
/// vector refits once to the same bits: the correction is exactly zero.
#[test]
fn identify_without_weight_is_the_weightless_fit() {
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::extended(7);
    let (q, w, d, _) = panda_under_gravity(&PANDA_TORSIONS, 30, 20.0, false, 9);
    let opts = vjm::IdentifyOptions::default();
    assert_eq!(opts.gravity, None);
    let none = vjm::identify(&panda, &model, Measurements::new(&q, &w, &d), &opts).unwrap();
    assert_eq!(none.gravity_iterations, 0);
    let mut zero = opts;
    zero.gravity = Some(Gravity::new([0.0; 3]).unwrap());
    let refit = vjm::identify(&panda, &model, Measurements::new(&q, &w, &d), &zero).unwrap();
    assert_eq!(refit.gravity_iterations, 1);
    assert_eq!(refit.compliance, none.compliance);
    assert_eq!(refit.solution.solution, none.solution.solution);
    assert_eq!(refit.stderr, none.stderr);
    // The weightless building blocks refuse gravity rather than ignore it.
    for err in [
        vjm::build_design(&panda, &model, Measurements::new(&q, &w, &d), &zero).map(|_| ()),
        vjm::accumulate(&panda, &model, Measurements::new(&q, &w, &d), &zero).map(|_| ()),
    ] {
        let err = err.unwrap_err();
        assert!(
            matches!(
                &err,
                VjmError::InvalidOption {
                    name: "gravity",
                    ..
                }
            ),
            "{err}"
        );
    }
}

/// Gravity on a chain whose link has a shape but no `<inertial>` is an error naming the link.
#[test]
fn identify_under_gravity_names_a_link_without_inertial() {
    let xml = BRANCHED.replace(
        r#"<link name="camera"><inertial><mass value="0.5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        r#"<link name="camera"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>"#,
    );
    let chain = SerialChain::from_urdf_str(&xml, "base", "flange").unwrap();
    let model = VirtualJointModel::traditional(2);
    let q = [0.1, 0.2, -0.3, 0.4, 0.5, -0.6];
    let w = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3].repeat(3);
    let d = [1e-5; 9];
    let mut opts = vjm::IdentifyOptions::default();
    assert!(vjm::identify(&chain, &model, Measurements::new(&q, &w, &d), &opts).is_ok());
    opts.gravity = Some(Gravity::default());
    for result in [
        vjm::identify(&chain, &model, Measurements::new(&q, &w, &d), &opts),
        vjm::identify_dense(&chain, &model, Measurements::new(&q, &w, &d), &opts),
    ] {
        let err = result.unwrap_err();
        assert!(
            matches!(&err, VjmError::InvalidInertial { link, .. } if link == "camera"),
            "{err}"
        );
    }
}

/// A model identified under gravity records the gravity and a hash of the chain's masses; it
/// round-trips, and loads only with the masses it was identified with. A weightless model's
/// file has neither field (the file written before gravity was recorded).
#[test]
fn a_model_identified_under_gravity_records_gravity_and_inertials() {
    use vjm::{DataSource, StiffnessModel};
    let panda = SerialChain::bundled();
    let model = VirtualJointModel::traditional(7);
    let (q, w, d, r) = panda_under_gravity(&PANDA_TORSIONS, 20, 20.0, false, 13);
    let mut opts = vjm::IdentifyOptions::default();
    opts.use_rotations = true;
    let weightless = vjm::identify(
        &panda,
        &model,
        Measurements::new(&q, &w, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    let sm = StiffnessModel::from_identification(
        &weightless,
        &panda,
        &model,
        &opts,
        DataSource::in_memory(20),
    )
    .unwrap();
    assert_eq!(sm.gravity(), None);
    assert_eq!(sm.inertials_sha256(), None);
    let text = sm.to_json();
    assert!(
        !text.contains("gravity") && !text.contains("inertials"),
        "{text}"
    );

    let g = Gravity::new([0.0, 0.0, -9.81]).unwrap();
    opts.gravity = Some(g);
    let id = vjm::identify(
        &panda,
        &model,
        Measurements::new(&q, &w, &d).with_rotation(Some(&r)),
        &opts,
    )
    .unwrap();
    let sm =
        StiffnessModel::from_identification(&id, &panda, &model, &opts, DataSource::in_memory(20))
            .unwrap();
    assert_eq!(sm.gravity(), Some(g));
    let hash = vjm::inertials_sha256(&panda).unwrap();
    assert_eq!(sm.inertials_sha256(), Some(hash.as_str()));
    let text = sm.to_json();
    let back = StiffnessModel::from_json(&text, "g.json").unwrap();
    assert_eq!(back, sm);
    assert_eq!(back.gravity(), Some(g));
    back.check_robot(&panda, "g.json").unwrap();

    // Other masses (the hand 1 kg heavier) are another robot for this model.
    let mut bodies = panda.mass_model().unwrap().bodies().to_vec();
    bodies[6].mass += 1.0;
    let heavier = panda
        .clone()
        .with_masses(vjm::gravity::MassModel::new(bodies).unwrap())
        .unwrap();
    assert_ne!(vjm::inertials_sha256(&heavier).unwrap(), hash);
    let err = back.check_robot(&heavier, "g.json").unwrap_err();
    assert!(err.to_string().contains("inertials"), "{err}");
    // ... while the weightless model does not care.
    StiffnessModel::from_identification(
        &weightless,
        &panda,
        &model,
        &{
            let mut o = opts;
            o.gravity = None;
            o
        },
        DataSource::in_memory(20),
    )
    .unwrap()
    .check_robot(&heavier, "w.json")
    .unwrap();

    // Files edited and re-hashed: a forged inertials hash is refused on load with the chain,
    // a malformed one or gravity without its hash when parsed.
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
        f(&mut doc["model"]);
        let inner: StiffnessModel = serde_json::from_value(doc["model"].clone()).unwrap();
        doc["content_sha256"] = serde_json::Value::String(inner.content_sha256());
        doc.to_string()
    };
    let other = format!("0{}", &hash[1..]);
    let other = if other == hash {
        format!("1{}", &hash[1..])
    } else {
        other
    };
    let forged = edit(&|m| m["inertials_sha256"] = serde_json::Value::String(other.clone()));
    let m = StiffnessModel::from_json(&forged, "forged.json").unwrap();
    let err = m.check_robot(&panda, "forged.json").unwrap_err();
    assert!(
        matches!(&err, vjm::ModelError::OtherRobot { what, .. } if what.contains("inertials")),
        "{err}"
    );
    let malformed = edit(&|m| m["inertials_sha256"] = serde_json::Value::String("xyz".into()));
    let err = StiffnessModel::from_json(&malformed, "bad.json").unwrap_err();
    assert!(err.to_string().contains("inertials_sha256"), "{err}");
    let unhashed = edit(&|m| {
        m.as_object_mut().unwrap().remove("inertials_sha256");
    });
    let err = StiffnessModel::from_json(&unhashed, "bad.json").unwrap_err();
    assert!(
        err.to_string().contains("inertials_sha256 is missing"),
        "{err}"
    );
    // Not three numbers: refused when parsed (before the hash is compared).
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    doc["model"]["gravity"] = serde_json::json!([0.0, -9.81]);
    let err = StiffnessModel::from_json(&doc.to_string(), "bad.json").unwrap_err();
    assert!(
        matches!(&err, vjm::ModelError::Format { message, .. } if message.contains("gravity") || message.contains("length 3")),
        "{err}"
    );
}
