//! The serial arm as a [`Problem`] of the shared diagnosis engine: its terms (springs,
//! catalogue candidates, lack-of-fit blocks), the whitening of each row, and the pass that
//! compresses the whitened design.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use nalgebra::{Matrix3, Vector3};
use stiffness_core::engine::{Compressed, CompressedAccumulator, Fit, Problem, RowSet};
use stiffness_core::{Cancel, Cancelled, Progress};

use super::candidates::{
    candidate_columns, compliance_map3x6, spring_column, Alternative, Candidate, Linearisation,
    RowKinematics,
};
use super::rows::{RowBuilder, ROW_BATCH};
use crate::chain::SerialChain;
use crate::dataset::{Dataset, SetLabel};
use crate::gravity::GravityWorkspace;
use crate::model::SpringAxis;

/// One term of a model: a linear spring (index into the 3n springs, joint-major `[z, x, y]`),
/// a catalogue candidate, or a block of the lack-of-fit alternative.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Term {
    /// A linear virtual spring.
    Spring(usize),
    /// A candidate extension.
    Cand(Candidate),
    /// A block of the lack-of-fit alternative.
    Alt(Alternative),
}

/// Rows polled between two cancellation checks.
const CANCEL_EVERY: usize = 4096;
/// Compressed designs kept (one per linearisation point met).
const CACHE: usize = 16;

/// The noise the whitening assumes: tracker noise plus the force-sensor noise propagated
/// through the compliance `propagate` (`Σ_i = σ_d² I + G Σ_W Gᵀ`, `G = J_t |C| Jᵀ`).
#[derive(Debug, Clone)]
pub struct Whitening {
    /// Per-axis displacement standard deviation, m.
    pub displacement_sigma: f64,
    /// Per-axis wrench standard deviation, N and N·m.
    pub wrench_sigma: [f64; 6],
    /// |compliance| (3n) the wrench noise is propagated through.
    pub propagate_abs: Vec<f64>,
}

impl Whitening {
    /// `(L⁻¹, √diag Σ)` for a row, with `Σ = L Lᵀ`. Written out for 3×3 (the sum of the six
    /// rank-one terms `σ_k² g_k g_kᵀ`, then Cholesky and the triangular inverse in closed form):
    /// it runs for every row of every pass. A Σ that is not positive definite (it cannot be
    /// with `σ_d > 0`, short of overflow) whitens by `1/σ_d`.
    pub fn of(&self, row: &RowKinematics) -> (Matrix3<f64>, [f64; 3]) {
        let sd = self.displacement_sigma;
        let v = sd * sd;
        // The upper triangle of Σ: s00 s01 s02 s11 s12 s22.
        let mut a = [v, 0.0, 0.0, v, 0.0, v];
        if self.wrench_sigma.iter().any(|s| *s != 0.0) {
            let g = compliance_map3x6(row, &self.propagate_abs);
            for (k, s) in self.wrench_sigma.iter().enumerate() {
                let w = s * s;
                let (g0, g1, g2) = (g[(0, k)], g[(1, k)], g[(2, k)]);
                a[0] += w * g0 * g0;
                a[1] += w * g0 * g1;
                a[2] += w * g0 * g2;
                a[3] += w * g1 * g1;
                a[4] += w * g1 * g2;
                a[5] += w * g2 * g2;
            }
        }
        let sigma = [a[0].sqrt(), a[3].sqrt(), a[5].sqrt()];
        let fallback = (Matrix3::identity() / sd, sigma);
        let l00 = a[0].sqrt();
        if !(l00 > 0.0 && l00.is_finite()) {
            return fallback;
        }
        let l10 = a[1] / l00;
        let l20 = a[2] / l00;
        let d11 = a[3] - l10 * l10;
        if !(d11 > 0.0 && d11.is_finite()) {
            return fallback;
        }
        let l11 = d11.sqrt();
        let l21 = (a[4] - l20 * l10) / l11;
        let d22 = a[5] - l20 * l20 - l21 * l21;
        if !(d22 > 0.0 && d22.is_finite()) {
            return fallback;
        }
        let l22 = d22.sqrt();
        let (m00, m11, m22) = (1.0 / l00, 1.0 / l11, 1.0 / l22);
        let m10 = -l10 * m00 * m11;
        let m21 = -l21 * m11 * m22;
        let m20 = -(l20 * m00 + l21 * m10) * m22;
        (
            Matrix3::new(m00, 0.0, 0.0, m10, m11, 0.0, m20, m21, m22),
            sigma,
        )
    }
}

/// A cached within-pose factor with what it was made for (point and columns).
type WithinEntry = (Linearisation, Vec<usize>, Arc<WithinPose>);

/// A VJM diagnosis problem: the data, the split, the whitening and the column layout.
pub struct VjmProblem<'a> {
    pub(super) chain: &'a SerialChain,
    pub(super) data: &'a Dataset<'a>,
    pub(super) labels: Vec<SetLabel>,
    pub(super) groups: Vec<usize>,
    /// RMS torsion torque per joint over the training rows, N·m: the unit of the hinge
    /// candidate's knots (empty in the springs-only pre-fit, which has no hinge columns).
    pub(super) tau_scale: Vec<f64>,
    pub(super) whitening: Whitening,
    /// Wrench noise of the backlash candidate's torque expectation (the options' value).
    pub(super) torque_noise: [f64; 6],
    /// The weight the measurements were taken under (a workspace every pass's row builder
    /// clones); `None` for a weightless diagnosis.
    pub(super) gravity: Option<GravityWorkspace>,
    /// Candidates with columns of their own (not tilts) and their column ranges.
    layout: Vec<(Candidate, Range<usize>)>,
    alternatives: Vec<(Alternative, Range<usize>)>,
    m: usize,
    y: usize,
    cache: Mutex<Vec<(Linearisation, Arc<Compressed>)>>,
    /// Within-pose factors made, by linearisation and selected columns: the verdict of an
    /// extended model whose findings are springs (tilts) needs the baseline's factor again.
    within_cache: Mutex<Vec<WithinEntry>>,
    pub(super) cancel: Cancel,
    /// Where the passes report their progress (rows done of the pass), from any thread.
    pub(super) sink: Option<&'a (dyn Fn(Progress) + Sync)>,
    /// Rows done in the current pass, over all its parts.
    rows_done: AtomicUsize,
}

impl std::fmt::Debug for VjmProblem<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VjmProblem")
            .field("rows", &self.data.len())
            .field("columns", &self.ncols())
            .field("whitening", &self.whitening)
            .finish_non_exhaustive()
    }
}

impl<'a> VjmProblem<'a> {
    /// The problem for `data` on `chain` with the split `labels`; rows are clustered by the
    /// data's pose groups ([`Dataset::pose_groups`]).
    pub fn new(
        chain: &'a SerialChain,
        data: &'a Dataset<'a>,
        labels: Vec<SetLabel>,
        tau_scale: Vec<f64>,
        whitening: Whitening,
        torque_noise: [f64; 6],
        cancel: Cancel,
    ) -> Self {
        let groups = data.pose_groups();
        let n = chain.n_joints();
        let m = 3 * n;
        let mut next = m;
        let mut layout = Vec::new();
        let all = super::candidates::catalogue(&vec![true; m])
            .into_iter()
            .chain(super::candidates::catalogue(&vec![false; m]));
        let mut seen: Vec<Candidate> = Vec::new();
        for c in all {
            if matches!(c, Candidate::JointTilt { .. }) || seen.contains(&c) {
                continue;
            }
            seen.push(c);
            layout.push((c, next..next + c.n_columns()));
            next += c.n_columns();
        }
        // The lack-of-fit blocks come after y: they are read only by the within-pose pass of a
        // verdict, not folded into the compressed design of every pass (86 → 59 columns).
        let y = next;
        let mut next = y + 1;
        let mut alternatives = Vec::new();
        for a in Alternative::IN_LAYOUT {
            alternatives.push((a, next..next + a.n_columns(n)));
            next += a.n_columns(n);
        }
        Self {
            chain,
            data,
            labels,
            groups,
            tau_scale,
            whitening,
            torque_noise,
            gravity: None,
            layout,
            alternatives,
            m,
            y,
            cache: Mutex::new(Vec::new()),
            within_cache: Mutex::new(Vec::new()),
            cancel,
            sink: None,
            rows_done: AtomicUsize::new(0),
        }
    }

    /// The same problem for measurements taken under gravity (`gravity`: a workspace for the
    /// chain's extended model).
    pub fn with_gravity(mut self, gravity: Option<GravityWorkspace>) -> Self {
        self.gravity = gravity;
        self
    }

    /// The same problem reporting the progress of its passes to `sink`.
    pub fn with_sink(mut self, sink: Option<&'a (dyn Fn(Progress) + Sync)>) -> Self {
        self.sink = sink;
        self
    }

    /// Starts a pass over the rows: its progress counts from 0.
    pub fn begin_pass(&self) {
        self.rows_done.store(0, Ordering::Relaxed);
    }

    /// The same data with another whitening (the cache is not shared).
    pub fn with_whitening(&self, whitening: Whitening) -> Self {
        Self {
            chain: self.chain,
            data: self.data,
            labels: self.labels.clone(),
            groups: self.groups.clone(),
            tau_scale: self.tau_scale.clone(),
            whitening,
            torque_noise: self.torque_noise,
            gravity: self.gravity.clone(),
            layout: self.layout.clone(),
            alternatives: self.alternatives.clone(),
            m: self.m,
            y: self.y,
            cache: Mutex::new(Vec::new()),
            within_cache: Mutex::new(Vec::new()),
            cancel: self.cancel.clone(),
            sink: self.sink,
            rows_done: AtomicUsize::new(0),
        }
    }

    /// Number of columns of the compressed design (y included, last).
    pub fn ncols(&self) -> usize {
        self.y + 1
    }

    /// Number of raw columns of a row: the compressed design's, then the lack-of-fit blocks'.
    pub fn nraw(&self) -> usize {
        self.alternatives
            .last()
            .map_or(self.ncols(), |(_, r)| r.end)
    }

    /// A row builder for this problem.
    pub fn builder(&self) -> RowBuilder<'a> {
        let builder = RowBuilder::new(self.chain, self.torque_noise);
        match &self.gravity {
            Some(g) => builder.with_gravity(g.clone()),
            None => builder,
        }
    }

    /// Raw (unwhitened) columns of one row ([`Self::nraw`]), in layout order: springs,
    /// candidates, the measured displacement y, then the lack-of-fit blocks. With `want`
    /// ([`Self::nraw`] long), a candidate or block none of whose columns is wanted gets zero
    /// columns without being computed (the geometric column is an iterative solve; the
    /// springs are always computed).
    pub fn raw_columns(
        &self,
        builder: &RowBuilder<'_>,
        row: &RowKinematics,
        lin: &Linearisation,
        want: Option<&[bool]>,
        out: &mut Vec<[f64; 3]>,
    ) {
        out.clear();
        for s in 0..self.m {
            out.push(spring_column(row, s));
        }
        let wanted = |r: &Range<usize>| want.is_none_or(|w| w[r.clone()].iter().any(|b| *b));
        for (c, r) in &self.layout {
            if wanted(r) {
                candidate_columns(builder, c, row, lin, &self.tau_scale, out);
            } else {
                out.extend(std::iter::repeat_n([0.0; 3], r.len()));
            }
        }
        out.push(row.displacement);
        for (a, r) in &self.alternatives {
            if wanted(r) {
                a.columns(row, out);
            } else {
                out.extend(std::iter::repeat_n([0.0; 3], r.len()));
            }
        }
    }

    /// The mask of the columns of `terms` (for the `want` of [`Self::for_each_row_in`]).
    pub fn mask(&self, terms: &[Term]) -> Vec<bool> {
        let mut m = vec![false; self.nraw()];
        for t in terms {
            for c in Problem::columns(self, *t) {
                m[c] = true;
            }
        }
        m
    }

    /// A problem of the springs alone (no candidate or block columns): the pre-fit that sets
    /// the force-noise propagation needs no more.
    pub fn springs_only(&self, whitening: Whitening) -> Self {
        let mut p = self.with_whitening(whitening);
        p.layout.clear();
        p.alternatives.clear();
        p.y = p.m;
        p
    }

    /// The prediction `Σ_k β_k x_k` (m, base frame) of a fit for one row from its raw
    /// columns.
    pub fn predict(&self, fit: &Fit<Term, Linearisation>, cols: &[[f64; 3]]) -> [f64; 3] {
        let mut p = [0.0; 3];
        let mut k = 0;
        for t in &fit.terms {
            for c in self.columns(*t) {
                for r in 0..3 {
                    p[r] += fit.coef[k] * cols[c][r];
                }
                k += 1;
            }
        }
        p
    }

    fn set_of(&self, i: usize) -> RowSet {
        match self.labels[i] {
            SetLabel::Train => RowSet::Train,
            SetLabel::Test => RowSet::Test,
        }
    }

    /// One pass over every row: `visit(i, row, whitening, raw columns)`; polls the cancel
    /// token every few thousand rows.
    pub fn for_each_row(
        &self,
        lin: &Linearisation,
        want: Option<&[bool]>,
        visit: impl FnMut(usize, &RowKinematics, &Matrix3<f64>, &[f64; 3], &[[f64; 3]]),
    ) -> Result<(), Cancelled> {
        self.for_each_row_in(lin, 0..self.data.len(), want, visit)
    }

    /// [`Self::for_each_row`] over the rows `range` only.
    pub fn for_each_row_in(
        &self,
        lin: &Linearisation,
        range: Range<usize>,
        want: Option<&[bool]>,
        visit: impl FnMut(usize, &RowKinematics, &Matrix3<f64>, &[f64; 3], &[[f64; 3]]),
    ) -> Result<(), Cancelled> {
        self.visit_rows(lin, range, want, false, visit)
    }

    /// [`Self::for_each_row_in`] over the training rows of `range` only (a held-out row's
    /// kinematics are not computed).
    pub fn for_each_train_row_in(
        &self,
        lin: &Linearisation,
        range: Range<usize>,
        want: Option<&[bool]>,
        visit: impl FnMut(usize, &RowKinematics, &Matrix3<f64>, &[f64; 3], &[[f64; 3]]),
    ) -> Result<(), Cancelled> {
        self.visit_rows(lin, range, want, true, visit)
    }

    fn visit_rows(
        &self,
        lin: &Linearisation,
        range: Range<usize>,
        want: Option<&[bool]>,
        train_only: bool,
        mut visit: impl FnMut(usize, &RowKinematics, &Matrix3<f64>, &[f64; 3], &[[f64; 3]]),
    ) -> Result<(), Cancelled> {
        let mut builder = self.builder();
        builder.set_linearisation(&lin.compliance);
        let mut rows: Vec<RowKinematics> = (0..ROW_BATCH).map(|_| builder.empty_row()).collect();
        let mut batch = Vec::with_capacity(ROW_BATCH);
        let mut cols = Vec::with_capacity(self.nraw());
        // The deflected equilibrium is solved for the batch when the pass wants the geometric
        // non-linearity's column.
        let deflect = self
            .layout
            .iter()
            .find(|(c, _)| *c == Candidate::GeometricNonlinearity)
            .filter(|(_, r)| want.is_none_or(|w| w[r.clone()].iter().any(|b| *b)))
            .map(|_| &lin.compliance[..]);
        let mut start = range.start;
        while start < range.end {
            let end = (start + ROW_BATCH).min(range.end);
            for i in start..end {
                if i % CANCEL_EVERY == 0 {
                    self.cancel.check()?;
                    if let Some(sink) = self.sink {
                        let n = self.data.len();
                        let done = self.rows_done.fetch_add(CANCEL_EVERY, Ordering::Relaxed);
                        sink(Progress {
                            stage: "pass over the rows",
                            done: done.min(n),
                            total: n,
                        });
                    }
                }
            }
            batch.clear();
            batch
                .extend((start..end).filter(|&i| !train_only || self.labels[i] == SetLabel::Train));
            builder.rows_into(self.data, &batch, deflect, &mut rows);
            for (&i, row) in batch.iter().zip(&rows) {
                let (w, sigma) = self.whitening.of(row);
                self.raw_columns(&builder, row, lin, want, &mut cols);
                visit(i, row, &w, &sigma, &cols);
            }
            start = end;
        }
        Ok(())
    }

    /// The compressed design of the rows `range` at `lin`, and what `extras` asks for from
    /// the same rows.
    fn compress_range(
        &self,
        lin: &Linearisation,
        range: Range<usize>,
        extras: Extras<'_>,
    ) -> Result<PartOut, Cancelled> {
        let p = self.ncols();
        let mut acc = CompressedAccumulator::new(p);
        let n_joints = self.chain.n_joints();
        let mut runs = extras
            .within
            .map(|sel| WithinRuns::new(sel.len(), n_joints));
        let mut torque_sq = vec![0.0; if extras.torque_squares { n_joints } else { 0 }];
        // The design's columns, and the within-pose selection's (which may name lack-of-fit
        // blocks, after y).
        let mut want = vec![false; self.nraw()];
        want[..p].fill(true);
        for &c in extras.within.unwrap_or(&[]) {
            want[c] = true;
        }
        let mut z = vec![Vector3::zeros(); self.nraw()];
        let mut zrow = vec![0.0; p];
        self.for_each_row_in(lin, range, Some(&want), |i, row, w, _, cols| {
            for ((zk, c), wanted) in z.iter_mut().zip(cols).zip(&want) {
                if *wanted {
                    *zk = whiten(w, c);
                }
            }
            let set = self.set_of(i);
            for r in 0..3 {
                for (dst, zk) in zrow.iter_mut().zip(&z) {
                    *dst = zk[r];
                }
                acc.push(set, &zrow).expect("rows have the layout's width");
            }
            if set == RowSet::Train {
                if let (Some(runs), Some(sel)) = (&mut runs, extras.within) {
                    runs.push(
                        self.groups[i],
                        w,
                        sel.iter().map(|&c| z[c]),
                        (0..n_joints).map(|j| z[3 * j]),
                    );
                }
                for (j, sq) in torque_sq.iter_mut().enumerate() {
                    // The gear's knots sit in the range of the total torque, preload included.
                    *sq += (row.tau_gravity[3 * j] + row.tau[3 * j]).powi(2);
                }
            }
        })?;
        Ok(PartOut {
            acc,
            runs,
            torque_sq,
        })
    }

    /// Contiguous parts of the rows, one per thread for a large pass, cut at a change of pose
    /// so that no run of a pose's rows is split between parts (the [`WithinPose`] offsets).
    fn pose_parts(&self) -> Vec<Range<usize>> {
        let n = self.data.len();
        if n < PARALLEL_ROWS {
            return std::iter::once(0..n).collect();
        }
        let mut cuts = vec![0];
        for k in 1..PARTS {
            let mut b = k * n / PARTS;
            while b < n && b > 0 && self.groups[b] == self.groups[b - 1] {
                b += 1;
            }
            cuts.push(b.max(*cuts.last().expect("non-empty")));
        }
        cuts.push(n);
        cuts.windows(2).map(|w| w[0]..w[1]).collect()
    }

    /// One pass at `lin` that makes both the compressed design and the [`WithinPose`] factor
    /// over `sel` (the baseline's verdict needs both at the baseline's point), unless both
    /// are cached already. Later calls of [`Problem::compress`] and [`Self::within_pose`]
    /// find them.
    pub fn compress_with_within(
        &self,
        lin: &Linearisation,
        sel: &[usize],
    ) -> Result<(), Cancelled> {
        if self.cached_compressed(lin).is_some() && self.cached_within(lin, sel).is_some() {
            return Ok(());
        }
        let extras = Extras {
            within: Some(sel),
            ..Extras::default()
        };
        let out = self.compress_pass(lin, extras)?;
        self.store_compressed(lin, Arc::new(out.acc.finish()));
        if let Some(runs) = out.runs {
            self.store_within(lin, sel, Arc::new(runs.finish()));
        }
        Ok(())
    }

    /// One pass at `lin` that makes the compressed design (cached for [`Problem::compress`])
    /// and returns the RMS torsion torque of each joint over the training rows, N·m (the
    /// knots of the hinge candidate; the pre-fit's pass computes the torques anyway).
    pub fn compress_with_torque_rms(&self, lin: &Linearisation) -> Result<Vec<f64>, Cancelled> {
        let extras = Extras {
            torque_squares: true,
            ..Extras::default()
        };
        let out = self.compress_pass(lin, extras)?;
        let n_train = self
            .labels
            .iter()
            .filter(|l| **l == SetLabel::Train)
            .count();
        self.store_compressed(lin, Arc::new(out.acc.finish()));
        Ok(out
            .torque_sq
            .iter()
            .map(|s| (s / n_train.max(1) as f64).sqrt())
            .collect())
    }

    /// The pass of [`Problem::compress`] with `extras`, its parts merged in row order.
    fn compress_pass(&self, lin: &Linearisation, extras: Extras<'_>) -> Result<PartOut, Cancelled> {
        self.begin_pass();
        let parts = over_parts(&self.pose_parts(), |r| self.compress_range(lin, r, extras));
        let mut it = parts.into_iter();
        let mut out = it.next().expect("at least one part")?;
        for part in it {
            let part = part?;
            out.acc.merge(part.acc).expect("parts have the same width");
            if let (Some(runs), Some(r)) = (&mut out.runs, part.runs) {
                runs.merge(r);
            }
            for (a, b) in out.torque_sq.iter_mut().zip(part.torque_sq) {
                *a += b;
            }
        }
        Ok(out)
    }

    fn cached_compressed(&self, lin: &Linearisation) -> Option<Arc<Compressed>> {
        let cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        cache.iter().find(|(l, _)| l == lin).map(|(_, c)| c.clone())
    }

    fn store_compressed(&self, lin: &Linearisation, c: Arc<Compressed>) {
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if cache.len() >= CACHE {
            cache.remove(0);
        }
        cache.push((lin.clone(), c));
    }

    fn cached_within(&self, lin: &Linearisation, sel: &[usize]) -> Option<Arc<WithinPose>> {
        let cache = self.within_cache.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .iter()
            .find(|(l, c, _)| l == lin && c == sel)
            .map(|(_, _, w)| w.clone())
    }

    fn store_within(&self, lin: &Linearisation, sel: &[usize], w: Arc<WithinPose>) {
        let mut cache = self.within_cache.lock().unwrap_or_else(|e| e.into_inner());
        if cache.len() >= CACHE {
            cache.remove(0);
        }
        cache.push((lin.clone(), sel.to_vec(), w));
    }
}

/// What a compress pass accumulates besides the compressed design, from the same rows.
#[derive(Debug, Clone, Copy, Default)]
struct Extras<'s> {
    /// The [`WithinPose`] factor over these columns.
    within: Option<&'s [usize]>,
    /// Σ τ_jz² over the training rows, per joint.
    torque_squares: bool,
}

/// One part's share of a compress pass.
struct PartOut {
    acc: CompressedAccumulator,
    runs: Option<WithinRuns>,
    /// Per joint (empty unless asked for).
    torque_sq: Vec<f64>,
}

/// Rows below which a pass is not split over threads.
const PARALLEL_ROWS: usize = 8192;
/// The number of contiguous parts a large pass is split into, fixed (not the core count) so
/// that the merged factors, hence every decision, are the same on every machine.
const PARTS: usize = 2;

/// `f` over the rows `0..n`: one call for a small pass, else one per contiguous part, each on a
/// thread of its own; the results in row order. A panic in a part is resumed here.
pub(super) fn in_parts<T: Send>(n: usize, f: impl Fn(Range<usize>) -> T + Sync) -> Vec<T> {
    if n < PARALLEL_ROWS {
        return vec![f(0..n)];
    }
    let parts: Vec<Range<usize>> = (0..PARTS)
        .map(|k| k * n / PARTS..(k + 1) * n / PARTS)
        .collect();
    over_parts(&parts, f)
}

/// `f` over each of `parts`, one thread per part when there are several; the results in the
/// order of `parts`. A panic in a part is resumed here.
pub(super) fn over_parts<T: Send>(
    parts: &[Range<usize>],
    f: impl Fn(Range<usize>) -> T + Sync,
) -> Vec<T> {
    if let [only] = parts {
        return vec![f(only.clone())];
    }
    std::thread::scope(|s| {
        let handles: Vec<_> = parts
            .iter()
            .map(|r| {
                let f = &f;
                s.spawn(move || f(r.clone()))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    })
}

/// The per-cluster score sums `s_g = X_gᵀ r_g` of a fit over training rows (whitened model
/// columns and residual): [`Problem::cluster_sums`] in a pass of its own, or the final pass
/// for the findings whose test the selection left to it.
pub(super) struct ClusterSums<'f> {
    /// The fit's columns in the layout, and its coefficients.
    idx: Vec<usize>,
    coef: &'f [f64],
    y: usize,
    sums: Vec<Vec<f64>>,
    used: Vec<bool>,
    x: Vec<Vector3<f64>>,
}

impl<'f> ClusterSums<'f> {
    pub(super) fn new(problem: &VjmProblem<'_>, fit: &'f Fit<Term, Linearisation>) -> Self {
        let p = fit.coef.len();
        let n_groups = problem.groups.iter().copied().max().map_or(0, |g| g + 1);
        Self {
            idx: fit.terms.iter().flat_map(|t| problem.columns(*t)).collect(),
            coef: &fit.coef,
            y: problem.y,
            sums: vec![vec![0.0; p]; n_groups],
            used: vec![false; n_groups],
            x: vec![Vector3::zeros(); p],
        }
    }

    /// A training row of cluster `g` with whitening `w` and raw columns `cols`.
    pub(super) fn add(&mut self, g: usize, w: &Matrix3<f64>, cols: &[[f64; 3]]) {
        let mut pred = Vector3::zeros();
        for (k, &c) in self.idx.iter().enumerate() {
            self.x[k] = whiten(w, &cols[c]);
            pred += self.x[k] * self.coef[k];
        }
        let r = whiten(w, &cols[self.y]) - pred;
        self.used[g] = true;
        for (s, xk) in self.sums[g].iter_mut().zip(&self.x) {
            *s += xk.dot(&r);
        }
    }

    /// Adds another part's sums (later rows).
    pub(super) fn merge(&mut self, other: ClusterSums<'_>) {
        for (g, (s, u)) in other.sums.into_iter().zip(other.used).enumerate() {
            if u {
                self.used[g] = true;
                for (a, b) in self.sums[g].iter_mut().zip(s) {
                    *a += b;
                }
            }
        }
    }

    /// The sums of the clusters that had training rows, in cluster order.
    pub(super) fn finish(self) -> Vec<Vec<f64>> {
        self.sums
            .into_iter()
            .zip(self.used)
            .filter_map(|(s, u)| u.then_some(s))
            .collect()
    }
}

impl VjmProblem<'_> {
    /// The per-measurement moments of the training rows at `lin` for a wild cluster bootstrap test
    /// (`test` of the layout columns `model` against `full`, in the orders it was built with):
    /// each row's whitened `full` columns and its residual from `model` with the test's
    /// restricted coefficients. One pass over the training rows.
    pub(super) fn wild_cluster_moments(
        &self,
        lin: &Linearisation,
        test: &stiffness_core::engine::wild_cluster::WildClusterTest,
        model: &[usize],
        full: &[usize],
    ) -> Result<Option<stiffness_core::engine::wild_cluster::ClusterMoments>, Cancelled> {
        use stiffness_core::engine::wild_cluster::MAX_CLUSTERS;
        // A cluster is a measurement (a row: its three displacement components share the
        // force sensor's noise through the row's Jacobian); beyond MAX_CLUSTERS rows,
        // consecutive rows are grouped into MAX_CLUSTERS clusters. Measurements are
        // independent of each other (a shared offset per pose is the `pose_offsets` block's
        // business), and at 4 wrenches per pose rows give the covariance of a 14-column
        // block ~120 clusters where poses give ~30: on clean data the test's p with poses as
        // clusters was calibrated too, but it could not reach below ~1e-3 where F's was 1e-20.
        let n = self.data.len();
        let n_groups = n.min(MAX_CLUSTERS);
        let cluster = |i: usize| i * n_groups / n;
        if test.moments(n_groups).is_none() {
            return Ok(None);
        }
        let mut want = vec![false; self.nraw()];
        for &c in full.iter().chain(model) {
            want[c] = true;
        }
        let coef = test.restricted_coefficients();
        self.begin_pass();
        let parts = in_parts(self.data.len(), |range| {
            let mut m = test.moments(n_groups).expect("within the cap");
            let mut x = vec![Vector3::zeros(); full.len()];
            let mut row = vec![0.0; full.len()];
            self.for_each_train_row_in(lin, range, Some(&want), |i, _, w, _, cols| {
                let mut e = whiten(w, &cols[self.y]);
                for (&c, b) in model.iter().zip(coef) {
                    e -= whiten(w, &cols[c]) * *b;
                }
                for (xk, &c) in x.iter_mut().zip(full) {
                    *xk = whiten(w, &cols[c]);
                }
                for r in 0..3 {
                    for (dst, xk) in row.iter_mut().zip(&x) {
                        *dst = xk[r];
                    }
                    m.push_row(test, cluster(i), &row, e[r]);
                }
            })?;
            Ok::<_, Cancelled>(m)
        });
        let mut it = parts.into_iter();
        let mut m = it.next().expect("at least one part")?;
        for part in it {
            m.merge(&part?);
        }
        Ok(Some(m))
    }
}

fn whiten(w: &Matrix3<f64>, v: &[f64; 3]) -> Vector3<f64> {
    w * Vector3::new(v[0], v[1], v[2])
}

impl Problem for VjmProblem<'_> {
    type Term = Term;
    type Lin = Linearisation;

    fn columns(&self, term: Term) -> Range<usize> {
        match term {
            Term::Spring(s) => s..s + 1,
            Term::Cand(Candidate::JointTilt { joint, axis }) => {
                let s = 3 * joint + axis.index();
                s..s + 1
            }
            Term::Cand(c) => self
                .layout
                .iter()
                .find(|(d, _)| *d == c)
                .map(|(_, r)| r.clone())
                .expect("every candidate has columns in the layout"),
            Term::Alt(a) => self
                .alternatives
                .iter()
                .find(|(d, _)| *d == a)
                .map(|(_, r)| r.clone())
                .expect("every block has columns in the layout"),
        }
    }

    fn observation_column(&self) -> usize {
        self.y
    }

    fn bilinear(&self, term: Term) -> bool {
        matches!(term, Term::Cand(c) if c.bilinear())
    }

    fn compress(&self, lin: &Linearisation) -> Result<Arc<Compressed>, Cancelled> {
        if let Some(c) = self.cached_compressed(lin) {
            return Ok(c);
        }
        let c = Arc::new(self.compress_pass(lin, Extras::default())?.acc.finish());
        self.store_compressed(lin, c.clone());
        Ok(c)
    }

    fn model_columns(
        &self,
        lin: &Linearisation,
        cols: &[usize],
    ) -> Result<(Vec<Vec<f64>>, Vec<f64>), Cancelled> {
        // The training rows' whitened `cols` and y, folded into their own small factor: a
        // fit's iteration needs no other column (nor the held-out rows).
        let sel: Vec<usize> = cols.iter().copied().chain([self.y]).collect();
        let mut want = vec![false; self.nraw()];
        for &c in &sel {
            want[c] = true;
        }
        let q = sel.len();
        self.begin_pass();
        let parts = over_parts(&self.pose_parts(), |range| {
            let mut acc = stiffness_core::lsq::TriangularAccumulator::new(q);
            let mut z = vec![Vector3::zeros(); q];
            let mut zrow = vec![0.0; q];
            self.for_each_train_row_in(lin, range, Some(&want), |_, _, w, _, raw| {
                for (zk, &c) in z.iter_mut().zip(&sel) {
                    *zk = whiten(w, &raw[c]);
                }
                for r in 0..3 {
                    for (dst, zk) in zrow.iter_mut().zip(&z) {
                        *dst = zk[r];
                    }
                    acc.push_row_unchecked(&zrow);
                }
            })?;
            Ok::<_, Cancelled>(acc)
        });
        let mut it = parts.into_iter();
        let mut acc = it.next().expect("at least one part")?;
        for part in it {
            acc.merge(part?).expect("parts have the same width");
        }
        let f = acc.finish();
        let col = |k: usize| -> Vec<f64> { (0..q).map(|i| f.r()[i * q + k]).collect() };
        Ok(((0..cols.len()).map(col).collect(), col(cols.len())))
    }

    /// The compliances of every spring term of the fit: the model's springs and the tilt
    /// findings (a tilt is a spring's column, so its compliance belongs in the point where the
    /// bilinear findings — a wrench bias `−J C Jᵀ β`, a frame misalignment, the geometric
    /// non-linearity — and gravity's coupling are evaluated; leaving it out left a per-pose
    /// offset `J ΔC Jᵀ β` of a bias found together with a tilt).
    fn relinearise(&self, terms: &[Term], coef: &[f64]) -> Linearisation {
        let mut c = vec![0.0; self.m];
        let mut k = 0;
        for t in terms {
            let cols = self.columns(*t);
            if matches!(t, Term::Spring(_) | Term::Cand(Candidate::JointTilt { .. })) {
                c[cols.start] = coef[k];
            }
            k += cols.len();
        }
        Linearisation { compliance: c }
    }

    fn cluster_sums(&self, fit: &Fit<Term, Linearisation>) -> Result<Vec<Vec<f64>>, Cancelled> {
        let want = self.mask(&fit.terms);
        self.begin_pass();
        // Each part's sums per cluster (a pose split between parts gets a share from each);
        // the parts are added in row order.
        let parts = in_parts(self.data.len(), |range| {
            let mut sums = ClusterSums::new(self, fit);
            self.for_each_train_row_in(&fit.lin, range, Some(&want), |i, _, w, _, cols| {
                sums.add(self.groups[i], w, cols);
            })?;
            Ok::<_, Cancelled>(sums)
        });
        let mut it = parts.into_iter();
        let mut sums = it.next().expect("at least one part")?;
        for part in it {
            sums.merge(part?);
        }
        Ok(sums.finish())
    }

    fn guard(&self, cand: Term) -> Vec<Term> {
        match cand {
            // A link translation must stand against every rotational spring too: near the
            // wrist, where lever arms are short, tilts missing from the model mimic a
            // translation (the seed's tilted truth named one at J6x without this guard).
            Term::Cand(
                Candidate::MountTranslation
                | Candidate::MountRotation
                | Candidate::LinkTranslation { .. },
            ) => (0..self.m).map(Term::Spring).collect(),
            _ => Vec::new(),
        }
    }

    fn alias_groups(&self, finding: Term) -> Vec<Vec<Term>> {
        // Two tilts of a neighbouring joint together rotate the links beyond it about any
        // line through that joint normal to its axis: on arms whose neighbouring joints are
        // close (Panda's and xArm7's elbows), a tilt of J4 about x and y fits the data as a
        // tilt of J3 does, though neither of J4's tilts alone does.
        let Term::Cand(Candidate::JointTilt { joint, .. }) = finding else {
            return Vec::new();
        };
        [joint.checked_sub(1), Some(joint + 1)]
            .into_iter()
            .flatten()
            .filter(|&k| k < self.chain.n_joints())
            .map(|k| {
                [SpringAxis::X, SpringAxis::Y]
                    .map(|axis| Term::Cand(Candidate::JointTilt { joint: k, axis }))
                    .to_vec()
            })
            .collect()
    }

    fn cancel(&self) -> &Cancel {
        &self.cancel
    }
}

/// The training design with a free offset per pose projected out (the per-pose-offset block
/// of the lack-of-fit alternative, handled by its sufficient statistics instead of as G×3
/// explicit columns). One pass over contiguous runs of a pose's rows: per run, `M = Σ WᵢᵀWᵢ`
/// and `S = Σ Wᵢᵀ Zᵢ` (Zᵢ the 3×P whitened row block), then the projected rows
/// `Zᵢ − Wᵢ M⁻¹ S` are folded into a triangular factor. A pose whose rows are not
/// contiguous in the file gets one offset per run (a drift between visits is then an offset
/// too), and a run is cut every [`MAX_RUN`] rows so that memory stays bounded.
#[derive(Debug, Clone)]
pub struct WithinPose {
    /// R of the projected training design over the selected columns.
    pub factor: stiffness_core::lsq::TriangularFactor,
    /// R of the same training rows and columns without the projection: the F tests of the
    /// lack-of-fit blocks alone, which are not in the compressed design.
    pub plain: stiffness_core::lsq::TriangularFactor,
    /// Offsets projected out: 3 per run with a non-singular `M`.
    pub n_offsets: usize,
    /// R of the training design with each run's offsets **and** its own scale of every joint's
    /// torsion response projected out (the `pose_compliance` block, see `WithinRuns::flush`).
    pub pose_compliance: stiffness_core::lsq::TriangularFactor,
    /// Parameters that projection took: per run the rank of its local columns.
    pub n_local: usize,
}

/// Longest run of rows given one offset.
pub const MAX_RUN: usize = 4096;

impl WithinPose {
    /// The columns of `cols` (the factor's numbering) that [`WithinPose::pose_compliance`]'s
    /// projection leaves in the data: those in the data before it (the engine's zero-column
    /// rule on the unprojected columns, read from [`WithinPose::plain`]) whose projected norm
    /// exceeds the engine's `RANK_TOL` of their unprojected norm. The model's torsion springs
    /// are in every run's local span: projected, they are rounding, and the zero-column rule
    /// applied to the projected design, relative to its own largest column, would count them
    /// when every column given is rounding (a torsion-only baseline).
    pub fn pose_compliance_columns(&self, cols: &[usize]) -> Vec<usize> {
        use stiffness_core::engine::basis::{RANK_TOL, ZERO_COLUMN_RTOL};
        let norm = |f: &stiffness_core::lsq::TriangularFactor, k: usize| -> f64 {
            let p = f.ncols();
            (0..p).map(|i| f.r()[i * p + k].powi(2)).sum::<f64>().sqrt()
        };
        let zero = ZERO_COLUMN_RTOL
            * cols
                .iter()
                .map(|&k| norm(&self.plain, k))
                .fold(0.0, f64::max);
        cols.iter()
            .copied()
            .filter(|&k| {
                let plain = norm(&self.plain, k);
                plain > zero && norm(&self.pose_compliance, k) > RANK_TOL * plain
            })
            .collect()
    }
}

impl VjmProblem<'_> {
    /// The [`WithinPose`] factor at `lin` over the columns `cols` of the layout (in that
    /// order; the factor's column k is `cols[k]`). One pass over the rows, unless the same
    /// factor was made before (the last `CACHE` are kept; [`Self::compress_with_within`]
    /// makes one along with the compressed design).
    pub fn within_pose(
        &self,
        lin: &Linearisation,
        cols: &[usize],
    ) -> Result<Arc<WithinPose>, Cancelled> {
        if let Some(w) = self.cached_within(lin, cols) {
            return Ok(w);
        }
        self.begin_pass();
        let results = over_parts(&self.pose_parts(), |r| self.within_range(lin, r, cols));
        let mut it = results.into_iter();
        let mut runs = it.next().expect("at least one part")?;
        for r in it {
            runs.merge(r?);
        }
        let w = Arc::new(runs.finish());
        self.store_within(lin, cols, w.clone());
        Ok(w)
    }

    fn within_range(
        &self,
        lin: &Linearisation,
        range: Range<usize>,
        sel: &[usize],
    ) -> Result<WithinRuns, Cancelled> {
        let mut want = vec![false; self.nraw()];
        for &c in sel {
            want[c] = true;
        }
        let n = self.chain.n_joints();
        let mut runs = WithinRuns::new(sel.len(), n);
        self.for_each_train_row_in(lin, range, Some(&want), |i, _, w, _, cols| {
            runs.push(
                self.groups[i],
                w,
                sel.iter().map(|&c| whiten(w, &cols[c])),
                (0..n).map(|j| whiten(w, &cols[3 * j])),
            );
        })?;
        Ok(runs)
    }
}

/// The per-pose-offset projection of one part's training rows, a run of a pose's rows at a
/// time (see [`WithinPose`]): the run's whitening matrices and whitened row blocks are kept
/// until the pose changes (or [`MAX_RUN`] rows), then projected and folded.
struct WithinRuns {
    acc: stiffness_core::lsq::TriangularAccumulator,
    /// The offsets' share of the unprojected rows' Gram matrix, three rows per run (see
    /// [`Self::flush`]); with the projected rows' factor it makes the unprojected factor.
    offsets: stiffness_core::lsq::TriangularAccumulator,
    /// Training rows pushed.
    rows: usize,
    n_offsets: usize,
    /// Columns per row block.
    p: usize,
    /// The current run: its group, whitening matrices and whitened row blocks (p per row).
    group: usize,
    ws: Vec<Matrix3<f64>>,
    zs: Vec<Vector3<f64>>,
    zrow: Vec<f64>,
    /// Scratch of a flush, p each: `S = Σ Wᵢᵀ Zᵢ` (then `M⁻¹ S`) and `L⁻¹ S`.
    s: Vec<Vector3<f64>>,
    shares: Vec<Vector3<f64>>,
    /// The rows with each run's offsets and torsion scales projected out
    /// ([`WithinPose::pose_compliance`]), and the local ranks projected.
    local_acc: stiffness_core::lsq::TriangularAccumulator,
    n_local: usize,
    /// Joints, and the current run's whitened torsion columns `Wᵢ J_t[:, 3j] τ_3j` (n per row).
    n_joints: usize,
    ls: Vec<Vector3<f64>>,
    /// Scratch of the local projection: the run's columns, p × 3·rows.
    proj: Vec<f64>,
}

impl WithinRuns {
    fn new(p: usize, n_joints: usize) -> Self {
        Self {
            local_acc: stiffness_core::lsq::TriangularAccumulator::new(p),
            n_local: 0,
            n_joints,
            ls: Vec::new(),
            proj: Vec::new(),
            acc: stiffness_core::lsq::TriangularAccumulator::new(p),
            offsets: stiffness_core::lsq::TriangularAccumulator::new(p),
            rows: 0,
            n_offsets: 0,
            p,
            group: usize::MAX,
            ws: Vec::new(),
            zs: Vec::new(),
            zrow: vec![0.0; p],
            s: vec![Vector3::zeros(); p],
            shares: vec![Vector3::zeros(); p],
        }
    }

    /// A training row of pose `group` with whitening `w`, whitened columns `z` (p) and
    /// whitened torsion columns `torsion` (one per joint).
    fn push(
        &mut self,
        group: usize,
        w: &Matrix3<f64>,
        z: impl Iterator<Item = Vector3<f64>>,
        torsion: impl Iterator<Item = Vector3<f64>>,
    ) {
        if group != self.group || self.ws.len() >= MAX_RUN {
            self.flush();
            self.group = group;
        }
        self.ws.push(*w);
        self.zs.extend(z);
        self.ls.extend(torsion);
    }

    /// The `pose_compliance` projection of the current run: its rows `Zᵢ` projected off the
    /// span of its local columns — the three offsets `Wᵢ e_k` and every joint's torsion
    /// response `Wᵢ J_t[:, 3j] τ_3j`, i.e. a free offset and a free scale of each joint's
    /// torsion compliance for this run alone — and folded. [`WithinRuns::flush`]'s `M⁻¹ S`
    /// generalised from the 3×3 `M` to the (3+n)×(3+n) Gram matrix of the local columns, which
    /// may be singular: a run of one wrench (3 rows) carries its offsets only, a joint whose
    /// torsion does not move the tip (an axis through the tip point) carries nothing. The rank
    /// is decided by the engine's own policy (`stiffness_core::engine::basis`: a column below
    /// 10⁻¹² of the largest local column is not in the data, a column within 10⁻⁷ of the span
    /// of those before it adds nothing), on the explicit local columns (3·rows long,
    /// orthonormalised twice by Gram–Schmidt) rather than on their Gram matrix, whose
    /// eigenvalues would square the condition number. Offsets go first, so that a run keeps
    /// its offsets and gets the torsion scales it can carry; the ranks add up to `n_local`.
    fn flush_local(&mut self) {
        let (p, n, rows) = (self.p, self.n_joints, self.ws.len());
        let len = 3 * rows;
        let mut local: Vec<Vec<f64>> = Vec::with_capacity(3 + n);
        for k in 0..3 {
            local.push(
                self.ws
                    .iter()
                    .flat_map(|w| [w[(0, k)], w[(1, k)], w[(2, k)]])
                    .collect(),
            );
        }
        for j in 0..n {
            local.push(
                self.ls
                    .iter()
                    .skip(j)
                    .step_by(n.max(1))
                    .flat_map(|v| [v.x, v.y, v.z])
                    .collect(),
            );
        }
        let basis = stiffness_core::engine::basis::Basis::of_design(&local);
        self.n_local += basis.rank();
        self.proj.clear();
        self.proj.resize(p * len, 0.0);
        for (k, col) in self.proj.chunks_exact_mut(len).enumerate() {
            for (i, z) in self.zs.chunks_exact(p).enumerate() {
                col[3 * i..3 * i + 3].copy_from_slice(z[k].as_slice());
            }
            basis.project_out(col);
        }
        for r in 0..len {
            for (k, dst) in self.zrow.iter_mut().enumerate() {
                *dst = self.proj[k * len + r];
            }
            self.local_acc.push_row_unchecked(&self.zrow);
        }
    }

    /// Projects the run's offset out of its rows (`Zᵢ − Wᵢ M⁻¹ S`) and folds them. The
    /// unprojected rows are not folded: their Gram matrix is the projected rows' plus
    /// `Sᵀ M⁻¹ S` (the cross terms vanish, as `Σ Wᵢᵀ (Zᵢ − Wᵢ M⁻¹ S) = 0`), which is the
    /// Gram matrix of the three rows `L⁻¹ S` (`M = L Lᵀ`): three rows per run instead of three
    /// per row, and an update, not a downdate.
    fn flush(&mut self) {
        if self.ws.is_empty() {
            return;
        }
        let p = self.p;
        self.flush_local();
        self.rows += 3 * self.ws.len();
        let m: Matrix3<f64> = self.ws.iter().map(|w| w.transpose() * w).sum();
        let offset = m
            .try_inverse()
            .and_then(|mi| m.cholesky().map(|ch| (mi, ch.l())));
        if let Some((mi, l)) = offset {
            self.n_offsets += 3;
            let (b, shares) = (&mut self.s, &mut self.shares);
            b.fill(Vector3::zeros());
            for (w, z) in self.ws.iter().zip(self.zs.chunks_exact(p)) {
                let wt = w.transpose();
                for (bk, zk) in b.iter_mut().zip(z) {
                    *bk += wt * zk;
                }
            }
            for (sk, bk) in shares.iter_mut().zip(b.iter()) {
                *sk = l
                    .solve_lower_triangular(bk)
                    .expect("the Cholesky factor of M has a non-zero diagonal");
            }
            for r in 0..3 {
                for (dst, sk) in self.zrow.iter_mut().zip(shares.iter()) {
                    *dst = sk[r];
                }
                self.offsets.push_row_unchecked(&self.zrow);
            }
            for bk in b.iter_mut() {
                *bk = mi * *bk;
            }
            for (w, z) in self.ws.iter().zip(self.zs.chunks_exact_mut(p)) {
                for (zk, bk) in z.iter_mut().zip(b.iter()) {
                    *zk -= w * bk;
                }
            }
        }
        for z in self.zs.chunks_exact(p) {
            for r in 0..3 {
                for (dst, zk) in self.zrow.iter_mut().zip(z) {
                    *dst = zk[r];
                }
                self.acc.push_row_unchecked(&self.zrow);
            }
        }
        self.ws.clear();
        self.zs.clear();
        self.ls.clear();
    }

    /// Adds another part's rows (later rows of the file).
    fn merge(&mut self, mut other: WithinRuns) {
        self.flush();
        other.flush();
        self.acc
            .merge(other.acc)
            .expect("parts have the same width");
        self.offsets
            .merge(other.offsets)
            .expect("parts have the same width");
        self.local_acc
            .merge(other.local_acc)
            .expect("parts have the same width");
        self.rows += other.rows;
        self.n_offsets += other.n_offsets;
        self.n_local += other.n_local;
    }

    fn finish(mut self) -> WithinPose {
        use stiffness_core::lsq::{TriangularAccumulator, TriangularFactor};
        self.flush();
        let factor = self.acc.finish();
        let mut plain = self.offsets;
        plain
            .merge(TriangularAccumulator::from_factor(factor.clone()))
            .expect("the same width");
        let plain = plain.finish();
        let plain = TriangularFactor::from_upper(self.p, plain.r().to_vec(), self.rows)
            .expect("a p×p factor");
        WithinPose {
            factor,
            plain,
            n_offsets: self.n_offsets,
            pose_compliance: self.local_acc.finish(),
            n_local: self.n_local,
        }
    }
}
