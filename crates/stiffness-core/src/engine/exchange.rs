//! The exchange step of the forward selection: a finding accepted early, before a later
//! finding was in the model, may be the wrong member of its alias set. A wrench bias and a
//! tilt of joint 3 together: before the bias is in the model a tilt of joint 4 fits the
//! combined signal a little better and is accepted; once the bias is in, the tilt of joint 3
//! fits better, and without the exchange a spurious tilt is later accepted to make up the
//! difference (issue 23). After every acceptance each earlier finding is tried against its
//! single aliases, all terms re-linearised jointly; a swap is kept when it lowers the
//! training SSE and does not raise the held-out SSE, one swap at a time, best first, until
//! none helps.

use super::compressed::RowSet;
use super::fit::{cluster_robust, fit, score_given, sse, Fit};
use super::select::HOLDOUT_RTOL;
use super::select::{
    aliases_of, step_evidence, DeferredClusterTest, SelectOptions, Selected, Step,
};
use super::Problem;
use crate::Cancelled;

/// What the exchange may change in the selection's state.
pub(super) struct State<'a, T, L> {
    /// The model with every finding.
    pub current: &'a mut Fit<T, L>,
    /// The findings in order.
    pub findings: &'a mut Vec<Selected<T>>,
    /// Their deferred cluster-robust tests.
    pub deferred: &'a mut Vec<DeferredClusterTest<T, L>>,
    /// The candidates still to score.
    pub pool: &'a mut Vec<T>,
    /// Each finding's step.
    pub steps: &'a [Step<T, L>],
}

/// A swap of finding `index` for candidate `cand`, and the model it gives.
struct Swap<T, L> {
    index: usize,
    cand: T,
    fit: Fit<T, L>,
    sse: f64,
}

/// A swap of a problem's terms.
type SwapOf<P> = Swap<<P as Problem>::Term, <P as Problem>::Lin>;

/// Swaps earlier findings for aliases that fit better given the later findings, one at a
/// time, until none does (at most one round per pair of findings).
pub(super) fn exchange<P: Problem>(
    problem: &P,
    state: &mut State<'_, P::Term, P::Lin>,
    opts: &SelectOptions,
) -> Result<(), Cancelled> {
    let n = state.findings.len();
    for _round in 0..n * n {
        problem.cancel().check()?;
        let Some(swap) = best_swap(problem, state)? else {
            break;
        };
        restate(problem, state, &swap, opts)?;
        *state.current = swap.fit;
    }
    Ok(())
}

/// The swap that lowers the training SSE of the current model most, without raising its
/// held-out SSE.
fn best_swap<P: Problem>(
    problem: &P,
    state: &State<'_, P::Term, P::Lin>,
) -> Result<Option<SwapOf<P>>, Cancelled> {
    let current = &*state.current;
    let sse_now = sse(problem, current, RowSet::Train);
    let heldout_now = sse(problem, current, RowSet::Test);
    let mut best: Option<SwapOf<P>> = None;
    let last = state.findings.len() - 1;
    for (index, finding) in state.findings[..last].iter().enumerate() {
        let a = finding.cand;
        let alternatives: Vec<P::Term> = finding
            .aliases
            .iter()
            .filter(|al| {
                al.group.is_empty()
                    && !current.terms.contains(&al.cand)
                    && problem.guard(al.cand).is_empty()
            })
            .map(|al| al.cand)
            .collect();
        if alternatives.is_empty() {
            continue;
        }
        let others: Vec<P::Term> = current.terms.iter().copied().filter(|t| *t != a).collect();
        // A first look at the current point, on the compressed design (no pass over the
        // rows): the model without `a`, with `a` or each alternative added. `score_given`
        // reads only the terms and the compressed design of the fit it is given.
        let without = Fit {
            terms: others.clone(),
            ..current.clone()
        };
        let mut pool = vec![a];
        pool.extend_from_slice(&alternatives);
        let scores = score_given(problem, &without, &[], &pool)?;
        let sse_a = scores[0].sse_full;
        for s in &scores[1..] {
            if s.rank == 0 || s.sse_full >= sse_a * (1.0 - HOLDOUT_RTOL) {
                continue;
            }
            // The swap refitted, every bilinear term re-linearised with it.
            let mut terms = others.clone();
            terms.push(s.cand);
            let trial = fit(problem, &terms, &current.lin)?;
            let sse_trial = sse(problem, &trial, RowSet::Train);
            let better = sse_trial < sse_now * (1.0 - HOLDOUT_RTOL)
                && sse(problem, &trial, RowSet::Test) <= heldout_now
                && best.as_ref().is_none_or(|b| sse_trial < b.sse);
            if better {
                best = Some(Swap {
                    index,
                    cand: s.cand,
                    fit: trial,
                    sse: sse_trial,
                });
            }
        }
    }
    Ok(best)
}

/// Finding `swap.index` restated as `swap.cand` at its own step: the evidence and aliases the
/// candidate had there, its deferred cluster-robust test, and the pool given back the old
/// finding's aliases that are not the new one's.
fn restate<P: Problem>(
    problem: &P,
    state: &mut State<'_, P::Term, P::Lin>,
    swap: &Swap<P::Term, P::Lin>,
    opts: &SelectOptions,
) -> Result<(), Cancelled> {
    let step = &state.steps[swap.index];
    let old = &state.findings[swap.index];
    let Some(b) = step.scores.iter().find(|s| s.cand == swap.cand) else {
        return Ok(());
    };
    let mut terms = step.before.terms.clone();
    terms.push(swap.cand);
    let at_step = fit(problem, &terms, &step.before.lin)?;
    let k = problem.columns(swap.cand).len();
    let testable: Vec<_> = step.scores.iter().collect();
    let aliases = aliases_of(problem, &step.before, &testable, b, step.bh_cut, opts)?;
    let evidence = super::SelectionEvidence {
        step: old.evidence.step,
        cluster_robust: if opts.defer_cluster_robust {
            None
        } else {
            cluster_robust(problem, &at_step, k)?
        },
        ..step_evidence(
            b,
            &step.p,
            opts.fdr,
            old.evidence.heldout_sse_before,
            sse(problem, &at_step, RowSet::Test),
        )
    };
    // Candidates the old finding took out of the pool as its aliases come back unless they
    // are the new one's aliases (or in the model).
    let old_cand = old.cand;
    let returned: Vec<P::Term> = std::iter::once(old_cand)
        .chain(
            old.aliases
                .iter()
                .filter(|al| al.group.is_empty())
                .map(|al| al.cand),
        )
        .filter(|c| {
            *c != swap.cand
                && !swap.fit.terms.contains(c)
                && !state.pool.contains(c)
                && !aliases
                    .iter()
                    .any(|al| al.group.is_empty() && al.cand == *c)
        })
        .collect();
    state.pool.extend(returned);
    state.pool.retain(|c| {
        *c != swap.cand
            && !aliases
                .iter()
                .any(|al| al.group.is_empty() && al.cand == *c)
    });
    if let Some(d) = state.deferred.iter_mut().find(|d| d.finding == swap.index) {
        d.fit = at_step;
        d.k = k;
    }
    state.findings[swap.index] = Selected {
        cand: swap.cand,
        aliases,
        evidence,
    };
    Ok(())
}
