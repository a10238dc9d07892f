//! Batched, rank-revealing identification of the virtual-spring compliances
//! (seed eqs. 8–12): streaming — normal equations accumulated lane-wise over rayon threads,
//! or a streaming QR (TSQR) — or dense.

use rayon::prelude::*;
use serde::Serialize;

use crate::chain::{check_finite, SerialChain};
use crate::error::VjmError;
use crate::gravity::{Gravity, GravityWorkspace, RowFrame};
use crate::kinematics::Workspace;
use crate::lanes::gram::{gram_range, GramProblem};
use crate::lanes::kinematics::ChainLanes;
use crate::lsq::{
    self, RankRevealingSolution, SolveOptions, TriangularAccumulator, TriangularFactor,
};
use crate::measurements::Measurements;
use crate::model::{SpringAxis, SpringKind, VirtualJointModel};
use crate::regressor::Measured;
use crate::stats::student_t_975;

/// How [`identify`] reduces the N measurements to an m×m problem.
///
/// Both reductions stream (memory independent of N) and share the rank-revealing solver;
/// they differ in arithmetic and in how much of the design's conditioning they keep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum SolveMethod {
    /// Normal equations, then QR when they cannot be trusted: the Gram path is kept when
    /// the column-scaled design's condition number over its identifiable part is at most
    /// [`NORMAL_EQUATIONS_MAX_CONDITION`] (estimates then carry a relative rounding error
    /// ≲ c·κ²ε ≈ 1e-8·c, far below any measurement noise) and every singular value it
    /// dropped is below [`NORMAL_EQUATIONS_ROUNDING_FLOOR`]·σ₁; otherwise the data are read
    /// again through the streaming QR. The result says which was used. A direction with
    /// σ between `rank_rtol`·σ₁ and the floor is the one case where Auto reports a lower
    /// rank than QR would: its standard error would be ≥ 10⁷ times the best-determined one's.
    #[default]
    Auto,
    /// Normal equations only: one pass, about half the arithmetic of QR and vectorised
    /// (AVX-512 or AVX2 + FMA when the CPU has them). Squares the condition number, so singular values
    /// below [`NORMAL_EQUATIONS_RANK_RTOL`]·σ₁ count as zero whatever `rank_rtol` says.
    NormalEquations,
    /// Streaming Householder QR (TSQR): backward stable, resolves singular values down to
    /// `rank_rtol`·σ₁ (1e-9 by default); about 5× slower.
    Qr,
}

/// Largest condition number (column-scaled, identifiable part) for which
/// [`SolveMethod::Auto`] keeps the normal-equations result.
pub const NORMAL_EQUATIONS_MAX_CONDITION: f64 = 1e4;

/// Rank cut-off the normal equations use at least: their singular values carry absolute
/// errors of ~√(pε)·σ₁ ≈ 1e-7·σ₁ (structural zeros of the Panda's design come out at
/// 1e-9 … 1e-8), so only values well above that are told apart from zero.
pub const NORMAL_EQUATIONS_RANK_RTOL: f64 = 1e-6;

/// Singular values (relative to σ₁) the normal equations produce for exactly rank-deficient
/// designs: about √(pε) at most (measured on the Panda: 4e-10 … 8e-9). A dropped singular
/// value above this is probably real, and [`SolveMethod::Auto`] then re-reads through QR.
pub const NORMAL_EQUATIONS_ROUNDING_FLOOR: f64 = 1e-7;

/// Options of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct IdentifyOptions {
    /// Standard deviation of the measurement noise per axis `[dx, dy, dz, rx, ry, rz]`
    /// (m, m, m, rad, rad, rad). Rows are divided by these (weighted least squares). Only
    /// ratios matter unless `noise_scale_known`.
    pub noise_sigma: [f64; 6],
    /// `true`: `noise_sigma` are the true standard deviations (σ² = 1 after whitening);
    /// `false`: the common scale is estimated from the residuals.
    pub noise_scale_known: bool,
    /// Use the measured rotations (6 rows per measurement) — requires `rotation` data.
    pub use_rotations: bool,
    /// Constrain every compliance to be ≥ 0 (under gravity: on the measurements corrected at
    /// the unconstrained refits' fixed point).
    pub nonnegative: bool,
    /// Relative singular-value cut-off of the column-scaled design for the rank.
    pub rank_rtol: f64,
    /// Threshold on null-space entries for identifiability/aliasing decisions.
    pub null_tol: f64,
    /// Normal equations, QR, or normal equations with a conditioning check (default).
    pub method: SolveMethod,
    /// The gravity the measurements were taken under (base frame), or `None` for a weightless
    /// arm (the default here; Python's `identify` and the CLI default to standard gravity,
    /// [`Gravity::default`]). With gravity the displacements are fitted about the sagged
    /// equilibrium (see [`identify`]); the chain then needs its masses
    /// ([`SerialChain::mass_model`]).
    pub gravity: Option<Gravity>,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        let s = SolveOptions::default();
        Self {
            noise_sigma: [1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5],
            noise_scale_known: false,
            use_rotations: false,
            nonnegative: false,
            rank_rtol: s.rank_rtol,
            null_tol: s.null_tol,
            method: SolveMethod::Auto,
            gravity: None,
        }
    }
}

impl IdentifyOptions {
    fn solve_options(&self) -> SolveOptions {
        SolveOptions {
            rank_rtol: self.rank_rtol,
            null_tol: self.null_tol,
            noise_scale_known: self.noise_scale_known,
            nonnegative: self.nonnegative,
            ..SolveOptions::default()
        }
    }
    fn measured(&self) -> Measured {
        if self.use_rotations {
            Measured::Full
        } else {
            Measured::Translation
        }
    }
}

/// One parameter in user-facing form (JSON-ready).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterEstimate {
    /// 1-based actuated joint index, base → tip.
    pub joint: usize,
    /// Name of the actuated joint.
    pub joint_name: String,
    /// Spring axis: `z` torsion, `x`/`y` tilt (for a translation: the direction it moves).
    pub axis: SpringAxis,
    /// Rotation (torsion, tilt) or translation (model `full`); left out of the JSON for a
    /// rotation, so the rotational models' output is as before.
    #[serde(skip_serializing_if = "SpringKind::is_rotation")]
    pub kind: SpringKind,
    /// Compliance in rad/(N·m) (a translation's in m/N), `None` when not identifiable.
    pub compliance: Option<f64>,
    /// Standard error, in the compliance's unit.
    pub stderr: Option<f64>,
    /// 95 % confidence interval.
    pub ci95: Option<(f64, f64)>,
    /// Whether the compliance is identifiable on its own.
    pub identifiable: bool,
    /// Whether the estimate is weak ([`crate::screening::is_weak`]: its standard error exceeds
    /// its magnitude or any plausible compliance); false when not identifiable alone.
    pub weak: bool,
}

/// One term of a [`Combination`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CombinationTerm {
    /// 0-based parameter index.
    pub param: usize,
    /// 1-based joint.
    pub joint: usize,
    /// Spring axis.
    pub axis: SpringAxis,
    /// Rotation or translation (left out of the JSON for a rotation).
    #[serde(skip_serializing_if = "SpringKind::is_rotation")]
    pub kind: SpringKind,
    /// Coefficient: the ratio of the independent parameter's unit to this one's
    /// (dimensionless between two rotations or two translations; m/rad for a translation in
    /// a rotation's combination).
    pub coefficient: f64,
}

impl ParameterEstimate {
    /// The spring's label: `J3x` (rotation), `J3tx` (translation).
    pub fn label(&self) -> String {
        spring_of(self.joint, self.axis, self.kind).to_string()
    }
}

impl CombinationTerm {
    /// The spring's label: `J3x` (rotation), `J3tx` (translation).
    pub fn label(&self) -> String {
        spring_of(self.joint, self.axis, self.kind).to_string()
    }
}

/// The spring at 1-based `joint`.
fn spring_of(joint: usize, axis: SpringAxis, kind: SpringKind) -> crate::model::Spring {
    crate::model::Spring {
        joint: joint.saturating_sub(1),
        axis,
        kind,
    }
}

/// An identifiable linear combination of compliances (a base parameter):
/// `c_indep + Σ β c_dep`, rad/(N·m).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Combination {
    /// Human-readable form, e.g. `J1y + 1.000000*J2z`.
    pub label: String,
    /// The terms; the first is the independent parameter with coefficient 1.
    pub terms: Vec<CombinationTerm>,
    /// Estimated value.
    pub value: f64,
    /// Standard error.
    pub stderr: Option<f64>,
    /// 95 % confidence interval.
    pub ci95: Option<(f64, f64)>,
    /// Whether the estimate is weak ([`crate::screening::is_weak`]).
    pub weak: bool,
}

/// The result of [`identify`], ready for `serde_json`.
#[derive(Debug, Clone, Serialize)]
pub struct Identification {
    /// Model name (`traditional`, `extended`, `custom`).
    pub model: String,
    /// Number of parameters m.
    pub n_params: usize,
    /// Numerical rank (number of identifiable combinations).
    pub rank: usize,
    /// Number of scalar equations used.
    pub n_equations: usize,
    /// Per parameter (model order): compliance rad/(N·m), `None` when not identifiable.
    pub compliance: Vec<Option<f64>>,
    /// Per parameter: standard error.
    pub stderr: Vec<Option<f64>>,
    /// Per parameter: 95 % interval.
    pub ci95: Vec<Option<(f64, f64)>>,
    /// Per parameter: identifiable alone.
    pub identifiable: Vec<bool>,
    /// Per parameter, user-facing.
    pub parameters: Vec<ParameterEstimate>,
    /// The `rank` base parameters.
    pub combinations: Vec<Combination>,
    /// Groups of parameter indices that alias each other.
    pub aliases: Vec<Vec<usize>>,
    /// The same groups as labels (`J1y`, ...).
    pub alias_labels: Vec<Vec<String>>,
    /// RMS of the whitened residuals (dimensionless; ≈ 1 when `noise_sigma` is right).
    pub residual_rms: f64,
    /// σ² used for the standard errors.
    pub sigma2: Option<f64>,
    /// Singular values of the column-scaled, whitened design, descending.
    pub singular_values: Vec<f64>,
    /// σ_1/σ_r of the column-scaled design over its identifiable part.
    pub condition_number: f64,
    /// The reduction that produced this result: `normal_equations` or `qr` (never `auto`).
    pub method: SolveMethod,
    /// Refits about the sagged equilibrium under [`IdentifyOptions::gravity`] after the
    /// weightless fit; 0 for a weightless identification.
    pub gravity_iterations: usize,
    /// The low-level solution (null space, covariance).
    #[serde(skip)]
    pub solution: RankRevealingSolution,
}

/// Identifies the spring compliances from N measurements, streaming: the regressor is
/// never stored; rows are folded, per rayon task, into a Gram matrix or a triangular factor
/// (see [`SolveMethod`]) that are merged at the end. Memory is O(m²) per thread whatever N.
///
/// Inputs (row-major, base frame, SI): `q` N×n (rad), `wrench` N×6 (N, N·m, at the tip
/// point), `displacement` N×3 (m), `rotation` N×3 (rad, small rotation vector) or `None`.
///
/// With [`IdentifyOptions::gravity`] the displacements are (loaded − unloaded), both at the
/// static equilibrium under the arm's weight: the weightless fit is refitted about the sagged
/// equilibrium, the Jacobian at the sag and gravity's stiffness coupling into the load's
/// torque at the current estimate, until the compliances change by ≤ [`GRAVITY_TOLERANCE`]
/// (at most [`MAX_GRAVITY_REFITS`] refits, else an error); the result's
/// `gravity_iterations` counts them. One more pass over the data per refit, one copy of the
/// displacements.
pub fn identify(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
) -> Result<Identification, VjmError> {
    // Without a row check nothing abandons the pass, so `None` cannot happen.
    identify_inner(chain, model, data, opts, None)?.ok_or_else(|| VjmError::Numerical {
        message: "the identification was abandoned without a row check".into(),
    })
}

/// A check of input rows `[start, end)` that [`identify_checking_rows`] fuses into its pass.
pub type RowCheck<'a> = &'a (dyn Fn(usize, usize) -> bool + Sync);

/// [`identify`] with a check of the input rows fused into its pass over the data:
/// `rows_ok(start, end)` is called on each chunk of rows just before the chunk is read, so
/// that the data are read from memory once (a separate checking pass over 10⁶ rows costs a
/// third of the identification). `Ok(None)` when it returned `false` for some chunk: the
/// identification is abandoned and the caller reports what is wrong. Streaming QR
/// (`SolveMethod::Qr`) checks every chunk first, then identifies.
pub fn identify_checking_rows(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
    rows_ok: RowCheck<'_>,
) -> Result<Option<Identification>, VjmError> {
    identify_inner(chain, model, data, opts, Some(rows_ok))
}

fn identify_inner(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
    rows_ok: Option<RowCheck<'_>>,
) -> Result<Option<Identification>, VjmError> {
    let Some(gravity) = opts.gravity else {
        return identify_pass(chain, model, data, opts, rows_ok);
    };
    // Before any pass: a chain without masses is refused naming the link.
    let weight = GravityWorkspace::new(chain, model, &gravity, None)?;
    let weightless = IdentifyOptions {
        gravity: None,
        ..*opts
    };
    // The first pass checks the rows; the refits read the same rows again.
    let Some(first) = identify_pass(chain, model, data, &unconstrained(&weightless), rows_ok)?
    else {
        return Ok(None);
    };
    refit_under_gravity(chain, &data, &weightless, &weight, first, |d, r, o| {
        let corrected = Measurements {
            displacement: d,
            rotation: r,
            ..data
        };
        identify_pass(chain, model, corrected, o, None)?.ok_or_else(|| VjmError::Numerical {
            message: "the identification was abandoned without a row check".into(),
        })
    })
    .map(Some)
}

/// Refits of the identification under gravity before [`identify`] gives up.
pub const MAX_GRAVITY_REFITS: usize = 20;

/// The refits under gravity stop when no compliance changes by more than this times the
/// largest compliance.
pub const GRAVITY_TOLERANCE: f64 = 1e-10;

/// The identification under gravity from the weightless one, `first`.
///
/// Under gravity a measurement (loaded − unloaded, both at the static equilibrium under the
/// weight) records `y = J(θ₀) C τ_eff`: the Jacobian at the sagged pose θ₀ = C τ₀ (where the
/// reference was taken), and the load's torque there plus gravity's coupling,
/// `τ_eff = τ + K_G Δθ` ([`GravityWorkspace::sag`], [`GravityWorkspace::effective_torques`]).
/// It is linear in C for given θ₀ and τ_eff but the weightless fit `fit` models `J(0) C τ(0)`,
/// so each refit fits `y' = y − (J(θ₀) C_k τ_eff − J(0) C_k τ(0))`, the measurements less
/// gravity's part at the current estimate C_k: its fixed point fits `y = J(θ₀) C τ_eff`
/// exactly, and the refits contract with the ratio of the sag and of ‖C K_G‖ to 1 (≈ 1e-2 on
/// an arm), a few refits to [`GRAVITY_TOLERANCE`]. Memory: one corrected copy of the
/// displacements (and rotations when used).
///
/// The refits are unconstrained fits; a non-negative fit (`opts.nonnegative`) is made once, on
/// the measurements corrected at the refits' fixed point. Non-negative least squares is not a
/// smooth map of the data: on a rank-deficient model it returns a vertex of its face of
/// minimisers (the Panda's J1y and J2z, one axis through one point, trade their shares), and
/// weakly determined springs at their bound enter and leave its active set from one refit to
/// the next, so refitting it never settled (`nonnegative_fits_settle_under_gravity`). `first`
/// is the unconstrained weightless fit; `fit` fits corrected measurements with the options
/// given.
fn refit_under_gravity(
    chain: &SerialChain,
    data: &Measurements<'_>,
    opts: &IdentifyOptions,
    weight: &GravityWorkspace,
    first: Identification,
    fit: impl Fn(&[f64], Option<&[f64]>, &IdentifyOptions) -> Result<Identification, VjmError>,
) -> Result<Identification, VjmError> {
    let free = unconstrained(opts);
    let rotation = data.rotation.filter(|_| opts.use_rotations);
    let mut displacement = data.displacement.to_vec();
    let mut rot = rotation.map(<[f64]>::to_vec);
    // The rows the refits correct: the rotations only when they are used.
    let measured = data.with_rotation(rotation);
    // Gravity's part is non-linear in C: evaluated at what the data determine, not at the
    // noise of directions they barely see (±0.15 rad/(N·m) on an xArm7's 21 springs, a sag
    // that diverges). Decided once, from the weightless fit, so the refits iterate one map.
    let weak = first.solution.weak_directions()?;
    let mut c = weak.determined(&first.solution.solution);
    let mut change = f64::INFINITY;
    for refit in 1..=MAX_GRAVITY_REFITS {
        correct_for_gravity(
            chain,
            &measured,
            weight,
            &c,
            refit,
            &mut displacement,
            rot.as_deref_mut(),
        )?;
        let mut next = fit(&displacement, rot.as_deref(), &free)?;
        next.gravity_iterations = refit;
        let c_next = weak.determined(&next.solution.solution);
        let scale = c_next.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let step = c_next
            .iter()
            .zip(&c)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        if step <= GRAVITY_TOLERANCE * scale {
            if !opts.nonnegative {
                return Ok(next);
            }
            let mut bounded = fit(&displacement, rot.as_deref(), opts)?;
            bounded.gravity_iterations = refit;
            return Ok(bounded);
        }
        c = c_next;
        change = step / scale;
    }
    Err(VjmError::Numerical {
        message: format!(
            "the identification under gravity did not settle in {MAX_GRAVITY_REFITS} refits: \
             the compliances still changed by {} of their size in the last (springs too soft \
             to hold the arm under its weight, or the wrong gravity vector or masses?)",
            stiffness_core::num::Short(change)
        ),
    })
}

/// `opts` without the non-negativity constraint (the refits under gravity).
fn unconstrained(opts: &IdentifyOptions) -> IdentifyOptions {
    IdentifyOptions {
        nonnegative: false,
        ..*opts
    }
}

/// Per-thread scratch of [`correct_for_gravity`].
#[derive(Clone)]
struct GravityRowScratch {
    ws: Workspace,
    weight: GravityWorkspace,
    jac0: Vec<f64>,
    jac: Vec<f64>,
    tau0: Vec<f64>,
    tau: Vec<f64>,
    effective: Vec<f64>,
    preload: Vec<f64>,
}

/// Writes the measurements less gravity's part at compliances `c` (see
/// [`refit_under_gravity`]) into `displacement` (N×3) and `rotation` (N×3, when rotations are
/// used: `data` has them exactly then), chunk by chunk over rayon tasks. `refit` numbers the
/// refit in errors.
fn correct_for_gravity(
    chain: &SerialChain,
    data: &Measurements<'_>,
    weight: &GravityWorkspace,
    c: &[f64],
    refit: usize,
    displacement: &mut [f64],
    rotation: Option<&mut [f64]>,
) -> Result<(), VjmError> {
    let measured_rotation = data.rotation;
    let model = weight.model();
    let m = model.n_params();
    let n = chain.n_joints();
    let scratch = GravityRowScratch {
        ws: Workspace::new(chain, model)?,
        weight: weight.clone(),
        jac0: vec![0.0; 6 * m],
        jac: vec![0.0; 6 * m],
        tau0: vec![0.0; m],
        tau: vec![0.0; m],
        effective: vec![0.0; m],
        preload: vec![0.0; m],
    };
    let rows_per = if measured_rotation.is_some() { 6 } else { 3 };
    let n_chunks = displacement.len().div_ceil(3 * CHUNK);
    let mut rot_chunks: Vec<Option<&mut [f64]>> = match rotation {
        Some(r) => r.chunks_mut(3 * CHUNK).map(Some).collect(),
        None => (0..n_chunks).map(|_| None).collect(),
    };
    let at_row = |i: usize| {
        move |e: VjmError| match e {
            VjmError::Numerical { message } => VjmError::Numerical {
                message: format!("row {i}, under gravity (refit {refit}): {message}"),
            },
            other => other,
        }
    };
    displacement
        .par_chunks_mut(3 * CHUNK)
        .zip(rot_chunks.par_iter_mut())
        .enumerate()
        .try_for_each_init(
            || scratch.clone(),
            |s, (chunk, (d, r))| -> Result<(), VjmError> {
                let start = chunk * CHUNK;
                for local in 0..d.len() / 3 {
                    let i = start + local;
                    let qi = &data.q[i * n..(i + 1) * n];
                    let f = &data.wrench[6 * i..6 * i + 6];
                    s.ws.evaluate(chain, qi);
                    s.ws.write_jacobian(&mut s.jac0);
                    s.jac.copy_from_slice(&s.jac0);
                    let mut tip = s.ws.p;
                    let mut tip_rotation = s.ws.tip_rotation(chain);
                    s.weight.evaluate(chain, qi).map_err(at_row(i))?;
                    let frame = RowFrame {
                        jacobian: &mut s.jac,
                        tip: &mut tip,
                        tip_rotation: &mut tip_rotation,
                    };
                    s.weight
                        .sagged_load(c, frame, f, &mut s.preload, &mut s.tau, &mut s.effective)
                        .map_err(at_row(i))?;
                    for k in 0..m {
                        let c0 = &s.jac0[6 * k..6 * k + 6];
                        s.tau0[k] = (0..6).map(|a| c0[a] * f[a]).sum();
                    }
                    for row in 0..rows_per {
                        let shift: f64 = (0..m)
                            .map(|k| {
                                c[k] * (s.jac[6 * k + row] * s.effective[k]
                                    - s.jac0[6 * k + row] * s.tau0[k])
                            })
                            .sum();
                        if row < 3 {
                            d[3 * local + row] = data.displacement[3 * i + row] - shift;
                        } else if let (Some(r), Some(measured)) =
                            (r.as_deref_mut(), measured_rotation)
                        {
                            r[3 * local + row - 3] = measured[3 * i + row - 3] - shift;
                        }
                    }
                }
                Ok(())
            },
        )
}

fn identify_pass(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
    rows_ok: Option<RowCheck<'_>>,
) -> Result<Option<Identification>, VjmError> {
    let Measurements {
        q,
        wrench,
        displacement,
        rotation,
    } = data;
    if opts.method == SolveMethod::Qr {
        if let Some(check) = rows_ok {
            let rows = q.len() / chain.n_joints().max(1);
            let ok = (0..rows.div_ceil(CHUNK))
                .into_par_iter()
                .all(|c| check(c * CHUNK, ((c + 1) * CHUNK).min(rows)));
            if !ok {
                return Ok(None);
            }
        }
        let factor = accumulate(chain, model, data, opts)?;
        return finish(chain, model, &factor, opts, SolveMethod::Qr).map(Some);
    }
    let inputs = validate_inner(chain, model, data, opts, false)?;
    let Some(gram) = accumulate_gram(chain, model, data, &inputs, rows_ok) else {
        return Ok(None);
    };
    if !gram.iter().all(|v| v.is_finite()) {
        // A non-finite input, reported with its row and column; otherwise finite values so
        // large that squares of whitened rows overflow (> 1e154), which no reduction here
        // survives (the QR's Householder norms square them too).
        check_all_finite(q, chain.n_joints(), wrench, displacement, rotation, opts)?;
        return Err(VjmError::Numerical {
            message: "the whitened measurements overflow when squared (|value / noise_sigma| > 1e154): check the units of displacement, wrench and noise_sigma".into(),
        });
    }
    let factor = lsq::factor_from_gram(
        model.n_params() + 1,
        &gram,
        inputs.rows * inputs.measured.rows(),
    )?;
    let mut ne_opts = *opts;
    ne_opts.rank_rtol = opts.rank_rtol.max(NORMAL_EQUATIONS_RANK_RTOL);
    let id = finish(
        chain,
        model,
        &factor,
        &ne_opts,
        SolveMethod::NormalEquations,
    )?;
    // Kept: well conditioned (false for NaN), and every dropped singular value at the
    // rounding floor of the Gram matrix rather than in the band a QR could still resolve.
    let s1 = id.singular_values.first().copied().unwrap_or(0.0);
    let trusted = id.condition_number <= NORMAL_EQUATIONS_MAX_CONDITION
        && id.singular_values[id.rank..]
            .iter()
            .all(|&s| s <= NORMAL_EQUATIONS_ROUNDING_FLOOR * s1);
    if opts.method == SolveMethod::Auto && !trusted {
        let factor = accumulate(chain, model, data, opts)?;
        return finish(chain, model, &factor, opts, SolveMethod::Qr).map(Some);
    }
    Ok(Some(id))
}

/// The whitened Gram matrix `[A b]ᵀ[A b]` ((m+1)×(m+1), row-major) of validated inputs,
/// lane-wise over rayon tasks; `None` when `rows_ok` refused a chunk (checked just before the
/// chunk is read).
fn accumulate_gram(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    inputs: &Inputs,
    rows_ok: Option<RowCheck<'_>>,
) -> Option<Vec<f64>> {
    let lanes = ChainLanes::new(chain, model);
    let problem = GramProblem {
        chain: &lanes,
        q: data.q,
        wrench: data.wrench,
        displacement: data.displacement,
        rotation: if inputs.measured == Measured::Full {
            data.rotation
        } else {
            None
        },
        rows: inputs.measured.rows(),
        inv_sigma: inputs.inv_sigma,
    };
    let p = model.n_params() + 1;
    let n_chunks = inputs.rows.div_ceil(CHUNK);
    // Chunk sums are collected in chunk order and added in that order, not reduced in
    // whatever tree rayon's work stealing builds: the result is then the same bits on every
    // run (for a given instruction set), which the normal equations' κ² sensitivity would
    // otherwise turn into run-to-run differences of ~1e-12. 245 chunks × p² values at N = 1e6.
    let chunks: Option<Vec<Vec<f64>>> = (0..n_chunks)
        .into_par_iter()
        .map(|c| {
            let (start, end) = (c * CHUNK, ((c + 1) * CHUNK).min(inputs.rows));
            rows_ok
                .is_none_or(|check| check(start, end))
                .then(|| gram_range(&problem, start, end))
        })
        .collect();
    let mut gram = vec![0.0; p * p];
    for chunk in &chunks? {
        for (x, y) in gram.iter_mut().zip(chunk) {
            *x += y;
        }
    }
    Some(gram)
}

/// The same as [`identify`] through the dense path: builds the whole whitened design
/// ([`build_design`]) and factors it with faer's QR. For checking and small problems. Under
/// gravity the same refits as [`identify`]'s, each a dense solve.
pub fn identify_dense(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
) -> Result<Identification, VjmError> {
    let weightless = IdentifyOptions {
        gravity: None,
        ..*opts
    };
    let weight = opts
        .gravity
        .map(|g| GravityWorkspace::new(chain, model, &g, None))
        .transpose()?;
    let fit = |d: &[f64], r: Option<&[f64]>, o: &IdentifyOptions| {
        let rows = Measurements {
            displacement: d,
            rotation: r,
            ..data
        };
        let (design, rhs) = build_design(chain, model, rows, o)?;
        let factor = lsq::dense_factor(&design, rhs.len(), model.n_params(), &rhs)?;
        finish(chain, model, &factor, o, SolveMethod::Qr)
    };
    let Some(weight) = weight else {
        return fit(data.displacement, data.rotation, &weightless);
    };
    let first = fit(
        data.displacement,
        data.rotation,
        &unconstrained(&weightless),
    )?;
    refit_under_gravity(chain, &data, &weightless, &weight, first, fit)
}

/// [`accumulate`], [`build_design`] and [`identify_from_factor`] are the weightless, linear
/// problem: under gravity the design depends on the compliances ([`identify`] refits).
fn refuse_gravity(opts: &IdentifyOptions, function: &str) -> Result<(), VjmError> {
    match opts.gravity {
        None => Ok(()),
        Some(_) => Err(VjmError::InvalidOption {
            name: "gravity",
            message: format!(
                "{function} builds the weightless (linear) problem; under gravity the design \
                 depends on the compliances: use identify or identify_dense, or set gravity to None"
            ),
        }),
    }
}

/// Solves from an accumulated factor (e.g. one merged from several batches). Weightless only:
/// an error for [`IdentifyOptions::gravity`] set.
pub fn identify_from_factor(
    chain: &SerialChain,
    model: &VirtualJointModel,
    factor: &TriangularFactor,
    opts: &IdentifyOptions,
) -> Result<Identification, VjmError> {
    refuse_gravity(opts, "identify_from_factor")?;
    model.check_chain(chain)?;
    if factor.ncols() != model.n_params() + 1 {
        return Err(VjmError::ShapeMismatch {
            what: "factor columns (m + 1)",
            expected: model.n_params() + 1,
            got: factor.ncols(),
        });
    }
    finish(chain, model, factor, opts, SolveMethod::Qr)
}

struct Inputs {
    rows: usize,
    measured: Measured,
    inv_sigma: [f64; 6],
}

fn validate(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
) -> Result<Inputs, VjmError> {
    validate_inner(chain, model, data, opts, true)
}

/// Every input value finite, or an error naming the first bad row and column.
fn check_all_finite(
    q: &[f64],
    n: usize,
    wrench: &[f64],
    displacement: &[f64],
    rotation: Option<&[f64]>,
    opts: &IdentifyOptions,
) -> Result<(), VjmError> {
    let all_finite = |what: &'static str, data: &[f64], cols: usize| -> Result<(), VjmError> {
        if data.iter().all(|v| v.is_finite()) {
            return Ok(());
        }
        for (i, row) in data.chunks_exact(cols).enumerate() {
            check_finite(what, row, i, 0)?;
        }
        Ok(())
    };
    all_finite("q", q, n)?;
    all_finite("wrench", wrench, 6)?;
    all_finite("displacement", displacement, 3)?;
    if let (true, Some(rot)) = (opts.use_rotations, rotation) {
        all_finite("rotation", rot, 3)?;
    }
    Ok(())
}

/// Shapes and options; the values too when `check_values` (the normal-equations path
/// skips that pass over the data: a non-finite value makes the Gram matrix non-finite, and
/// only then are the values searched for the row and column to report).
fn validate_inner(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
    check_values: bool,
) -> Result<Inputs, VjmError> {
    let Measurements {
        q,
        wrench,
        displacement,
        rotation,
    } = data;
    model.check_chain(chain)?;
    let n = chain.n_joints();
    for (i, s) in opts.noise_sigma.iter().enumerate() {
        if !(s.is_finite() && *s > 0.0) {
            return Err(VjmError::InvalidOption {
                name: "noise_sigma",
                message: format!(
                    "entry {i} must be finite and > 0, got {}",
                    stiffness_core::num::Short(*s)
                ),
            });
        }
    }
    if !q.len().is_multiple_of(n) || q.is_empty() {
        return Err(VjmError::ShapeMismatch {
            what: "q (N×n row-major, n = number of joints)",
            expected: (q.len() / n).max(1) * n,
            got: q.len(),
        });
    }
    let rows = q.len() / n;
    let check_len = |what: &'static str, data: &[f64], cols: usize| {
        if data.len() != rows * cols {
            Err(VjmError::ShapeMismatch {
                what,
                expected: rows * cols,
                got: data.len(),
            })
        } else {
            Ok(())
        }
    };
    check_len("wrench (N×6)", wrench, 6)?;
    check_len("displacement (N×3)", displacement, 3)?;
    if opts.use_rotations {
        let Some(rot) = rotation else {
            return Err(VjmError::InvalidOption {
                name: "use_rotations",
                message: "is true but no rotation data (N×3) was given".into(),
            });
        };
        check_len("rotation (N×3)", rot, 3)?;
    }
    if check_values {
        check_all_finite(q, n, wrench, displacement, rotation, opts)?;
    }
    let measured = opts.measured();
    let m = model.n_params();
    let have = rows * measured.rows();
    if have < m {
        return Err(VjmError::TooFewMeasurements {
            have,
            need: m,
            why: format!(
                "{rows} measurements × {} rows each; the {} model has {m} parameters",
                measured.rows(),
                model.name()
            ),
        });
    }
    let mut inv_sigma = [0.0; 6];
    for (o, s) in inv_sigma.iter_mut().zip(&opts.noise_sigma) {
        *o = 1.0 / s;
    }
    Ok(Inputs {
        rows,
        measured,
        inv_sigma,
    })
}

/// Measurements per rayon task: large enough to amortise the task and the final merge,
/// small enough to balance two cores.
const CHUNK: usize = 4096;

/// The streaming factor of the whitened `[A b]` (see [`identify`]). Weightless only: an error
/// for [`IdentifyOptions::gravity`] set (the design then depends on the compliances).
pub fn accumulate(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
) -> Result<TriangularFactor, VjmError> {
    refuse_gravity(opts, "accumulate")?;
    let inputs = validate(chain, model, data, opts)?;
    let (q, wrench) = (data.q, data.wrench);
    let ws0 = Workspace::new(chain, model)?;
    let m = model.n_params();
    let n = chain.n_joints();
    let n_chunks = inputs.rows.div_ceil(CHUNK);
    let acc = (0..n_chunks)
        .into_par_iter()
        .fold(
            || (ws0.clone(), TriangularAccumulator::new(m + 1), vec![0.0; m]),
            |(mut ws, mut acc, mut g), c| {
                let end = ((c + 1) * CHUNK).min(inputs.rows);
                for i in c * CHUNK..end {
                    ws.evaluate(chain, &q[i * n..(i + 1) * n]);
                    let f = &wrench[i * 6..i * 6 + 6];
                    push_measurement(&mut ws, &mut acc, &mut g, f, i, &data, &inputs);
                }
                (ws, acc, g)
            },
        )
        .map(|(_, acc, _)| acc)
        .reduce_with(|mut a, b| {
            // Same column count by construction.
            let _ = a.merge(b);
            a
        })
        .unwrap_or_else(|| TriangularAccumulator::new(m + 1));
    Ok(acc.finish())
}

#[inline]
fn push_measurement(
    ws: &mut Workspace,
    acc: &mut TriangularAccumulator,
    g: &mut [f64],
    f: &[f64],
    i: usize,
    data: &Measurements<'_>,
    inputs: &Inputs,
) {
    let mut jac = std::mem::take(&mut ws.jac);
    ws.write_jacobian(&mut jac);
    for (k, gk) in g.iter_mut().enumerate() {
        let col = &jac[6 * k..6 * k + 6];
        *gk = col[0] * f[0]
            + col[1] * f[1]
            + col[2] * f[2]
            + col[3] * f[3]
            + col[4] * f[4]
            + col[5] * f[5];
    }
    for r in 0..inputs.measured.rows() {
        let rhs = if r < 3 {
            data.displacement[3 * i + r]
        } else {
            data.rotation.map_or(0.0, |rot| rot[3 * i + r - 3])
        };
        acc.push_product_row(
            inputs.inv_sigma[r],
            jac.iter().skip(r).step_by(6).copied(),
            g,
            rhs,
        );
    }
    ws.jac = jac;
}

/// The whitened dense design (row-major, (N·rows)×m) and right-hand side of the
/// identification problem: row (i, r) is `A_i[r, :]/σ_r` and `Δx_i[r]/σ_r`. Weightless only
/// (an error for [`IdentifyOptions::gravity`] set).
pub fn build_design(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: Measurements<'_>,
    opts: &IdentifyOptions,
) -> Result<(Vec<f64>, Vec<f64>), VjmError> {
    refuse_gravity(opts, "build_design")?;
    let inputs = validate(chain, model, data, opts)?;
    let Measurements {
        q,
        wrench,
        displacement,
        rotation,
    } = data;
    let mut ws = Workspace::new(chain, model)?;
    let m = model.n_params();
    let n = chain.n_joints();
    let rpm = inputs.measured.rows();
    let mut design = vec![0.0; inputs.rows * rpm * m];
    let mut rhs = vec![0.0; inputs.rows * rpm];
    let mut block = vec![0.0; rpm * m];
    for i in 0..inputs.rows {
        let mut f = [0.0; 6];
        f.copy_from_slice(&wrench[i * 6..i * 6 + 6]);
        crate::regressor::regressor_rows(
            chain,
            model,
            &q[i * n..(i + 1) * n],
            &f,
            inputs.measured,
            &mut ws,
            &mut block,
        )?;
        for r in 0..rpm {
            let row = i * rpm + r;
            let s = inputs.inv_sigma[r];
            for k in 0..m {
                design[row * m + k] = block[r * m + k] * s;
            }
            let y = if r < 3 {
                displacement[3 * i + r]
            } else {
                rotation.map_or(0.0, |rot| rot[3 * i + r - 3])
            };
            rhs[row] = y * s;
        }
    }
    Ok((design, rhs))
}

fn finish(
    chain: &SerialChain,
    model: &VirtualJointModel,
    factor: &TriangularFactor,
    opts: &IdentifyOptions,
    method: SolveMethod,
) -> Result<Identification, VjmError> {
    let sol = lsq::solve_factor(factor, &opts.solve_options())?;
    let t = student_t_975(if opts.noise_scale_known {
        usize::MAX
    } else {
        sol.dof
    });
    let t = if opts.noise_scale_known {
        Some(1.959_963_984_540_054)
    } else {
        t
    };
    let ci = |v: Option<f64>, s: Option<f64>| match (v, s, t) {
        (Some(v), Some(s), Some(t)) => Some((v - t * s, v + t * s)),
        _ => None,
    };
    let labels = model.labels();
    let springs = model.springs();
    let ci95: Vec<_> = (0..sol.n_params)
        .map(|k| ci(sol.estimate[k], sol.stderr[k]))
        .collect();
    let parameters = springs
        .iter()
        .enumerate()
        .map(|(k, s)| ParameterEstimate {
            joint: s.joint + 1,
            joint_name: chain.joint_names()[s.joint].clone(),
            axis: s.axis,
            kind: s.kind,
            compliance: sol.estimate[k],
            stderr: sol.stderr[k],
            ci95: ci95[k],
            identifiable: sol.identifiable[k],
            weak: sol.estimate[k].is_some_and(|v| crate::screening::is_weak(v, sol.stderr[k])),
        })
        .collect();
    let combinations = sol
        .combinations
        .iter()
        .map(|c| {
            let terms: Vec<CombinationTerm> = c
                .terms
                .iter()
                .map(|&(param, coefficient)| CombinationTerm {
                    param,
                    joint: springs[param].joint + 1,
                    axis: springs[param].axis,
                    kind: springs[param].kind,
                    coefficient,
                })
                .collect();
            let mut label = labels[c.terms[0].0].clone();
            for &(p, coef) in &c.terms[1..] {
                let sign = if coef < 0.0 { '-' } else { '+' };
                label.push_str(&format!(" {sign} {:.6}*{}", coef.abs(), labels[p]));
            }
            Combination {
                label,
                terms,
                value: c.value,
                stderr: c.stderr,
                ci95: ci(Some(c.value), c.stderr),
                weak: crate::screening::is_weak(c.value, c.stderr),
            }
        })
        .collect();
    let alias_labels = sol
        .aliases
        .iter()
        .map(|g| g.iter().map(|&k| labels[k].clone()).collect())
        .collect();
    let condition_number = if sol.rank > 0 {
        sol.singular_values[0] / sol.singular_values[sol.rank - 1]
    } else {
        f64::INFINITY
    };
    Ok(Identification {
        model: model.name().to_string(),
        n_params: sol.n_params,
        rank: sol.rank,
        n_equations: sol.n_equations,
        compliance: sol.estimate.clone(),
        stderr: sol.stderr.clone(),
        ci95,
        identifiable: sol.identifiable.clone(),
        parameters,
        combinations,
        aliases: sol.aliases.clone(),
        alias_labels,
        residual_rms: (sol.rss / sol.n_equations.max(1) as f64).sqrt(),
        sigma2: sol.sigma2,
        singular_values: sol.singular_values.clone(),
        condition_number,
        method,
        gravity_iterations: 0,
        solution: sol,
    })
}
