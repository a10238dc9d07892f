//! A conservative CSJM simulator: cables as linear springs with rest lengths, optional
//! conservative point loads (platform weight), the potential energy Φ(R), the external moment
//! that holds the platform at a pose, the analytic stiffness there, and an equilibrium solver.
//!
//! Cable s pulls with `t_s = k_s e_s + k₂_s e_s²`, `e_s = c_s − L0_s` (linear by default,
//! `k₂ = 0`; stiffening with [`CsjmSimulator::with_cable_stiffening`]), which must stay > 0 (a
//! cable cannot push); a slack cable is an error naming it.
//! Φ(R) = Σ (½ k_s e_s² + ⅓ k₂_s e_s³) + Σ_loads −f_B·(R p_A).
//! The external moment holding the platform at R is the body gradient of Φ:
//! `τ_i(R) = d/dε Φ(R·exp(ε hat σ_i))` (N·m, frame A), checked by finite differences in the tests.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::geometry::{CsjmGeometry, CABLES};
use super::kinetostatics::{check_pose, CableKinematics};
use super::loads::PointLoad;
use super::stiffness::{stiffness_from_kinematics, Stiffness};
use crate::error::CsjmError;
use crate::so3;

/// One cable with its driving unit, modelled as a linear spring that can only pull.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cable {
    /// Stiffness `k_s = ∂t_s/∂c_s` of the cable with its driving unit, N/m (> 0).
    pub stiffness: f64,
    /// Rest length `L0_s`, m (> 0): tension is `k_s (c_s − L0_s)`.
    pub rest_length: f64,
}

/// Options of [`CsjmSimulator::equilibrium`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct EquilibriumOptions {
    /// Starting pose `ᴮ_A R` of the Newton iteration.
    pub initial_pose: Rotation3<f64>,
    /// Convergence when ‖τ_hold(R) − τ‖ ≤ this, N·m.
    pub moment_tolerance: f64,
    /// Maximum Newton iterations.
    pub max_iterations: usize,
    /// Largest rotation of one Newton step, rad (a trust radius against wild first steps).
    pub max_step: f64,
}

impl Default for EquilibriumOptions {
    fn default() -> Self {
        Self {
            initial_pose: Rotation3::identity(),
            moment_tolerance: 1e-10,
            max_iterations: 100,
            max_step: 0.25,
        }
    }
}

impl EquilibriumOptions {
    /// Default options starting from `initial_pose`.
    pub fn starting_at(initial_pose: Rotation3<f64>) -> Self {
        Self {
            initial_pose,
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<(), CsjmError> {
        check_pose(&self.initial_pose)?;
        if !(self.moment_tolerance.is_finite() && self.moment_tolerance > 0.0) {
            return Err(CsjmError::InvalidOption {
                what: "moment_tolerance [N·m]",
                value: self.moment_tolerance,
            });
        }
        if !(self.max_step.is_finite() && self.max_step > 0.0) {
            return Err(CsjmError::InvalidOption {
                what: "max_step [rad]",
                value: self.max_step,
            });
        }
        if self.max_iterations == 0 {
            return Err(CsjmError::InvalidOption {
                what: "max_iterations",
                value: 0.0,
            });
        }
        Ok(())
    }
}

/// A static equilibrium found by [`CsjmSimulator::equilibrium`].
#[derive(Debug, Clone, PartialEq)]
pub struct Equilibrium {
    /// The pose `ᴮ_A R`.
    pub pose: Rotation3<f64>,
    /// Cable tensions there, N.
    pub tensions: [f64; CABLES],
    /// The analytic stiffness there (its `external_moment` is the holding moment).
    pub stiffness: Stiffness,
    /// Newton iterations used.
    pub iterations: usize,
    /// Final ‖τ_hold(R) − τ‖, N·m.
    pub residual: f64,
}

/// Conservative CSJM: geometry, six spring cables and optional point loads (immutable model).
#[derive(Debug, Clone, PartialEq)]
pub struct CsjmSimulator {
    geometry: CsjmGeometry,
    cables: [Cable; CABLES],
    /// Quadratic coefficient k₂_s of each cable law, N/m² (0: linear).
    stiffening: [f64; CABLES],
    /// Constant tension offset of each cable, N (0 by default; friction for a fixed sliding
    /// direction).
    tension_offsets: [f64; CABLES],
    loads: Vec<PointLoad>,
}

/// Internal state at one pose.
struct PoseState {
    kinematics: CableKinematics,
    tensions: [f64; CABLES],
}

impl CsjmSimulator {
    /// A simulator from a geometry and six cables. Errors name the cable whose stiffness is
    /// not finite and > 0 or whose rest length is not finite and > 0.
    pub fn new(geometry: CsjmGeometry, cables: [Cable; CABLES]) -> Result<Self, CsjmError> {
        for (i, c) in cables.iter().enumerate() {
            if !(c.stiffness.is_finite() && c.stiffness > 0.0) {
                return Err(CsjmError::InvalidCableParameter {
                    cable: i + 1,
                    what: "stiffness [N/m]",
                    value: c.stiffness,
                    requirement: "finite and > 0",
                });
            }
            if !(c.rest_length.is_finite() && c.rest_length > 0.0) {
                return Err(CsjmError::InvalidCableParameter {
                    cable: i + 1,
                    what: "rest length [m]",
                    value: c.rest_length,
                    requirement: "finite and > 0",
                });
            }
        }
        Ok(Self {
            geometry,
            cables,
            stiffening: [0.0; CABLES],
            tension_offsets: [0.0; CABLES],
            loads: Vec::new(),
        })
    }

    /// A simulator whose cables (stiffness `stiffness`, N/m) carry exactly `tensions` (N, > 0)
    /// at `pose`: rest lengths `L0_s = c_s(pose) − t_s/k_s`.
    ///
    /// ```
    /// use nalgebra::{Rotation3, Vector3};
    /// use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator, EquilibriumOptions};
    /// let sim = CsjmSimulator::with_pretension(CsjmGeometry::prototype(), [4000.0; 6], [60.0; 6], &Rotation3::identity()).unwrap();
    /// let tau = Vector3::new(0.5, -1.0, 0.2); // external moment, N·m, frame A
    /// let eq = sim.equilibrium(&tau, &EquilibriumOptions::default()).unwrap();
    /// assert!((sim.holding_moment(&eq.pose).unwrap() - tau).norm() < 1e-9);
    /// ```
    pub fn with_pretension(
        geometry: CsjmGeometry,
        stiffness: [f64; CABLES],
        tensions: [f64; CABLES],
        pose: &Rotation3<f64>,
    ) -> Result<Self, CsjmError> {
        let kin = CableKinematics::new(&geometry, pose)?;
        let mut cables = [Cable {
            stiffness: 0.0,
            rest_length: 0.0,
        }; CABLES];
        for i in 0..CABLES {
            if !tensions[i].is_finite() {
                return Err(CsjmError::NonFinite {
                    what: "cable tension",
                    cable: Some(i + 1),
                });
            }
            if tensions[i] <= 0.0 {
                return Err(CsjmError::SlackCable {
                    cable: i + 1,
                    tension: tensions[i],
                });
            }
            let rest_length = kin.lengths()[i] - tensions[i] / stiffness[i];
            cables[i] = Cable {
                stiffness: stiffness[i],
                rest_length,
            };
        }
        Self::new(geometry, cables)
    }

    /// Adds a conservative point load (e.g. [`PointLoad::prototype_gravity`]).
    pub fn with_load(mut self, load: PointLoad) -> Self {
        self.loads.push(load);
        self
    }

    /// Makes the cables stiffen with extension: `t_s = k_s e_s + k₂_s e_s²` (`k2` in N/m²,
    /// finite and ≥ 0; `e_s = c_s − L0_s`, m), the behaviour of polymer (UHMWPE) cables and of
    /// their driving units under growing tension. The tangent stiffness is
    /// `∂t_s/∂c_s = k_s + 2k₂_s e_s`. Rest lengths are re-solved so that every cable keeps the
    /// tension it has at `pose` (so a pre-tension set with [`Self::with_pretension`] is kept);
    /// the linear coefficient `k_s` is unchanged.
    ///
    /// Errors: a `k2` that is not finite and ≥ 0 (names the cable), a slack cable at `pose`.
    ///
    /// ```
    /// use nalgebra::Rotation3;
    /// use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator};
    /// let home = Rotation3::identity();
    /// let sim = CsjmSimulator::with_pretension(CsjmGeometry::prototype(), [5000.0; 6], [80.0; 6], &home)?
    ///     .with_cable_stiffening([2.0e5; 6], &home)?;
    /// assert!((sim.tensions(&home)?[0] - 80.0).abs() < 1e-9);
    /// # Ok::<(), so3_stiffness::CsjmError>(())
    /// ```
    pub fn with_cable_stiffening(
        mut self,
        k2: [f64; CABLES],
        pose: &Rotation3<f64>,
    ) -> Result<Self, CsjmError> {
        for (i, v) in k2.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) {
                return Err(CsjmError::InvalidCableParameter {
                    cable: i + 1,
                    what: "stiffening k2 [N/m²]",
                    value: *v,
                    requirement: "finite and ≥ 0",
                });
            }
        }
        let state = self.state(pose)?;
        #[allow(clippy::needless_range_loop)] // four arrays indexed by cable
        for i in 0..CABLES {
            // The elastic part of the tension (offsets, if any, stay as they are).
            let t = state.tensions[i] - self.tension_offsets[i];
            let k = self.cables[i].stiffness;
            if !(t > 0.0) {
                return Err(CsjmError::SlackCable {
                    cable: i + 1,
                    tension: t,
                });
            }
            // Positive root of k e + k₂ e² = t, in the form without cancellation.
            let extension = 2.0 * t / (k + (k * k + 4.0 * k2[i] * t).sqrt());
            self.cables[i].rest_length = state.kinematics.lengths()[i] - extension;
            if !(self.cables[i].rest_length > 0.0) {
                return Err(CsjmError::InvalidCableParameter {
                    cable: i + 1,
                    what: "rest length [m] after stiffening",
                    value: self.cables[i].rest_length,
                    requirement: "finite and > 0",
                });
            }
        }
        self.stiffening = k2;
        Ok(self)
    }

    /// Adds a constant offset to each cable tension, N (finite): `t_s = k_s e_s + k₂_s e_s² +
    /// offset_s`. With `offset_s = f_s·sign(ċ_s)` this is Coulomb friction `f_s` in the cable
    /// routing while cable s slides in a known direction (lengthening: the platform must pull
    /// harder). For fixed offsets the model stays conservative (Φ gains `Σ offset_s e_s`), so
    /// the equilibrium solver and the analytic stiffness apply unchanged; the stiffness does
    /// not depend on the offsets except through the tensions. Replaces earlier offsets.
    ///
    /// Errors: a non-finite offset (names the cable).
    pub fn with_tension_offsets(mut self, offsets: [f64; CABLES]) -> Result<Self, CsjmError> {
        for (i, v) in offsets.iter().enumerate() {
            if !v.is_finite() {
                return Err(CsjmError::NonFinite {
                    what: "cable tension offset",
                    cable: Some(i + 1),
                });
            }
        }
        self.tension_offsets = offsets;
        Ok(self)
    }

    /// Constant tension offsets of the cables, N (all 0 by default).
    pub fn tension_offsets(&self) -> &[f64; CABLES] {
        &self.tension_offsets
    }

    /// Quadratic coefficients k₂_s of the cable laws, N/m² (all 0 for linear cables).
    pub fn cable_stiffening(&self) -> &[f64; CABLES] {
        &self.stiffening
    }

    /// Tangent stiffness `∂t_s/∂c_s = k_s + 2k₂_s e_s` of each cable at `pose`, N/m.
    pub fn tangent_cable_stiffness(
        &self,
        pose: &Rotation3<f64>,
    ) -> Result<[f64; CABLES], CsjmError> {
        let state = self.state(pose)?;
        Ok(self.tangent_stiffness_of(&state))
    }

    fn tangent_stiffness_of(&self, state: &PoseState) -> [f64; CABLES] {
        std::array::from_fn(|i| {
            let extension = state.kinematics.lengths()[i] - self.cables[i].rest_length;
            self.cables[i].stiffness + 2.0 * self.stiffening[i] * extension
        })
    }

    /// The geometry.
    pub fn geometry(&self) -> &CsjmGeometry {
        &self.geometry
    }

    /// The cables.
    pub fn cables(&self) -> &[Cable; CABLES] {
        &self.cables
    }

    /// The point loads.
    pub fn loads(&self) -> &[PointLoad] {
        &self.loads
    }

    fn state(&self, pose: &Rotation3<f64>) -> Result<PoseState, CsjmError> {
        let kinematics = CableKinematics::new(&self.geometry, pose)?;
        let mut tensions = [0.0; CABLES];
        for (i, cable) in self.cables.iter().enumerate() {
            let extension = kinematics.lengths()[i] - cable.rest_length;
            let tension = extension * (cable.stiffness + self.stiffening[i] * extension)
                + self.tension_offsets[i];
            if tension <= 0.0 {
                return Err(CsjmError::SlackCable {
                    cable: i + 1,
                    tension,
                });
            }
            tensions[i] = tension;
        }
        Ok(PoseState {
            kinematics,
            tensions,
        })
    }

    /// Cable tensions at `pose` (N); error naming the first slack cable.
    pub fn tensions(&self, pose: &Rotation3<f64>) -> Result<[f64; CABLES], CsjmError> {
        Ok(self.state(pose)?.tensions)
    }

    /// Potential energy Φ(R), J: cable springs plus point loads. Errors on a slack cable.
    pub fn potential(&self, pose: &Rotation3<f64>) -> Result<f64, CsjmError> {
        let state = self.state(pose)?;
        let springs: f64 = (0..CABLES)
            .map(|i| {
                let e = state.kinematics.lengths()[i] - self.cables[i].rest_length;
                e * e * (0.5 * self.cables[i].stiffness + self.stiffening[i] * e / 3.0)
                    + self.tension_offsets[i] * e
            })
            .sum();
        let loads: f64 = self.loads.iter().map(|l| l.potential(pose)).sum();
        Ok(springs + loads)
    }

    fn internal_moment(&self, state: &PoseState, pose: &Rotation3<f64>) -> Vector3<f64> {
        self.loads
            .iter()
            .fold(state.kinematics.cable_moment(&state.tensions), |m, l| {
                m + l.moment_in_a(pose)
            })
    }

    /// External moment (N·m, frame A) that holds the platform in equilibrium at `pose`:
    /// `τ = −(JᵀT + Σ p × Rᵀf)`, the body gradient of Φ.
    pub fn holding_moment(&self, pose: &Rotation3<f64>) -> Result<Vector3<f64>, CsjmError> {
        let state = self.state(pose)?;
        Ok(-self.internal_moment(&state, pose))
    }

    fn stiffness_of(&self, state: &PoseState, pose: &Rotation3<f64>) -> Stiffness {
        let k = self.tangent_stiffness_of(state);
        stiffness_from_kinematics(&state.kinematics, pose, &state.tensions, &k, &self.loads)
    }

    /// Analytic stiffness at `pose` under the moment that holds it there ([`Self::holding_moment`]).
    pub fn stiffness(&self, pose: &Rotation3<f64>) -> Result<Stiffness, CsjmError> {
        let state = self.state(pose)?;
        Ok(self.stiffness_of(&state, pose))
    }

    /// The pose at which the external moment `external_moment_in_a` (N·m, components in the
    /// platform frame A, as a platform-mounted force/torque sensor reports it) holds the
    /// platform in equilibrium together with the cables and point loads.
    ///
    /// Newton on SO(3): `R ← R·exp(hat δ)` with `K_D δ = −(τ_hold(R) − τ)` (K_D, the
    /// component-wise derivative of the A-frame moment, is the exact Newton matrix here),
    /// steps capped at `max_step`, backtracking on ‖τ_hold − τ‖. May return an unstable
    /// equilibrium if started near one; check `stiffness.is_stable()`.
    ///
    /// Errors: invalid options or moment; slack cable at the start pose or at the load (names
    /// the cable); [`CsjmError::NoConvergence`] otherwise.
    pub fn equilibrium(
        &self,
        external_moment_in_a: &Vector3<f64>,
        options: &EquilibriumOptions,
    ) -> Result<Equilibrium, CsjmError> {
        options.validate()?;
        if !external_moment_in_a.iter().all(|x| x.is_finite()) {
            return Err(CsjmError::NonFinite {
                what: "external moment (frame A)",
                cable: None,
            });
        }
        let tolerance = options.moment_tolerance;
        let mut pose = options.initial_pose;
        let mut state = self.state(&pose)?;
        let mut residual_vec = -self.internal_moment(&state, &pose) - external_moment_in_a;
        let mut residual = residual_vec.norm();
        for iteration in 0..=options.max_iterations {
            if residual <= tolerance {
                let stiffness = self.stiffness_of(&state, &pose);
                return Ok(Equilibrium {
                    pose,
                    tensions: state.tensions,
                    stiffness,
                    iterations: iteration,
                    residual,
                });
            }
            if iteration == options.max_iterations {
                break;
            }
            let euclidean: Matrix3<f64> = self.stiffness_of(&state, &pose).euclidean;
            let Some(mut step) = euclidean
                .lu()
                .solve(&(-residual_vec))
                .filter(|s| s.iter().all(|x| x.is_finite()))
            else {
                return Err(CsjmError::NoConvergence {
                    iterations: iteration,
                    residual,
                    tolerance,
                    reason: "singular tangent stiffness",
                });
            };
            let norm = step.norm();
            if norm > options.max_step {
                step *= options.max_step / norm;
            }
            let mut accepted = None;
            let mut full_step_error = None;
            let mut alpha = 1.0;
            for _ in 0..40 {
                let candidate = pose * so3::exp(&(alpha * step));
                match self.state(&candidate) {
                    Ok(cand_state) => {
                        let r =
                            -self.internal_moment(&cand_state, &candidate) - external_moment_in_a;
                        if r.norm() < (1.0 - 1e-4 * alpha) * residual {
                            accepted = Some((candidate, cand_state, r));
                            break;
                        }
                    }
                    Err(e) => {
                        if full_step_error.is_none() {
                            full_step_error = Some(e);
                        }
                    }
                }
                alpha *= 0.5;
            }
            match accepted {
                Some((p, s, r)) => {
                    pose = p;
                    state = s;
                    residual_vec = r;
                    residual = r.norm();
                }
                None => {
                    // Round-off floor: the residual cannot decrease further but is tiny.
                    if residual <= 1e3 * tolerance {
                        let stiffness = self.stiffness_of(&state, &pose);
                        return Ok(Equilibrium {
                            pose,
                            tensions: state.tensions,
                            stiffness,
                            iterations: iteration,
                            residual,
                        });
                    }
                    if let Some(e @ CsjmError::SlackCable { .. }) = full_step_error {
                        return Err(e);
                    }
                    return Err(CsjmError::NoConvergence {
                        iterations: iteration,
                        residual,
                        tolerance,
                        reason: "line search failed",
                    });
                }
            }
        }
        Err(CsjmError::NoConvergence {
            iterations: options.max_iterations,
            residual,
            tolerance,
            reason: "iteration limit reached",
        })
    }

    /// Equilibria along a load path (allocating level): solve for each external moment in
    /// turn (N·m, frame A), each solve starting from the previous solution (continuation), the
    /// first from `options.initial_pose`. Small load steps make every solve a few Newton steps.
    ///
    /// Errors with [`CsjmError::InBatch`] naming the first load that fails.
    pub fn equilibrium_path(
        &self,
        external_moments_in_a: &[Vector3<f64>],
        options: &EquilibriumOptions,
    ) -> Result<Vec<Equilibrium>, CsjmError> {
        let mut out = Vec::with_capacity(external_moments_in_a.len());
        let mut opts = *options;
        for (index, tau) in external_moments_in_a.iter().enumerate() {
            let eq = self
                .equilibrium(tau, &opts)
                .map_err(|e| CsjmError::InBatch {
                    index,
                    source: Box::new(e),
                })?;
            opts.initial_pose = eq.pose;
            out.push(eq);
        }
        Ok(out)
    }

    /// Batch level of [`Self::equilibrium_path`]: writes only the poses into `poses_out`
    /// (same length as `external_moments_in_a`), no allocation. On error the poses before the
    /// failing item are written and the rest untouched.
    pub fn equilibrium_path_in_place(
        &self,
        external_moments_in_a: &[Vector3<f64>],
        options: &EquilibriumOptions,
        poses_out: &mut [Rotation3<f64>],
    ) -> Result<(), CsjmError> {
        if poses_out.len() != external_moments_in_a.len() {
            return Err(CsjmError::LengthMismatch {
                what: "poses_out",
                expected: external_moments_in_a.len(),
                got: poses_out.len(),
            });
        }
        let mut opts = *options;
        for (index, (tau, out)) in external_moments_in_a
            .iter()
            .zip(poses_out.iter_mut())
            .enumerate()
        {
            let eq = self
                .equilibrium(tau, &opts)
                .map_err(|e| CsjmError::InBatch {
                    index,
                    source: Box::new(e),
                })?;
            opts.initial_pose = eq.pose;
            *out = eq.pose;
        }
        Ok(())
    }

    /// Stiffness at many poses into `out` (same length as `poses`), no allocation.
    /// Errors with [`CsjmError::InBatch`] naming the first failing pose.
    pub fn stiffness_in_place(
        &self,
        poses: &[Rotation3<f64>],
        out: &mut [Stiffness],
    ) -> Result<(), CsjmError> {
        if out.len() != poses.len() {
            return Err(CsjmError::LengthMismatch {
                what: "stiffness out",
                expected: poses.len(),
                got: out.len(),
            });
        }
        for (index, (pose, slot)) in poses.iter().zip(out.iter_mut()).enumerate() {
            *slot = self.stiffness(pose).map_err(|e| CsjmError::InBatch {
                index,
                source: Box::new(e),
            })?;
        }
        Ok(())
    }
}
