//! Cable attachment geometry of a CSJM: six points `a_i` on the platform (frame A) and six
//! points `b_i` on the base (frame B); cable `i` runs from `A_i` to `B_i`.

use nalgebra::Vector3;

use crate::error::{CsjmError, Side};

/// Number of cables of a CSJM.
pub const CABLES: usize = 6;

/// Points closer than this (m) are treated as coincident; far below any machining tolerance.
const MIN_POINT_SEPARATION: f64 = 1e-9;

/// Side lengths and plane offsets of the seed's prototype (seed section IV.A), SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrototypeDimensions {
    /// A1A2 = A3A4 = A5A6, m.
    pub platform_short_side: f64,
    /// A2A3 = A4A5 = A6A1, m.
    pub platform_long_side: f64,
    /// B2B3 = B4B5 = B6B1, m.
    pub base_short_side: f64,
    /// B1B2 = B3B4 = B5B6, m.
    pub base_long_side: f64,
    /// OO_A: height of the platform hole plane above O along z_A, m.
    pub platform_offset: f64,
    /// OO_B: depth of the base hole plane below O along −z_B, m.
    pub base_offset: f64,
}

impl PrototypeDimensions {
    /// The dimensions printed in the seed (section IV.A).
    pub const PAPER: PrototypeDimensions = PrototypeDimensions {
        platform_short_side: 0.010,
        platform_long_side: 0.095,
        base_short_side: 0.005,
        base_long_side: 0.128,
        platform_offset: 0.08,
        base_offset: 0.08,
    };
}

/// Cable attachment points of a cable-driven spherical joint module.
///
/// `a_i` (m, components in the platform frame A) and `b_i` (m, components in the base frame B)
/// are position vectors from the joint centre O, the common origin of A and B. The pose
/// `R = ᴮ_A R` maps A-components to B-components, so the cable vector in B is `b_i − R a_i`.
///
/// Immutable once built; [`CsjmGeometry::new`] validates it.
#[derive(Debug, Clone, PartialEq)]
pub struct CsjmGeometry {
    platform_points_in_a: [Vector3<f64>; CABLES],
    base_points_in_b: [Vector3<f64>; CABLES],
}

fn validate_side(points: &[Vector3<f64>; CABLES], side: Side) -> Result<(), CsjmError> {
    let what = match side {
        Side::Platform => "platform point a_i",
        Side::Base => "base point b_i",
    };
    for (i, p) in points.iter().enumerate() {
        if !p.iter().all(|x| x.is_finite()) {
            return Err(CsjmError::NonFinite {
                what,
                cable: Some(i + 1),
            });
        }
        let distance = p.norm();
        if distance < MIN_POINT_SEPARATION {
            return Err(CsjmError::PointAtCentre {
                side,
                cable: i + 1,
                distance,
            });
        }
    }
    for i in 0..CABLES {
        for j in (i + 1)..CABLES {
            let distance = (points[i] - points[j]).norm();
            if distance < MIN_POINT_SEPARATION {
                return Err(CsjmError::CoincidentPoints {
                    side,
                    first: i + 1,
                    second: j + 1,
                    distance,
                });
            }
        }
    }
    Ok(())
}

/// Vertices of a semi-regular hexagon (alternating sides `short`, `long`) in the plane
/// z = `height`, counter-clockwise about +z, the midpoint of the first short side at azimuth
/// `first_short_midpoint` (rad). Vertex 0 and 1 bound that first short side.
///
/// The hexagon is inscribed in a circle (3-fold symmetry): with β the half central angle of
/// the short side, `short/long = sin β / sin(60° − β)`, hence
/// `tan β = short·(√3/2) / (long + short/2)` and the circumradius is `short / (2 sin β)`.
fn semi_regular_hexagon(
    short: f64,
    long: f64,
    height: f64,
    first_short_midpoint: f64,
) -> [Vector3<f64>; CABLES] {
    let beta = (short * 3f64.sqrt() / 2.0).atan2(long + short / 2.0);
    let radius = short / (2.0 * beta.sin());
    let third = 2.0 * std::f64::consts::FRAC_PI_3;
    std::array::from_fn(|v| {
        let pair_centre = first_short_midpoint + third * (v / 2) as f64;
        let azimuth = if v % 2 == 0 {
            pair_centre - beta
        } else {
            pair_centre + beta
        };
        Vector3::new(radius * azimuth.cos(), radius * azimuth.sin(), height)
    })
}

impl CsjmGeometry {
    /// Builds a geometry from the six platform points (m, frame A) and six base points
    /// (m, frame B), both measured from the joint centre O.
    ///
    /// Errors if a coordinate is not finite, a point lies at O, or two points of the same
    /// body coincide — each error names the cable.
    pub fn new(
        platform_points_in_a: [Vector3<f64>; CABLES],
        base_points_in_b: [Vector3<f64>; CABLES],
    ) -> Result<Self, CsjmError> {
        validate_side(&platform_points_in_a, Side::Platform)?;
        validate_side(&base_points_in_b, Side::Base)?;
        Ok(Self {
            platform_points_in_a,
            base_points_in_b,
        })
    }

    /// The seed's prototype (section IV.A), with the layout assumptions below.
    ///
    /// The seed prints side lengths only; the drawing (its Figures 1 and 4) fixes the rest
    /// qualitatively. Assumptions (see `docs/so3-stiffness.md`):
    ///
    /// 1. Both hole patterns are semi-regular hexagons inscribed in circles (3-fold symmetry):
    ///    platform radius ≈ 0.0579 m, base radius ≈ 0.0754 m.
    /// 2. Vertices are numbered counter-clockwise about +z; on the platform the short sides
    ///    are A1A2, A3A4, A5A6, on the base B2B3, B4B5, B6B1 (as printed).
    /// 3. The platform holes lie in the plane z_A = +OO_A = +0.08 m (above O), the base holes
    ///    in z_B = −OO_B = −0.08 m (below O): cables pull the platform down onto the joint.
    /// 4. x_A points to the midpoint of A1A2; x_B points to the midpoint of the long side B1B2,
    ///    i.e. the base short sides sit at azimuths ±60°, 180°, rotated 60° from the platform
    ///    short sides at 0°, ±120°. Each cable therefore leans tangentially, neighbours in
    ///    opposite senses, which gives torsional stiffness about z.
    ///
    /// At R = I equal tensions are in equilibrium (the 3-fold and mirror symmetries cancel
    /// their moment) and J has full rank, so all six cables can be tensioned.
    ///
    /// ```
    /// use so3_stiffness::csjm::CsjmGeometry;
    /// let g = CsjmGeometry::prototype();
    /// let (a, b) = (g.platform_point(0), g.platform_point(1)); // A1, A2
    /// assert!(((a - b).norm() - 0.010).abs() < 1e-12);
    /// ```
    pub fn prototype() -> Self {
        Self::from_prototype_dimensions(&PrototypeDimensions::PAPER)
    }

    // Unvalidated construction; callers guarantee finite, positive dimensions.
    fn from_prototype_dimensions(d: &PrototypeDimensions) -> Self {
        let platform = semi_regular_hexagon(
            d.platform_short_side,
            d.platform_long_side,
            d.platform_offset,
            0.0,
        );
        // Base: short sides B2B3, B4B5, B6B1 centred at +60°, 180°, −60°. Build the hexagon
        // starting from B2 (first short side B2B3 at +60°) and rotate the labels by one.
        let from_b2 = semi_regular_hexagon(
            d.base_short_side,
            d.base_long_side,
            -d.base_offset,
            std::f64::consts::FRAC_PI_3,
        );
        let base = std::array::from_fn(|i| from_b2[(i + CABLES - 1) % CABLES]);
        Self {
            platform_points_in_a: platform,
            base_points_in_b: base,
        }
    }

    /// A prototype-like layout with user dimensions (all in m, all finite and > 0).
    pub fn try_from_prototype_dimensions(d: &PrototypeDimensions) -> Result<Self, CsjmError> {
        let fields = [
            ("platform_short_side [m]", d.platform_short_side),
            ("platform_long_side [m]", d.platform_long_side),
            ("base_short_side [m]", d.base_short_side),
            ("base_long_side [m]", d.base_long_side),
            ("platform_offset OO_A [m]", d.platform_offset),
            ("base_offset OO_B [m]", d.base_offset),
        ];
        for (what, value) in fields {
            if !(value.is_finite() && value > 0.0) {
                return Err(CsjmError::InvalidOption { what, value });
            }
        }
        let g = Self::from_prototype_dimensions(d);
        Self::new(g.platform_points_in_a, g.base_points_in_b)
    }

    /// Platform point `a_i` (m, frame A); `cable` is 0-based.
    ///
    /// # Panics
    /// If `cable >= 6` (a programming error, not user data).
    pub fn platform_point(&self, cable: usize) -> Vector3<f64> {
        self.platform_points_in_a[cable]
    }

    /// Base point `b_i` (m, frame B); `cable` is 0-based.
    ///
    /// # Panics
    /// If `cable >= 6`.
    pub fn base_point(&self, cable: usize) -> Vector3<f64> {
        self.base_points_in_b[cable]
    }

    /// All platform points `a_i` (m, frame A).
    pub fn platform_points(&self) -> &[Vector3<f64>; CABLES] {
        &self.platform_points_in_a
    }

    /// All base points `b_i` (m, frame B).
    pub fn base_points(&self) -> &[Vector3<f64>; CABLES] {
        &self.base_points_in_b
    }
}

impl TryFrom<([Vector3<f64>; CABLES], [Vector3<f64>; CABLES])> for CsjmGeometry {
    type Error = CsjmError;
    /// `(platform points in A, base points in B)`, as [`CsjmGeometry::new`].
    fn try_from(
        points: ([Vector3<f64>; CABLES], [Vector3<f64>; CABLES]),
    ) -> Result<Self, Self::Error> {
        Self::new(points.0, points.1)
    }
}
