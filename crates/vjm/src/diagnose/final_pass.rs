//! The final pass: what is not a sufficient statistic — mean *relative* errors (a ratio per
//! row), per-pose errors, the bounded row sample of the residual-structure statistics and, on
//! request, the per-row predictions — accumulated while streaming the rows, in parallel parts.

use std::ops::Range;

use stiffness_core::engine::Fit;
use stiffness_core::Cancelled;

use super::candidates::{Linearisation, RowKinematics};
use super::problem::{ClusterSums, Term, VjmProblem};
use crate::dataset::SetLabel;

/// Sums of relative errors `‖d_pred − d‖/‖d‖` and their counts (rows with ‖d‖ = 0 have no
/// relative error and are not counted).
#[derive(Debug, Clone, Copy, Default)]
pub struct RelSum {
    /// Σ relative errors.
    pub sum: f64,
    /// Rows counted.
    pub count: usize,
}

impl RelSum {
    fn add(&mut self, e: Option<f64>) {
        if let Some(e) = e {
            self.sum += e;
            self.count += 1;
        }
    }
    fn merge(&mut self, o: RelSum) {
        self.sum += o.sum;
        self.count += o.count;
    }
    /// The mean; NaN without rows.
    pub fn mean(&self) -> f64 {
        if self.count == 0 {
            f64::NAN
        } else {
            self.sum / self.count as f64
        }
    }
}

/// What one fit's predictions give in the pass.
#[derive(Debug, Clone)]
pub struct FitTotals {
    /// Training rows.
    pub train: RelSum,
    /// Held-out rows.
    pub test: RelSum,
    /// Per pose group.
    pub per_pose: Vec<RelSum>,
    /// Residual of each sampled row (m, base frame), in sample order.
    pub sample_residuals: Vec<[f64; 3]>,
    /// Per-row predictions, when asked for.
    pub predictions: Vec<[f64; 3]>,
}

/// The output of [`predictions_pass`].
#[derive(Debug, Clone)]
pub struct PassOut {
    /// One entry per fit, in the order given.
    pub fits: Vec<FitTotals>,
    /// The sampled training rows' kinematics and per-axis noise (m).
    pub sample: Vec<(RowKinematics, [f64; 3])>,
    /// First row of every pose group (for its id and set).
    pub first_row: Vec<Option<usize>>,
    /// Per fit of `cluster` (in that order): its per-cluster score sums over the training
    /// rows, as [`stiffness_core::engine::Problem::cluster_sums`] gives them.
    pub cluster_sums: Vec<Vec<Vec<f64>>>,
}

fn rel_error(d: [f64; 3], p: [f64; 3]) -> Option<f64> {
    let e = ((d[0] - p[0]).powi(2) + (d[1] - p[1]).powi(2) + (d[2] - p[2]).powi(2)).sqrt();
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    (n > 0.0).then_some(e / n)
}

/// Streams every row once at `lin`, predicting with each of `fits` (whose columns must be
/// those at `lin`). Rows `i` with `i % stride == 0` that are training rows form the sample.
/// For each fit of `cluster` (also at `lin`), the per-cluster score sums of its
/// cluster-robust test, in the same parts and order as a pass of their own.
pub fn predictions_pass(
    problem: &VjmProblem<'_>,
    lin: &Linearisation,
    fits: &[&Fit<Term, Linearisation>],
    cluster: &[&Fit<Term, Linearisation>],
    stride: usize,
    per_row: bool,
) -> Result<PassOut, Cancelled> {
    let n = problem.data.len();
    let n_groups = problem.groups.iter().copied().max().map_or(0, |g| g + 1);
    let all_terms: Vec<Term> = fits
        .iter()
        .chain(cluster)
        .flat_map(|f| f.terms.iter().copied())
        .collect();
    let want = problem.mask(&all_terms);
    problem.begin_pass();
    let run = |range: Range<usize>| -> Result<(PassOut, Vec<ClusterSums<'_>>), Cancelled> {
        let mut out = PassOut {
            fits: fits
                .iter()
                .map(|_| FitTotals {
                    train: RelSum::default(),
                    test: RelSum::default(),
                    per_pose: vec![RelSum::default(); n_groups],
                    sample_residuals: Vec::new(),
                    predictions: Vec::new(),
                })
                .collect(),
            sample: Vec::new(),
            first_row: vec![None; n_groups],
            cluster_sums: Vec::new(),
        };
        let mut sums: Vec<ClusterSums<'_>> = cluster
            .iter()
            .map(|f| ClusterSums::new(problem, f))
            .collect();
        problem.for_each_row_in(lin, range, Some(&want), |i, row, w, sigma, cols| {
            let g = problem.groups[i];
            if out.first_row[g].is_none() {
                out.first_row[g] = Some(i);
            }
            let train = problem.labels[i] == SetLabel::Train;
            let sampled = train && i % stride == 0;
            if sampled {
                out.sample.push((row.clone(), *sigma));
            }
            if train {
                for s in sums.iter_mut() {
                    s.add(g, w, cols);
                }
            }
            let d = row.displacement;
            for (fit, t) in fits.iter().zip(out.fits.iter_mut()) {
                let p = problem.predict(fit, cols);
                let e = rel_error(d, p);
                if train {
                    t.train.add(e);
                } else {
                    t.test.add(e);
                }
                t.per_pose[g].add(e);
                if sampled {
                    t.sample_residuals
                        .push([d[0] - p[0], d[1] - p[1], d[2] - p[2]]);
                }
                if per_row {
                    t.predictions.push(p);
                }
            }
        })?;
        Ok((out, sums))
    };
    let results = super::problem::in_parts(n, run);
    let mut it = results.into_iter();
    let (mut acc, mut sums) = it.next().expect("at least one part")?;
    for r in it {
        let (o, part_sums) = r?;
        for (a, b) in sums.iter_mut().zip(part_sums) {
            a.merge(b);
        }
        for (a, b) in acc.fits.iter_mut().zip(o.fits) {
            a.train.merge(b.train);
            a.test.merge(b.test);
            for (x, y) in a.per_pose.iter_mut().zip(b.per_pose) {
                x.merge(y);
            }
            a.sample_residuals.extend(b.sample_residuals);
            a.predictions.extend(b.predictions);
        }
        acc.sample.extend(o.sample);
        for (x, y) in acc.first_row.iter_mut().zip(o.first_row) {
            if x.is_none() {
                *x = y;
            }
        }
    }
    acc.cluster_sums = sums.into_iter().map(ClusterSums::finish).collect();
    Ok(acc)
}

/// What the diagnosis takes from its final pass (or passes) over the rows.
pub struct FinalPasses {
    /// The baseline's totals.
    pub base: FitTotals,
    /// The extended model's totals.
    pub ext: FitTotals,
    /// The sampled training rows' kinematics, in row order (moved out of the pass, not
    /// cloned: up to 20 000 rows).
    pub sample: Vec<RowKinematics>,
    /// Their per-axis noise (m).
    pub sample_sigma: Vec<[f64; 3]>,
    /// First row of every pose group.
    pub first_row: Vec<Option<usize>>,
    /// (finding, its cluster-robust test) for every finding whose test the selection deferred.
    pub cluster_tests: Vec<(usize, Option<stiffness_core::stats::FTest>)>,
}

/// The final pass at the baseline's point, with the extended model's predictions when it has
/// the same point (else a second pass at its own), and the cluster-robust tests the selection
/// deferred: from the sums of a pass at their fit's point, or a pass of their own.
pub fn final_passes(
    problem: &VjmProblem<'_>,
    base_fit: &Fit<Term, Linearisation>,
    ext_fit: &Fit<Term, Linearisation>,
    deferred: &[super::DeferredTest],
    stride: usize,
    per_row: bool,
    cancel: &stiffness_core::Cancel,
) -> Result<FinalPasses, super::DiagnoseError> {
    use stiffness_core::engine::fit::{cluster_robust, cluster_robust_from_sums};
    let same_lin = ext_fit.lin == base_fit.lin;
    let fits: Vec<&Fit<Term, Linearisation>> = if same_lin {
        vec![base_fit, ext_fit]
    } else {
        vec![base_fit]
    };
    let at = |lin: &Linearisation| -> Vec<&super::DeferredTest> {
        deferred.iter().filter(|d| d.fit.lin == *lin).collect()
    };
    let in_base = at(&base_fit.lin);
    let in_ext = if same_lin {
        Vec::new()
    } else {
        at(&ext_fit.lin)
    };
    let base_cluster: Vec<&Fit<Term, Linearisation>> = in_base.iter().map(|d| &d.fit).collect();
    let ext_cluster: Vec<&Fit<Term, Linearisation>> = in_ext.iter().map(|d| &d.fit).collect();
    let mut pass = predictions_pass(
        problem,
        &base_fit.lin,
        &fits,
        &base_cluster,
        stride,
        per_row,
    )?;
    let from_sums = |d: &super::DeferredTest, sums: &[Vec<f64>]| {
        (
            d.finding,
            cluster_robust_from_sums(problem, &d.fit, d.k, sums),
        )
    };
    let mut cluster_tests: Vec<(usize, Option<stiffness_core::stats::FTest>)> = in_base
        .iter()
        .zip(&pass.cluster_sums)
        .map(|(d, sums)| from_sums(d, sums))
        .collect();
    let ext = if same_lin {
        pass.fits.pop().expect("two fits")
    } else {
        let mut ext_pass = predictions_pass(
            problem,
            &ext_fit.lin,
            &[ext_fit],
            &ext_cluster,
            stride,
            per_row,
        )?;
        for (d, sums) in in_ext.iter().zip(&ext_pass.cluster_sums) {
            cluster_tests.push(from_sums(d, sums));
        }
        ext_pass.fits.pop().expect("one fit")
    };
    for d in deferred {
        if !cluster_tests.iter().any(|(k, _)| *k == d.finding) {
            cancel.check()?;
            cluster_tests.push((d.finding, cluster_robust(problem, &d.fit, d.k)?));
        }
    }
    let base = pass.fits.pop().expect("the baseline");
    let (sample, sample_sigma) = std::mem::take(&mut pass.sample).into_iter().unzip();
    Ok(FinalPasses {
        base,
        ext,
        sample,
        sample_sigma,
        first_row: pass.first_row,
        cluster_tests,
    })
}
