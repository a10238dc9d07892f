//! Forward selection: candidate scoring → Benjamini–Hochberg → hold-out confirmation →
//! aliases → refit, repeated until nothing significant is left.

use super::basis::cosine;
use super::compressed::RowSet;
use super::exchange;
use super::fit::{cluster_robust, fit, score, score_given, sse, Fit, Score};
use super::Problem;
use crate::stats::benjamini_hochberg;
use crate::{Cancelled, Progress};

pub use super::schema::SelectionEvidence;

/// Options of [`select`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelectOptions {
    /// False discovery rate of the Benjamini–Hochberg step.
    pub fdr: f64,
    /// Most findings to name.
    pub max_findings: usize,
    /// |cos| at or above which two one-column candidates are aliases.
    pub alias_cosine: f64,
    /// A significant candidate b is an alias of a finding a when, with b in the model, the F
    /// test of a has p above this level.
    pub alias_alpha: f64,
    /// Leave each finding's cluster-robust test (a pass over the rows for its cluster sums)
    /// to the caller: the evidence's `cluster_robust` stays `None` and
    /// [`Selection::deferred_cluster_robust`] says which fit and how many columns to test,
    /// for a caller that makes a pass over the rows afterwards anyway. The test is reported,
    /// never decided on, so the selection is the same either way.
    pub defer_cluster_robust: bool,
}

/// A finding's cluster-robust test left to the caller ([`SelectOptions::defer_cluster_robust`]):
/// the Wald test that the last `k` coefficients of `fit` are zero
/// ([`super::fit::cluster_robust_from_sums`]).
#[derive(Debug, Clone)]
pub struct DeferredClusterTest<T, L> {
    /// Index of the finding in [`Selection::findings`].
    pub finding: usize,
    /// The fit of the step that accepted it.
    pub fit: Fit<T, L>,
    /// Its columns, the last of the fit's.
    pub k: usize,
}

/// A candidate the data cannot tell apart from a finding.
#[derive(Debug, Clone)]
pub struct AliasOf<T> {
    /// The alias.
    pub cand: T,
    /// |cos| of the one-column candidates' parts outside the model (None otherwise).
    pub cosine: Option<f64>,
    /// (SSE with the alias − SSE with the finding)/σ̂² in the scoring step.
    pub delta_chi2: f64,
    /// p of the finding's F test with the alias in the model (0 when not computed).
    pub p_finding_given_alias: f64,
    /// The other members of a joint alias ([`Problem::alias_groups`]): the data cannot tell
    /// the finding from `cand` and these together, though from none of them alone. Empty for
    /// an alias on its own. A joint alias's `delta_chi2` and `p_finding_given_alias` are the
    /// whole group's; its members stay candidates.
    pub group: Vec<T>,
}

/// One finding of the selection.
#[derive(Debug, Clone)]
pub struct Selected<T> {
    /// The candidate.
    pub cand: T,
    /// Its aliases.
    pub aliases: Vec<AliasOf<T>>,
    /// Its evidence.
    pub evidence: SelectionEvidence,
}

/// The outcome of [`select`].
#[derive(Debug, Clone)]
pub struct Selection<T, L> {
    /// Scores of the whole pool against the baseline (the first step's family).
    pub first_scores: Vec<Score<T>>,
    /// Findings in order.
    pub findings: Vec<Selected<T>>,
    /// Significant candidates that did not lower the held-out SSE.
    pub rejected_on_holdout: Vec<T>,
    /// Significant candidates not significant given their [`Problem::guard`] terms.
    pub explained_by_guard: Vec<T>,
    /// The model with every finding, as fitted in the last accepted step.
    pub last: Fit<T, L>,
    /// Per extra hypothesis of the first step's family: rejected by its Benjamini–Hochberg.
    pub extra_rejected: Vec<bool>,
    /// The findings' cluster-robust tests left to the caller (empty unless
    /// [`SelectOptions::defer_cluster_robust`]).
    pub deferred_cluster_robust: Vec<DeferredClusterTest<T, L>>,
}

/// Forward selection from `base` over `pool`. `extra_p` are further hypotheses of the first
/// step's family (e.g. the lack-of-fit and goodness-of-fit tests of the baseline), so that on
/// data with nothing to find the probability of *any* rejection is controlled at `fdr`
/// (Simes); they never become findings ([`Selection::extra_rejected`] says which the first
/// step rejected).
pub fn select<P: Problem>(
    problem: &P,
    base: Fit<P::Term, P::Lin>,
    mut pool: Vec<P::Term>,
    extra_p: &[f64],
    opts: &SelectOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Selection<P::Term, P::Lin>, Cancelled> {
    let cancel = problem.cancel();
    let first_scores = score(problem, &base, &pool)?;
    cancel.check()?;
    let mut extra_rejected = vec![false; extra_p.len()];
    let mut current = base;
    let mut findings: Vec<Selected<P::Term>> = Vec::new();
    let mut deferred = Vec::new();
    let mut rejected_on_holdout = Vec::new();
    let mut explained_by_guard = Vec::new();
    let mut scores = first_scores.clone();
    // The state of each accepted step, for the exchange ([`exchange::exchange`]).
    let mut steps: Vec<Step<P::Term, P::Lin>> = Vec::new();
    // The guard test is a family too: with many guarded candidates (VJM: the mount's and every
    // link's translations), one that only noise separates from its guard passes at
    // `alias_alpha` by chance. Bonferroni over that family keeps the chance that any does at
    // `alias_alpha`.
    let n_guarded = pool
        .iter()
        .filter(|c| !problem.guard(**c).is_empty())
        .count()
        .max(1);
    let guard_alpha = opts.alias_alpha / n_guarded as f64;
    for step in 1..=opts.max_findings {
        let testable: Vec<&Score<P::Term>> = scores.iter().filter(|s| s.rank > 0).collect();
        let mut p: Vec<f64> = testable.iter().map(|s| s.f_test.p_value).collect();
        if step == 1 {
            p.extend_from_slice(extra_p);
        }
        if p.is_empty() {
            break;
        }
        let rejected = benjamini_hochberg(&p, opts.fdr);
        if step == 1 {
            extra_rejected.copy_from_slice(&rejected[testable.len()..]);
        }
        let mut order: Vec<usize> = (0..testable.len()).filter(|&k| rejected[k]).collect();
        // Most significant first; p-values and F statistics equal to 9 significant digits are
        // ties (exact aliases, e.g. two tilts about one line, differ only by rounding) and keep
        // the catalogue's order, so that the named one does not depend on rounding.
        order.sort_by_key(|&k| {
            (
                significant(p[k]),
                std::cmp::Reverse(significant(testable[k].f_test.f)),
            )
        });
        let screened = Screened {
            explained_by_guard: &mut explained_by_guard,
            rejected_on_holdout: &mut rejected_on_holdout,
            pool: &mut pool,
        };
        let Some((k, trial, before, after)) =
            first_confirmed(problem, &current, &testable, &order, guard_alpha, screened)?
        else {
            break;
        };
        let a = testable[k];
        let bh_cut = bh_cut(&p, opts.fdr);
        let aliases = aliases_of(problem, &current, &testable, a, bh_cut, opts)?;
        let singles = aliases.iter().filter(|al| al.group.is_empty()).count();
        let evidence = SelectionEvidence {
            step,
            cluster_robust: if opts.defer_cluster_robust {
                None
            } else {
                cluster_robust(problem, &trial, problem.columns(a.cand).len())?
            },
            ..step_evidence(a, &p, opts.fdr, before, after)
        };
        // A joint alias's members stay candidates: none of them alone is the finding's alias.
        pool.retain(|c| *c != a.cand && !aliases[..singles].iter().any(|b| b.cand == *c));
        if opts.defer_cluster_robust {
            deferred.push(DeferredClusterTest {
                finding: findings.len(),
                fit: trial.clone(),
                k: problem.columns(a.cand).len(),
            });
        }
        findings.push(Selected {
            cand: a.cand,
            aliases,
            evidence,
        });
        steps.push(Step {
            before: current,
            scores: testable.iter().map(|s| (*s).clone()).collect(),
            p,
            bh_cut,
        });
        current = trial;
        if findings.len() >= 2 {
            let mut state = exchange::State {
                current: &mut current,
                findings: &mut findings,
                deferred: &mut deferred,
                pool: &mut pool,
                steps: &steps,
            };
            exchange::exchange(problem, &mut state, opts)?;
        }
        progress(Progress {
            stage: "selection",
            done: step,
            total: opts.max_findings,
        });
        cancel.check()?;
        if pool.is_empty() {
            break;
        }
        scores = score(problem, &current, &pool)?;
        cancel.check()?;
    }
    Ok(Selection {
        first_scores,
        findings,
        rejected_on_holdout,
        explained_by_guard,
        last: current,
        extra_rejected,
        deferred_cluster_robust: deferred,
    })
}

/// Where [`first_confirmed`] puts the candidates it passes over: those explained by their
/// guard terms and those that do not lower the held-out SSE (both leave the pool).
struct Screened<'a, T> {
    explained_by_guard: &'a mut Vec<T>,
    rejected_on_holdout: &'a mut Vec<T>,
    pool: &'a mut Vec<T>,
}

/// The first of the step's rejected candidates, in `order`, that is significant given its
/// guard terms (at `guard_alpha`) and lowers the held-out SSE by more than [`HOLDOUT_RTOL`]:
/// its index in `testable`, its trial fit, and the held-out SSE before and after.
#[allow(clippy::type_complexity)] // the one call site destructures it at once
fn first_confirmed<P: Problem>(
    problem: &P,
    current: &Fit<P::Term, P::Lin>,
    testable: &[&Score<P::Term>],
    order: &[usize],
    guard_alpha: f64,
    screened: Screened<'_, P::Term>,
) -> Result<Option<(usize, Fit<P::Term, P::Lin>, f64, f64)>, Cancelled> {
    let cancel = problem.cancel();
    for &k in order {
        cancel.check()?;
        let s = testable[k];
        let guard: Vec<P::Term> = problem
            .guard(s.cand)
            .into_iter()
            .filter(|g| !current.terms.contains(g))
            .collect();
        if !guard.is_empty() {
            let given = score_given(problem, current, &guard, &[s.cand])?;
            if given[0].rank == 0 || given[0].f_test.p_value > guard_alpha {
                screened.explained_by_guard.push(s.cand);
                screened.pool.retain(|c| *c != s.cand);
                continue;
            }
        }
        let mut terms = current.terms.clone();
        terms.push(s.cand);
        let trial = fit(problem, &terms, &current.lin)?;
        let before = sse(problem, current, RowSet::Test);
        let after = sse(problem, &trial, RowSet::Test);
        if after < before * (1.0 - HOLDOUT_RTOL) {
            return Ok(Some((k, trial, before, after)));
        }
        screened.rejected_on_holdout.push(s.cand);
        screened.pool.retain(|c| *c != s.cand);
    }
    Ok(None)
}

/// The state of an accepted step that the exchange needs to restate its finding as one of
/// its aliases: the model before the step and the step's scores and family.
#[derive(Debug, Clone)]
pub(super) struct Step<T, L> {
    /// The model the step scored against.
    pub before: Fit<T, L>,
    /// Its testable candidates' scores.
    pub scores: Vec<Score<T>>,
    /// The p-values of its Benjamini–Hochberg family.
    pub p: Vec<f64>,
    /// The family's largest rejected p-value.
    pub bh_cut: f64,
}

/// The largest p-value that Benjamini–Hochberg at `fdr` rejects in `p` (0 when none).
fn bh_cut(p: &[f64], fdr: f64) -> f64 {
    let m = p.len();
    let mut sorted = p.to_vec();
    sorted.sort_by(|x, y| x.total_cmp(y));
    (0..m)
        .filter(|&r| sorted[r] <= fdr * (r + 1) as f64 / m as f64)
        .map(|r| sorted[r])
        .fold(0.0, f64::max)
}

/// The evidence of candidate `a` at a step whose family's p-values are `p` (cluster-robust
/// test left to the caller, step number 0 until set).
pub(super) fn step_evidence<T>(
    a: &Score<T>,
    p: &[f64],
    fdr: f64,
    heldout_sse_before: f64,
    heldout_sse_after: f64,
) -> SelectionEvidence {
    let m = p.len();
    let rank_a = p.iter().filter(|&&v| v <= a.f_test.p_value).count();
    SelectionEvidence {
        step: 0,
        f_test: a.f_test,
        n_candidates: m,
        bh_threshold: fdr * rank_a as f64 / m as f64,
        sse_reduction: 1.0 - a.sse_full / a.sse_reduced,
        cluster_robust: None,
        heldout_sse_before,
        heldout_sse_after,
    }
}

/// The aliases of candidate `a` at a step that scored `testable` against `current`:
/// significant candidates b such that, once b is in the model, the data no longer need a (its
/// F test given b has p > alias_alpha), or whose columns are near-collinear with a's after
/// projecting out the model; then the joint aliases ([`Problem::alias_groups`]) that no
/// single alias already covers. Singles come first.
pub(super) fn aliases_of<P: Problem>(
    problem: &P,
    current: &Fit<P::Term, P::Lin>,
    testable: &[&Score<P::Term>],
    a: &Score<P::Term>,
    bh_cut: f64,
    opts: &SelectOptions,
) -> Result<Vec<AliasOf<P::Term>>, Cancelled> {
    let cancel = problem.cancel();
    let sigma2 = a.sse_full / a.f_test.df_den.max(1.0);
    let mut aliases = Vec::new();
    for b in testable {
        cancel.check()?;
        if b.cand == a.cand {
            continue;
        }
        let delta = (b.sse_full - a.sse_full) / sigma2;
        let one_column = |t: P::Term| problem.columns(t).len() == 1;
        let cos = (one_column(a.cand) && one_column(b.cand))
            .then(|| cosine(&a.first_residual, &b.first_residual).abs());
        let collinear = cos.is_some_and(|c| c >= opts.alias_cosine);
        let p_given = if b.f_test.p_value <= bh_cut {
            score_given(problem, current, &[b.cand], &[a.cand])?[0]
                .f_test
                .p_value
        } else {
            0.0
        };
        if collinear || p_given > opts.alias_alpha {
            aliases.push(AliasOf {
                cand: b.cand,
                cosine: cos,
                delta_chi2: delta,
                p_finding_given_alias: p_given,
                group: Vec::new(),
            });
        }
    }
    let singles = aliases.len();
    for group in problem.alias_groups(a.cand) {
        cancel.check()?;
        if let Some(alias) = group_alias(problem, current, testable, a, &group, bh_cut, opts)? {
            if !aliases[..singles].iter().any(|s| group.contains(&s.cand)) {
                aliases.push(alias);
            }
        }
    }
    Ok(aliases)
}

/// `group` as a joint alias of the finding `a` ([`Problem::alias_groups`]): every member
/// testable, none in the model, one significant at the step's Benjamini–Hochberg cut, and the
/// finding's F test given the whole group above `alias_alpha`.
fn group_alias<P: Problem>(
    problem: &P,
    current: &Fit<P::Term, P::Lin>,
    testable: &[&Score<P::Term>],
    a: &Score<P::Term>,
    group: &[P::Term],
    bh_cut: f64,
    opts: &SelectOptions,
) -> Result<Option<AliasOf<P::Term>>, Cancelled> {
    let members: Vec<&Score<P::Term>> = group
        .iter()
        .filter_map(|g| testable.iter().find(|s| s.cand == *g).copied())
        .collect();
    let usable = !group.is_empty()
        && members.len() == group.len()
        && !group
            .iter()
            .any(|g| current.terms.contains(g) || *g == a.cand)
        && members.iter().any(|s| s.f_test.p_value <= bh_cut);
    if !usable {
        return Ok(None);
    }
    let given = score_given(problem, current, group, &[a.cand])?;
    let p_given = given[0].f_test.p_value;
    // Rank 0 (the finding's columns lie in the group's span) is an exact alias: p = 1.
    if p_given <= opts.alias_alpha {
        return Ok(None);
    }
    // As for a single alias: the SSE with the group in place of the finding, against the SSE
    // with the finding, in noise variances (the reduced model of the test given the group is
    // the model with the group).
    let with_group = given[0].sse_reduced;
    let sigma2 = a.sse_full / a.f_test.df_den.max(1.0);
    Ok(Some(AliasOf {
        cand: group[0],
        cosine: None,
        delta_chi2: (with_group - a.sse_full) / sigma2,
        p_finding_given_alias: p_given,
        group: group[1..].to_vec(),
    }))
}

/// The held-out error must fall by more than this fraction for a candidate to be confirmed:
/// a smaller fall is rounding. (On a UR5 campaign a wrist hinge whose fitted value is zero up
/// to rounding was confirmed by one build on a fall of 4e-12 of the held-out error, and
/// rejected by another that differed from it only in rounding.)
pub const HOLDOUT_RTOL: f64 = 1e-9;

/// `x` rounded to 9 significant digits, as an orderable key (0 and non-finite values first).
fn significant(x: f64) -> i64 {
    if !(x.is_finite() && x > 0.0) {
        return i64::MIN;
    }
    (x.log10() * 1e8).round() as i64
}
