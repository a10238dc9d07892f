//! Bad input returns an error naming what is wrong (the cable, 1-based), never a panic.

use nalgebra::{Matrix3, Rotation3, Vector3};
use so3_stiffness::csjm::{
    stiffness_at, Cable, CsjmGeometry, CsjmSimulator, EquilibriumOptions, PointLoad,
};
use so3_stiffness::error::Side;
use so3_stiffness::CsjmError;

fn prototype_points() -> ([Vector3<f64>; 6], [Vector3<f64>; 6]) {
    let g = CsjmGeometry::prototype();
    (*g.platform_points(), *g.base_points())
}

#[test]
fn non_finite_point_names_the_cable() {
    let (mut a, b) = prototype_points();
    a[3].y = f64::NAN;
    let err = CsjmGeometry::new(a, b).unwrap_err();
    assert_eq!(
        err,
        CsjmError::NonFinite {
            what: "platform point a_i",
            cable: Some(4)
        }
    );
    assert!(err.to_string().contains("cable 4"), "{err}");
    let (a, mut b) = prototype_points();
    b[0].z = f64::INFINITY;
    assert_eq!(
        CsjmGeometry::try_from((a, b)).unwrap_err(),
        CsjmError::NonFinite {
            what: "base point b_i",
            cable: Some(1)
        }
    );
}

#[test]
fn coincident_points_are_named() {
    let (a, mut b) = prototype_points();
    b[4] = b[1];
    let err = CsjmGeometry::new(a, b).unwrap_err();
    assert!(
        matches!(
            err,
            CsjmError::CoincidentPoints {
                side: Side::Base,
                first: 2,
                second: 5,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("base point B2 and base point B5"),
        "{err}"
    );
}

#[test]
fn point_at_the_joint_centre_is_rejected() {
    let (mut a, b) = prototype_points();
    a[5] = Vector3::zeros();
    let err = CsjmGeometry::new(a, b).unwrap_err();
    assert!(
        matches!(
            err,
            CsjmError::PointAtCentre {
                side: Side::Platform,
                cable: 6,
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn zero_length_cable_is_named() {
    let (a, mut b) = prototype_points();
    b[2] = a[2]; // A3 and B3 coincide at the home pose
    let g = CsjmGeometry::new(a, b).unwrap();
    let err = so3_stiffness::csjm::jacobian(&g, &Rotation3::identity()).unwrap_err();
    assert!(
        matches!(err, CsjmError::ZeroLengthCable { cable: 3, .. }),
        "{err:?}"
    );
    let err = stiffness_at(&g, &Rotation3::identity(), &[10.0; 6], &[1e3; 6], &[]).unwrap_err();
    assert!(
        matches!(err, CsjmError::ZeroLengthCable { cable: 3, .. }),
        "{err:?}"
    );
}

#[test]
fn slack_or_non_finite_tension_is_named() {
    let g = CsjmGeometry::prototype();
    let id = Rotation3::identity();
    let mut t = [50.0; 6];
    t[4] = 0.0;
    let err = stiffness_at(&g, &id, &t, &[1e3; 6], &[]).unwrap_err();
    assert_eq!(
        err,
        CsjmError::SlackCable {
            cable: 5,
            tension: 0.0
        }
    );
    assert_eq!(
        err.to_string(),
        "cable 5 is slack: tension 0.000000e0 N ≤ 0"
    );
    t[4] = f64::NAN;
    assert_eq!(
        stiffness_at(&g, &id, &t, &[1e3; 6], &[]).unwrap_err(),
        CsjmError::NonFinite {
            what: "cable tension",
            cable: Some(5)
        }
    );
    let mut k = [1e3; 6];
    k[1] = -1.0;
    let err = stiffness_at(&g, &id, &[50.0; 6], &k, &[]).unwrap_err();
    assert!(
        matches!(err, CsjmError::InvalidCableParameter { cable: 2, .. }),
        "{err:?}"
    );
}

#[test]
fn simulator_reports_the_slack_cable() {
    let g = CsjmGeometry::prototype();
    // Rest length longer than the cable at home: cable 6 is slack there.
    let lengths = so3_stiffness::csjm::cable_lengths(&g, &Rotation3::identity()).unwrap();
    let cables = std::array::from_fn(|i| Cable {
        stiffness: 4000.0,
        rest_length: lengths[i] - if i == 5 { -0.001 } else { 0.01 },
    });
    let sim = CsjmSimulator::new(g.clone(), cables).unwrap();
    for err in [
        sim.tensions(&Rotation3::identity()).unwrap_err(),
        sim.potential(&Rotation3::identity()).unwrap_err(),
        sim.holding_moment(&Rotation3::identity()).unwrap_err(),
        sim.equilibrium(&Vector3::zeros(), &EquilibriumOptions::default())
            .unwrap_err(),
    ] {
        assert!(
            matches!(err, CsjmError::SlackCable { cable: 6, .. }),
            "{err:?}"
        );
    }
    // A moment too large for the pre-tension: the solver stops with the cable that goes slack
    // or a non-convergence error; it never panics or returns a pose with a slack cable.
    let sim =
        CsjmSimulator::with_pretension(g, [4000.0; 6], [20.0; 6], &Rotation3::identity()).unwrap();
    match sim.equilibrium(
        &Vector3::new(0.0, 0.0, 50.0),
        &EquilibriumOptions::default(),
    ) {
        Err(CsjmError::SlackCable { .. } | CsjmError::NoConvergence { .. }) => {}
        other => panic!("expected a slack-cable or convergence error, got {other:?}"),
    }
}

#[test]
fn invalid_cable_parameters_and_options_are_named() {
    let g = CsjmGeometry::prototype();
    let mut cables = [Cable {
        stiffness: 1e3,
        rest_length: 0.1,
    }; 6];
    cables[2].rest_length = 0.0;
    let err = CsjmSimulator::new(g.clone(), cables).unwrap_err();
    assert!(
        matches!(
            err,
            CsjmError::InvalidCableParameter {
                cable: 3,
                what: "rest length [m]",
                ..
            }
        ),
        "{err:?}"
    );
    // Pre-tension so large that the rest length would be negative.
    let mut t = [50.0; 6];
    t[0] = 1e6;
    let err =
        CsjmSimulator::with_pretension(g.clone(), [1e3; 6], t, &Rotation3::identity()).unwrap_err();
    assert!(
        matches!(err, CsjmError::InvalidCableParameter { cable: 1, .. }),
        "{err:?}"
    );
    let sim =
        CsjmSimulator::with_pretension(g, [1e3; 6], [50.0; 6], &Rotation3::identity()).unwrap();
    let err = sim
        .equilibrium(
            &Vector3::new(f64::NAN, 0.0, 0.0),
            &EquilibriumOptions::default(),
        )
        .unwrap_err();
    assert!(matches!(err, CsjmError::NonFinite { .. }), "{err:?}");
    let mut opts = EquilibriumOptions::default();
    opts.moment_tolerance = -1.0;
    assert!(matches!(
        sim.equilibrium(&Vector3::zeros(), &opts).unwrap_err(),
        CsjmError::InvalidOption { .. }
    ));
    let bad_pose = Rotation3::from_matrix_unchecked(Matrix3::from_element(f64::NAN));
    assert!(matches!(
        sim.holding_moment(&bad_pose).unwrap_err(),
        CsjmError::NonFinite { what: "pose R", .. }
    ));
    assert!(PointLoad::gravity(-1.0, Vector3::z()).is_err());
    assert!(PointLoad::new(Vector3::new(f64::NAN, 0.0, 0.0), Vector3::z()).is_err());
}
