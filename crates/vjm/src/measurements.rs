//! A borrowed view of measured rows: what an identification reads.

/// N measured rows, borrowed, row-major, base frame, SI: joint angles `q` N×n (rad), wrenches
/// N×6 `[fx, fy, fz, mx, my, mz]` (N, N·m, applied at the tip point), tip displacements N×3 (m)
/// and, when measured, tip rotations N×3 (rad, small rotation vectors).
///
/// The view only groups the slices; their shapes and values are checked by the function that
/// reads them (which knows the chain's n), with errors naming the array and the row.
///
/// ```
/// use vjm::Measurements;
/// let (q, wrench, displacement) = (vec![0.0; 7], vec![0.0; 6], vec![0.0; 3]);
/// let rows = Measurements::new(&q, &wrench, &displacement);
/// assert!(rows.rotation().is_none());
/// let rotation = vec![0.0; 3];
/// assert_eq!(rows.with_rotation(Some(&rotation)).rotation(), Some(&rotation[..]));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Measurements<'a> {
    pub(crate) q: &'a [f64],
    pub(crate) wrench: &'a [f64],
    pub(crate) displacement: &'a [f64],
    pub(crate) rotation: Option<&'a [f64]>,
}

impl<'a> Measurements<'a> {
    /// Rows of joint angles (N×n, rad), wrenches (N×6, N and N·m) and tip displacements (N×3,
    /// m), without rotations.
    pub fn new(q: &'a [f64], wrench: &'a [f64], displacement: &'a [f64]) -> Self {
        Self {
            q,
            wrench,
            displacement,
            rotation: None,
        }
    }

    /// The same rows with their tip rotations (N×3, rad), or without any (`None`).
    pub fn with_rotation(self, rotation: Option<&'a [f64]>) -> Self {
        Self { rotation, ..self }
    }

    /// Joint angles, N×n, rad.
    pub fn q(&self) -> &'a [f64] {
        self.q
    }

    /// Wrenches `[fx, fy, fz, mx, my, mz]` at the tip point, N×6, base frame, N and N·m.
    pub fn wrench(&self) -> &'a [f64] {
        self.wrench
    }

    /// Tip displacements, N×3, base frame, m.
    pub fn displacement(&self) -> &'a [f64] {
        self.displacement
    }

    /// Tip rotation vectors, N×3, base frame, rad, when measured.
    pub fn rotation(&self) -> Option<&'a [f64]> {
        self.rotation
    }
}
