//! Shared proptest strategies (rotations, CSJM geometries, loaded systems) and the seeded
//! proptest configuration used by every property test of this binary.

use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator, PointLoad, PrototypeDimensions, CABLES};
use so3_stiffness::so3;

/// Deterministic proptest configuration: fixed seed, no persistence files, `cases` cases.
pub fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x5eed_0003),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A unit vector (components from a cube, renormalised; degenerate draws fall back to x).
pub fn unit_vector() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| {
        let v = Vector3::new(x, y, z);
        if v.norm() < 1e-3 {
            Vector3::x()
        } else {
            v.normalize()
        }
    })
}

/// A rotation vector with angle in `[0, max_angle]`.
pub fn rotation_vector(max_angle: f64) -> impl Strategy<Value = Vector3<f64>> {
    (unit_vector(), 0.0..=max_angle).prop_map(|(n, t)| n * t)
}

/// A rotation with angle in `[0, π)`.
pub fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
    rotation_vector(std::f64::consts::PI - 1e-6).prop_map(|w| so3::exp(&w))
}

/// A random 3-vector with components in `[-scale, scale]`.
pub fn vector(scale: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-scale..scale, -scale..scale, -scale..scale).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

/// A prototype-like CSJM with random dimensions, every point jittered by up to 2 mm so that
/// no symmetry hides a wrong index or sign.
pub fn geometry() -> impl Strategy<Value = CsjmGeometry> {
    let dims = (
        0.006..0.03f64,
        0.06..0.13f64,
        0.006..0.03f64,
        0.08..0.16f64,
        0.05..0.12f64,
        0.05..0.12f64,
    );
    let jitter = proptest::collection::vec(vector(0.002), 2 * CABLES);
    (dims, jitter).prop_map(|((ps, pl, bs, bl, ha, hb), jitter)| {
        let d = PrototypeDimensions {
            platform_short_side: ps,
            platform_long_side: pl,
            base_short_side: bs,
            base_long_side: bl,
            platform_offset: ha,
            base_offset: hb,
        };
        let g = CsjmGeometry::try_from_prototype_dimensions(&d).expect("valid dimensions");
        let a = std::array::from_fn(|i| g.platform_point(i) + jitter[i]);
        let b = std::array::from_fn(|i| g.base_point(i) + jitter[CABLES + i]);
        CsjmGeometry::new(a, b).expect("jitter keeps points ≥ 2 mm apart")
    })
}

/// A loaded conservative system: random geometry, a pose within 0.5 rad of the identity,
/// tensions 5–120 N and cable stiffnesses 2–30 kN/m at that pose, and (half of the time) an
/// extra point load of up to 20 N at up to 0.15 m from O (a weight or counterweight).
pub fn loaded_system() -> impl Strategy<Value = (CsjmSimulator, Rotation3<f64>)> {
    (
        geometry(),
        rotation_vector(0.5),
        proptest::array::uniform6(5.0..120.0f64),
        proptest::array::uniform6(2e3..3e4f64),
        proptest::option::of((vector(0.15), vector(20.0))),
    )
        .prop_filter_map("rest length must stay positive", |(g, w, t, k, load)| {
            let pose = so3::exp(&w);
            let sim = CsjmSimulator::with_pretension(g, k, t, &pose).ok()?;
            let sim = match load {
                Some((p, f)) => sim.with_load(PointLoad::new(p, f).ok()?),
                None => sim,
            };
            Some((sim, pose))
        })
}
