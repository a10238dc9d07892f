"""A readable diagnosis report: Markdown with PNG plots (matplotlib, Agg backend).

:func:`write_report` turns a :class:`~robot_stiffness.results.Diagnosis` (of
:func:`robot_stiffness.vjm.diagnose` or :func:`robot_stiffness.csjm.diagnose`) into a directory
holding ``report.md`` and its plots:

* ``residuals.png`` — residual norm per measurement row, baseline vs baseline + findings;
* ``errors_per_pose.png`` (VJM) — mean relative error per pose, baseline vs extended, held-out
  poses marked;
* ``verdict.png`` (VJM) — what remains: each block of the lack-of-fit alternative tested
  against the baseline + findings (−log10 p), with the verdict's level;
* ``effects.png`` — the evidence for every candidate effect (first-step F-test p-values), with
  the named effects highlighted.

Reports scale: no plot draws more than :data:`MAX_POINTS` points per panel. Up to that many
rows (or poses) every one is drawn; beyond, the rows are binned in file order into a fixed
number of bins and each bin is drawn as its largest and its median residual (deterministic,
and the worst rows stay visible). ``progress(stage, done, total)`` is called before every plot;
an exception it raises stops the report (the CLI's Ctrl-C goes through it).

The report is built under a temporary name and moved into ``out_dir`` at the end, so a failure
never leaves a half-written report, and a file the package did not write is never replaced
(see :func:`write_report`).
"""

from __future__ import annotations

import io
import math
import os
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._arguments import checked
from ._errors import ArgumentTypeError, InvalidValueError
from ._outputs import Outputs
from .results import (
    Alias,
    Anova,
    CandidateScore,
    DirectionCorrelation,
    DisplacementRows,
    Diagnosis,
    Evidence,
    Finding,
    MomentRows,
    PoseErrors,
    ResidualStructure,
)

__all__ = ["write_report", "render_report", "render_files", "save_files", "story", "percent", "atomic_directory", "REPORT_FILES",
           "CSJM_REPORT_FILES", "MAX_POINTS"]

#: The files of a VJM report (relative to its folder).
REPORT_FILES = ("report.md", "residuals.png", "errors_per_pose.png", "effects.png", "verdict.png")
#: The files of a CSJM report.
CSJM_REPORT_FILES = ("report.md", "residuals.png", "effects.png")
#: At most this many points (segment ends, markers, line vertices) per plot panel.
MAX_POINTS = 10_000

PathLike = Union[str, "os.PathLike[str]"]
Progress = Callable[[str, int, int], None]
_Target = Union[Path, io.BytesIO]


def percent(x: Optional[float]) -> str:
    """``0.0775`` → ``"7.75 %"``; None/NaN → ``"n/a"``."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{100.0 * x:.2f} %"


def _pval(p: Optional[float]) -> str:
    if p is None or not math.isfinite(p):
        return "n/a"
    return f"{p:.1e}" if p < 1e-3 else f"{p:.3f}"


def _num(x: Optional[float], fmt: str = ".1f") -> str:
    return "n/a" if x is None or not math.isfinite(x) else format(x, fmt)


def _where(f: Union[Finding, Alias, CandidateScore]) -> str:
    parts = []
    if f.joint is not None:
        parts.append(f"joint {f.joint}")
    if f.axis is not None:
        parts.append(f"axis {f.axis}")
    return f" at {', '.join(parts)}" if parts else ""


def _alias_text(f: Finding) -> str:
    if not f.aliases:
        return ""
    return "; indistinguishable on these data from " + ", ".join(a.effect + _where(a) for a in f.aliases)


def _small(p: Optional[float], alpha: float) -> bool:
    return p is not None and math.isfinite(p) and p < alpha


def _what_is_wrong(r: ResidualStructure, alpha: float = 0.01) -> str:
    """The residual-structure statistics of one VJM fit, in words, significant ones only."""
    parts = []
    if math.isfinite(r.scaled_rms):
        parts.append(f"its residuals are {r.scaled_rms:.1f}× the noise level")
    if r.per_pose_anova is not None and _small(r.per_pose_anova.p_value, alpha):
        parts.append(f"they differ between configurations (per-pose ANOVA p = {_pval(r.per_pose_anova.p_value)})")
    mag = r.load_magnitude
    if mag is not None and _small(mag.p_value, alpha):
        parts.append(f"they grow with the load magnitude (Spearman ρ = {mag.rho:+.2f}, p = {_pval(mag.p_value)})")
    best = _strongest_torque(r)
    if best is not None and _small(best[1].p_value, alpha):
        parts.append(f"they correlate with the torque of joint {best[0]} (ρ = {best[1].rho:+.2f}, p = {_pval(best[1].p_value)})")
    d = r.load_direction
    if isinstance(d, DirectionCorrelation) and _small(d.p_bonferroni, alpha):
        parts.append(f"residual {d.residual_axis} depends on the force direction {d.force_axis} "
                     f"(ρ = {d.correlation.rho:+.2f}, p = {_pval(d.p_bonferroni)})")
    return "; ".join(parts)


def _strongest_torque(r: ResidualStructure) -> Optional[Tuple[int, Any]]:
    best = None
    for t in r.torque or []:
        c = t.correlation
        if c is not None and math.isfinite(c.p_value) and (best is None or c.p_value < best[1].p_value):
            best = (t.joint, c)
    return best


def _what_is_wrong_csjm(r: ResidualStructure, alpha: float = 0.01) -> str:
    parts = []
    if math.isfinite(r.scaled_rms):
        parts.append(f"its moment residuals are {r.scaled_rms:.1f}× the noise level")
    mag = r.load_magnitude
    if mag is not None and _small(mag.p_value, alpha):
        parts.append(f"they grow with the load (Spearman ρ = {mag.rho:+.2f}, p = {_pval(mag.p_value)})")
    d = r.load_direction
    if isinstance(d, Anova) and _small(d.p_value, alpha):
        parts.append(f"they depend on the load direction (ANOVA p = {_pval(d.p_value)})")
    lu = [x for x in r.loading_unloading or [] if x.test is not None and _small(x.test.p_value, alpha)]
    if lu:
        parts.append("they differ between loading and unloading about " + ", ".join(x.axis for x in lu)
                     + f" (p = {_pval(min(x.test.p_value for x in lu if x.test is not None))})")
    return "; ".join(parts)


def is_csjm(result: Diagnosis) -> bool:
    """True for a CSJM diagnosis, False for a VJM one."""
    return result.model_kind == "csjm"


def story(result: Diagnosis) -> List[str]:
    """A few sentences: what the baseline got wrong, the named cause, the gain on held-out rows."""
    result = as_diagnosis(result)
    base, ext = result.baseline, result.extended
    lines = [
        f"Baseline ({base.model}, {base.n_params} parameters): mean relative error "
        f"{percent(base.test_mean_rel_error)} on held-out data."
    ]
    structure = result.residuals.baseline
    wrong = _what_is_wrong_csjm(structure) if is_csjm(result) else _what_is_wrong(structure)
    if wrong:
        lines.append("What it gets wrong: " + wrong + ".")
    if result.findings:
        for f in result.findings:
            if not isinstance(f.evidence, Evidence):
                lines.append(
                    "K_D is measurably asymmetric as the connection term −½hat(τ₀) predicts "
                    "(connection_term): the symmetric covariant K = K_D − ½hat(τ₀) is the stiffness."
                )
                continue
            lines.append(
                f"Named cause: {f.effect}{_where(f)} (F-test p = {_pval(f.evidence.f_test.p_value)}, confirmed on "
                f"held-out rows){_alias_text(f)}."
            )
    else:
        lines.append("No effect of the catalogue improves the baseline significantly.")
    gain = result.gain
    lines.append(
        f"Baseline + findings ({ext.model}, {ext.n_params} parameters): "
        f"{percent(ext.test_mean_rel_error)} on held-out data"
        + (f", {percent(gain)} lower than the baseline." if math.isfinite(gain) else ".")
    )
    if result.unexplained:
        remaining = result.verdict.remaining if result.verdict is not None else None
        lines.append(
            f"What remains: {remaining}." if remaining
            else "Structured residual remains that no candidate explains."
        )
    return lines


# ----------------------------------------------------------------------------- bounded plots


def _bins(n: int, max_bins: int) -> npt.NDArray[np.int64]:
    """Start index of each of at most ``max_bins`` contiguous bins over ``n`` items (file order)."""
    count = max(1, min(n, max_bins))
    return np.unique(np.linspace(0, n, count, endpoint=False).astype(np.int64))


def _bin_stats(values: npt.NDArray[np.float64], starts: npt.NDArray[np.int64]) -> Tuple[
        npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Per-bin largest and median value."""
    top = np.maximum.reduceat(values, starts)
    ends = np.append(starts[1:], len(values))
    median = np.array([np.median(values[a:b]) for a, b in zip(starts, ends)], dtype=np.float64)
    return top, median


def _row_panel(ax: Any, err: npt.NDArray[np.float64], test: npt.NDArray[np.bool_]) -> str:
    """Residual norm per row on ``ax`` within :data:`MAX_POINTS`; returns the x-axis label."""
    n = len(err)
    idx = np.arange(n)
    if 2 * n <= MAX_POINTS:
        # One line collection per set, not one rectangle per row: ax.bar costs ~0.5 ms a bar.
        width = float(np.clip(500.0 / max(n, 1), 0.3, 4.0))  # points
        ax.vlines(idx[~test], 0.0, err[~test], color="tab:blue", label="training rows", linewidth=width)
        ax.vlines(idx[test], 0.0, err[test], color="tab:orange", label="held-out rows", linewidth=width)
        return "measurement row"
    # Per set: its rows in file order, binned; each bin is a segment from 0 to its largest
    # residual (2 points) and a vertex of the median line (1 point): 3 points a bin.
    per_set = MAX_POINTS // 6
    sets = ((~test, "tab:blue", "navy", "training rows"), (test, "tab:orange", "saddlebrown", "held-out rows"))
    for mask, color, dark, name in sets:
        rows = idx[mask]
        if len(rows) == 0:
            continue
        starts = _bins(len(rows), per_set)
        top, median = _bin_stats(err[mask], starts)
        x = rows[starts].astype(np.float64)
        ax.vlines(x, 0.0, top, color=color, label=f"{name}: largest in bin", linewidth=0.4)
        ax.plot(x, median, color=dark, linewidth=0.7, zorder=3, label=f"{name}: median in bin")
    return f"measurement row ({n} rows; each set in at most {per_set} bins of consecutive rows)"


def _plot_rows(result: Diagnosis, path: _Target) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result.rows
    if isinstance(rows, DisplacementRows):
        residuals = [1e6 * np.linalg.norm(rows.baseline - rows.measured, axis=1),
                     1e6 * np.linalg.norm(rows.extended - rows.measured, axis=1)]
        ylabel, title, xname = "‖d_pred − d_meas‖ (µm)", "Residuals", None
    elif isinstance(rows, MomentRows):
        residuals = [np.linalg.norm(rows.baseline_residual, axis=1), np.linalg.norm(rows.extended_residual, axis=1)]
        ylabel, title, xname = "‖Δτ − Δτ_pred‖ (N·m)", "Moment residuals", "load increment (file order)"
    else:
        residuals = [np.zeros(0), np.zeros(0)]
        ylabel, title, xname = "residual", "Residuals (rows not available)", None
    test = np.zeros(0, dtype=bool) if rows is None else np.asarray(rows.held_out, dtype=bool)
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, sharey=True)
    xlabel = "measurement row"
    for ax, err, which, model in ((axes[0], residuals[0], "baseline", result.baseline.model),
                                  (axes[1], residuals[1], "extended", result.extended.model)):
        if len(err) == 0:
            # Never a silently empty panel: say why nothing is drawn.
            ax.text(0.5, 0.5, "no per-row data in this diagnosis (diagnose with per_row=True)",
                    transform=ax.transAxes, ha="center", va="center", fontsize=9, color="dimgray")
        xlabel = _row_panel(ax, err, test)
        ax.set_ylim(bottom=0.0)
        ax.set_ylabel(ylabel)
        ax.set_title(f"{title}, {which}: {model}", fontsize=10)
        ax.legend(loc="upper right", fontsize=7)
    axes[1].set_xlabel(xname if xname and 2 * len(test) <= MAX_POINTS else xlabel)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


#: Up to this many poses the per-pose plot has a labelled bar pair per pose.
_LABELLED_POSES = 60


def _plot_per_pose(result: Diagnosis, path: _Target) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    poses = result.per_pose if result.per_pose is not None else PoseErrors([], [], [], [])
    b = 100.0 * poses.baseline
    e = 100.0 * poses.extended
    test = poses.held_out
    x = np.arange(len(poses))
    fig, ax = plt.subplots(figsize=(9, 3.8))
    # Points: 2 bars of 4 corners (or 2 segments of 2 ends) per pose, up to one shaded span of
    # 5 vertices per two poses.
    if len(poses) <= _LABELLED_POSES and 11 * len(poses) <= MAX_POINTS:
        ax.bar(x - 0.2, b, width=0.4, label="baseline", color="tab:red")
        ax.bar(x + 0.2, e, width=0.4, label="extended", color="tab:green")
        ax.set_xticks(x)
        ax.set_xticklabels([str(p) for p in poses.pose.tolist()], fontsize=7)
        ax.set_xlabel("pose (shaded: held out)")
    elif 7 * len(poses) <= MAX_POINTS:
        # Many poses: one line collection per model instead of one rectangle per pose (ax.bar
        # and a span per held-out pose took 5 s for 1500 poses), no per-pose tick labels.
        width = float(np.clip(250.0 / len(poses), 0.3, 4.0))  # points
        ax.vlines(x - 0.2, 0.0, b, color="tab:red", label="baseline", linewidth=width)
        ax.vlines(x + 0.2, 0.0, e, color="tab:green", label="extended", linewidth=width)
        ax.set_xlabel("pose, in file order (shaded: held out)")
    else:
        # More poses than points: the mean error of each bin of consecutive poses, two lines.
        starts = _bins(len(poses), MAX_POINTS // 4)
        counts = np.diff(np.append(starts, len(poses)))
        xs = starts.astype(np.float64)
        ax.plot(xs, np.add.reduceat(b, starts) / counts, color="tab:red", linewidth=0.6, label="baseline (bin mean)")
        ax.plot(xs, np.add.reduceat(e, starts) / counts, color="tab:green", linewidth=0.6, label="extended (bin mean)")
        ax.set_xlabel(f"pose, in file order ({len(poses)} poses in bins of ~{max(1, int(counts.mean()))})")
        test = np.zeros(0, dtype=bool)  # no shading: a bin mixes training and held-out poses
    ax.set_ylim(bottom=0.0)
    # Held-out poses: one shaded span per run of consecutive poses, in one collection.
    edges = np.flatnonzero(np.diff(np.concatenate([[0], test.astype(np.int8), [0]])))
    runs = [(float(a) - 0.5, float(c - a)) for a, c in zip(edges[::2], edges[1::2])]
    if runs:
        ax.broken_barh(runs, (0.0, 1.0), color="0.9", zorder=0, transform=ax.get_xaxis_transform())
    ax.set_ylabel("mean relative error (%)")
    ax.set_title("Error per pose", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _verdict_lines(result: Diagnosis) -> List[str]:
    """The tests behind `unexplained` (VJM), for the report."""
    v = result.verdict
    if v is None:
        return []
    lof = v.lack_of_fit
    out = ["", f"Lack of fit against the flexible alternative (no noise level needed): F = {_num(lof.f)} "
                f"({_num(lof.df_num, '.0f')}, {_num(lof.df_den, '.0f')}), p = {_pval(lof.p_value)}; "
                f"decided at {_num(v.alpha, '.3g')}."]
    g = v.goodness_of_fit
    if g is not None:
        out.append(f"Goodness of fit against the stated noise: χ²/df = {_num(g.ratio, '.3f')} "
                   f"(df {_num(g.df, '.0f')}), p = {_pval(g.p_value)}.")
    else:
        out.append("Goodness of fit: not tested (no noise level given; `--tracker-sigma`, `--force-sigma`, "
                   "`--moment-sigma`).")
    if v.remaining:
        out.append(f"What remains: {v.remaining}.")
    out += ["", "![What remains](verdict.png)", "", "| block | F | df | p | meaning |", "|---|---|---|---|---|"]
    for b in v.blocks:
        out.append(f"| {b.block} | {_num(b.f_test.f)} | {_num(b.f_test.df_num, '.0f')}, {_num(b.f_test.df_den, '.0f')} "
                   f"| {_pval(b.f_test.p_value)} | {b.meaning} |")
    return out


def _plot_verdict(result: Diagnosis, path: _Target) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    v = result.verdict
    fig, ax = plt.subplots(figsize=(8, 2.8))
    if v is None:
        ax.text(0.5, 0.5, "no verdict tests for this model", ha="center", va="center")
        ax.set_axis_off()
    else:
        tests = [("lack of fit (all)", v.lack_of_fit.p_value)] + [(b.block, b.f_test.p_value) for b in v.blocks]
        vals = [-math.log10(max(p, 1e-300)) for _, p in tests]
        colors = ["tab:red" if p <= v.alpha else "tab:gray" for _, p in tests]
        y = np.arange(len(tests))
        ax.barh(y, vals, color=colors)
        ax.set_yticks(y)
        ax.set_yticklabels([t for t, _ in tests], fontsize=8)
        ax.invert_yaxis()
        ax.axvline(-math.log10(v.alpha), color="k", linestyle="--", linewidth=0.8, label=f"level {v.alpha:g}")
        ax.set_xlabel("−log10 p (F test against the baseline + findings)")
        ax.set_title("What remains (red: significant)", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _plot_effects(result: Diagnosis, path: _Target) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    csjm = is_csjm(result)
    testable = [s for s in result.scores if s.f_test is not None and (csjm or s.testable)]
    scores = sorted(testable, key=lambda s: s.f_test.p_value if s.f_test is not None else 1.0)[:20]
    found = {(f.effect, f.joint, f.axis) for f in result.findings}
    labels = [s.effect if csjm or s.label is None else s.label for s in scores]
    vals = [-math.log10(max(s.f_test.p_value if s.f_test is not None else 1.0, 1e-300)) for s in scores]
    colors = ["tab:green" if (s.effect, s.joint, s.axis) in found else "tab:gray" for s in scores]
    fig, ax = plt.subplots(figsize=(9, max(2.5, 0.3 * len(scores) + 1)))
    y = np.arange(len(scores))
    ax.barh(y, vals, color=colors)
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=8)
    ax.invert_yaxis()
    fdr = result.fdr
    ax.axvline(-math.log10(fdr / max(1, len(testable))), color="k", linestyle="--", linewidth=0.8,
               label=f"strictest BH threshold (q = {fdr})")
    ax.set_xlabel("−log10 p (first-step F test against the baseline)")
    ax.set_title("Candidate effects (green: named)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


# ----------------------------------------------------------------------------- markdown


def _markdown(result: Diagnosis, title: str, source: Optional[str]) -> str:
    base, ext = result.baseline, result.extended
    out = [f"# {title}", ""]
    if source:
        out += [f"Data: `{source}` — {result.n_train} training rows, {result.n_test} held-out rows.", ""]
    out += ["## Summary", ""] + [f"- {s}" for s in story(result)] + [""]
    if math.isfinite(result.gain):
        out += [f"**The held-out error with the findings is {percent(result.gain)} lower than the baseline's** "
                f"({percent(base.test_mean_rel_error)} → {percent(ext.test_mean_rel_error)}).", ""]
    out += [
        "## Models", "",
        "| model | parameters | held-out mean rel. error | training mean rel. error |",
        "|---|---|---|---|",
        f"| baseline: {base.model} | {base.n_params} | {percent(base.test_mean_rel_error)} | {percent(base.train_mean_rel_error)} |",
        f"| extended: {ext.model} | {ext.n_params} | {percent(ext.test_mean_rel_error)} | {percent(ext.train_mean_rel_error)} |",
        "",
        "The error is the mean over rows of ‖d_pred − d_meas‖ / ‖d_meas‖ (translation only).",
        "",
        "![Residuals before and after](residuals.png)", "",
        "![Error per pose](errors_per_pose.png)", "",
        "## What the baseline gets wrong", "",
    ]
    out += ["| statistic | baseline | extended |", "|---|---|---|"]

    def stat(r: ResidualStructure, key: str) -> str:
        if key == "scaled_rms":
            return _num(r.scaled_rms, ".2f")
        if key == "anova":
            return f"p = {_pval(None if r.per_pose_anova is None else r.per_pose_anova.p_value)}"
        if key == "magnitude":
            c = r.load_magnitude
            return "n/a" if c is None else f"ρ = {c.rho:+.2f}, p = {_pval(c.p_value)}"
        if key == "direction":
            d = r.load_direction
            if not isinstance(d, DirectionCorrelation):
                return "n/a"
            return (f"residual {d.residual_axis} vs force {d.force_axis}: ρ = "
                    f"{d.correlation.rho:+.2f}, p = {_pval(d.p_bonferroni)}")
        best = _strongest_torque(r)
        return "n/a" if best is None else f"joint {best[0]}: ρ = {best[1].rho:+.2f}, p = {_pval(best[1].p_value)}"

    for label, key in (
        ("scaled residual RMS (1 = noise only)", "scaled_rms"),
        ("per-pose ANOVA (configuration)", "anova"),
        ("strongest joint-torque correlation", "torque"),
        ("correlation with load magnitude", "magnitude"),
        ("strongest load-direction correlation (Bonferroni)", "direction"),
    ):
        out.append(f"| {label} | {stat(result.residuals.baseline, key)} | {stat(result.residuals.extended, key)} |")
    out += ["", "## Named effects", "", "![Candidate effects](effects.png)", ""]
    if not result.findings:
        out += ["No candidate effect passed the false-discovery-rate selection and the held-out check.", ""]
    for f in result.findings:
        ev = f.evidence
        out += [f"### {f.effect}{_where(f)}", ""]
        if isinstance(ev, Evidence):
            ft = ev.f_test
            estimate = ", ".join(f"{v:.3e}" for v in ev.estimate if isinstance(v, float))
            out += [
                f"- selection step {ev.step}: F = {_num(ft.f)} ({_num(ft.df_num, 'g')}, {_num(ft.df_den, 'g')}), "
                f"p = {_pval(ft.p_value)}, Benjamini–Hochberg threshold {_pval(ev.bh_threshold)} over "
                f"{ev.n_candidates} candidates;",
                f"- removes {percent(ev.sse_reduction)} of the training whitened SSE; held-out whitened SSE "
                f"{_num(ev.heldout_sse_before)} → {_num(ev.heldout_sse_after)};",
                f"- estimate: {estimate} {ev.unit or ''}.",
            ]
        if f.aliases:
            out.append("- cannot be told apart on these data from: " + ", ".join(
                f"{a.effect}{_where(a)} (Δχ² = {_num(a.delta_chi2, '.2f')})" for a in f.aliases
            ) + ".")
        out.append("")
    if result.rejected_on_holdout:
        out += ["Significant on the training rows but not confirmed on held-out rows: "
                + ", ".join(result.rejected_on_holdout) + ".", ""]
    out += ["## Unexplained structure", ""]
    out.append(
        "Structured residual remains after the extension that no candidate explains."
        if result.unexplained
        else "No significant structure remains in the residuals of the baseline + findings."
    )
    out += _verdict_lines(result)
    out += ["", "## Fitted parameters (baseline + findings)", "", "| parameter | value | unit |", "|---|---|---|"]
    for p in ext.parameters:
        value = "not identifiable" if p.value is None or not math.isfinite(p.value) else f"{p.value:.4e}"
        out.append(f"| {p.label} | {value} | {p.unit} |")
    out.append("")
    return "\n".join(out)


def _matrix(m: Optional[Sequence[Sequence[float]]]) -> List[str]:
    return ["| " + " | ".join(f"{v:.3f}" for v in row) + " |" for row in m or []]


def _markdown_csjm(result: Diagnosis, title: str, source: Optional[str]) -> str:
    base, ext = result.baseline, result.extended
    out = [f"# {title}", ""]
    if source:
        out += [f"Data: `{source}` — {result.n_train} training rows, {result.n_test} held-out rows.", ""]
    out += ["## Summary", ""] + [f"- {s}" for s in story(result)] + [""]
    out += [
        "## Models", "",
        "| model | parameters | held-out mean rel. error of Δζ | training |",
        "|---|---|---|---|",
        f"| baseline: {base.model} | {base.n_params} | {percent(base.test_mean_rel_error)} | {percent(base.train_mean_rel_error)} |",
        f"| extended: {ext.model} | {ext.n_params} | {percent(ext.test_mean_rel_error)} | {percent(ext.train_mean_rel_error)} |",
        "",
        "![Moment residuals before and after](residuals.png)", "",
        "Covariant stiffness K of the baseline + findings (N·m/rad, frame A at R₀):", "",
        "| | | |", "|---|---|---|", *_matrix(ext.k), "",
        "## Named effects", "", "![Candidate effects](effects.png)", "",
    ]
    for f in result.findings:
        ev = f.evidence
        out += [f"### {f.effect}", ""]
        if isinstance(ev, Evidence):
            out.append(f"- F = {_num(ev.f_test.f)}, p = {_pval(ev.f_test.p_value)}; held-out whitened SSE "
                       f"{_num(ev.heldout_sse_before)} → {_num(ev.heldout_sse_after)}.")
            if ev.interpretation:
                out.append(f"- {ev.interpretation}")
        else:
            out.append(f"- λ = {_num(ev.lambda_, '.3f')} ± {_num(ev.lambda_stderr, '.3f')} (theory 1), asymmetry "
                       f"p = {_pval(ev.p_asymmetry)}, K_D differs from K by {percent(ev.relative_difference)}: "
                       f"{ev.interpretation}")
        if f.aliases:
            out.append("- indistinguishable on these data from: " + ", ".join(a.effect for a in f.aliases) + ".")
        out.append("")
    out += ["## Unexplained structure", "",
            "Structured residual remains that no candidate explains." if result.unexplained
            else "No significant structure remains in the residuals of the baseline + findings.", ""]
    return "\n".join(out)


class atomic_directory:
    """Context manager: yields a temporary folder to fill; on success its files are moved into
    ``path`` under the rules of :mod:`robot_stiffness._outputs` (a missing folder is created, an
    empty one filled, a non-empty one refused unless ``force``, and then only the files this
    package wrote there earlier are replaced); on failure the temporary folder is removed and
    nothing else is touched."""

    def __init__(self, path: PathLike, *, force: bool = False, expected: Sequence[str] = ()) -> None:
        self._outputs = Outputs(hint="force=True")
        self._staged = self._outputs.directory(path, force=force, expected=expected)
        self.path = Path(path)

    def __enter__(self) -> Path:
        return self._staged.path

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        try:
            if exc_type is None:
                self._outputs.commit()
        finally:
            self._outputs.discard()


def as_diagnosis(result: Any) -> Diagnosis:
    """A :class:`Diagnosis`, or the dict of its ``to_dict()`` (earlier versions' result), as a
    :class:`Diagnosis`."""
    if isinstance(result, Diagnosis):
        return result
    if isinstance(result, Mapping) and {"baseline", "findings", "extended"} <= set(result):
        try:
            return Diagnosis._from_dict(result)
        except (KeyError, IndexError, TypeError, ValueError) as e:
            raise InvalidValueError(f"result is not a complete diagnosis ({type(e).__name__}: {e})") from None
    raise ArgumentTypeError(
        "result must be a diagnosis: the value returned by vjm.diagnose / csjm.diagnose or its to_dict(), "
        f"got {type(result).__name__}"
    )


def render_files(result: Any, *, title: str = "Stiffness diagnosis", source: Optional[str] = None,
                 progress: Optional[Progress] = None) -> Dict[str, bytes]:
    """The report's files in memory, ``{name: content}``, without touching the file system (so
    it can run in a worker thread while the main thread owns the outputs).
    ``progress(stage, done, total)`` is called before each file and at the end; an exception it
    raises stops the report."""
    result = as_diagnosis(result)
    csjm = is_csjm(result)

    def png(plot: Callable[[Diagnosis, _Target], None]) -> Callable[[], bytes]:
        def draw() -> bytes:
            buf = io.BytesIO()
            plot(result, buf)
            return buf.getvalue()
        return draw

    def markdown() -> bytes:
        text = _markdown_csjm(result, title, source) if csjm else _markdown(result, title, source)
        return text.encode("utf-8")

    steps: List[Tuple[str, str, Callable[[], bytes]]] = [("residuals plot", "residuals.png", png(_plot_rows))]
    if not csjm:
        steps.append(("per-pose plot", "errors_per_pose.png", png(_plot_per_pose)))
    steps.append(("effects plot", "effects.png", png(_plot_effects)))
    if not csjm:
        steps.append(("verdict plot", "verdict.png", png(_plot_verdict)))
    steps.append(("text", "report.md", markdown))
    files: Dict[str, bytes] = {}
    for i, (stage, name, make) in enumerate(steps):
        if progress is not None:
            progress(f"report: {stage}", i, len(steps))
        files[name] = make()
    if progress is not None:
        progress("report: done", len(steps), len(steps))
    return files


def save_files(files: Mapping[str, bytes], directory: PathLike) -> Path:
    """Writes :func:`render_files`' output into an existing ``directory``; returns report.md."""
    d = Path(directory)
    for name, content in files.items():
        (d / name).write_bytes(content)
    return d / "report.md"


def render_report(result: Any, directory: PathLike, *, title: str = "Stiffness diagnosis",
                  source: Optional[str] = None, progress: Optional[Progress] = None) -> Path:
    """Writes ``report.md`` and the plots into an existing ``directory`` (no atomicity); see
    :func:`render_files` for ``progress``."""
    return save_files(render_files(result, title=title, source=source, progress=progress), directory)


@checked
def write_report(result: Any, out_dir: PathLike, *, title: str = "Stiffness diagnosis",
                 source: Optional[str] = None, force: bool = False) -> Path:
    """Write the report of a diagnosis (a :class:`~robot_stiffness.results.Diagnosis` or its
    ``to_dict()``) into ``out_dir``; returns the path of ``report.md``.

    ``out_dir`` is created if missing and filled if empty. A non-empty folder raises
    :class:`~robot_stiffness.OutputPathError` unless ``force``; then only the files an earlier
    report wrote there (listed in its ``.robot-stiffness-manifest.json``, unchanged since) are
    replaced or removed, and every other file is left alone. Nothing is written unless the
    whole report was rendered."""
    data = as_diagnosis(result)
    files = CSJM_REPORT_FILES if is_csjm(data) else REPORT_FILES
    with atomic_directory(out_dir, force=force, expected=files) as tmp:
        render_report(data, tmp, title=title, source=source)
    return Path(out_dir) / "report.md"
