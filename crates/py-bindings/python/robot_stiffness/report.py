"""A readable diagnosis report: Markdown with PNG plots (matplotlib, Agg backend).

:func:`write_report` turns the result of :func:`robot_stiffness.vjm.diagnose` into a directory
holding ``report.md`` and three plots:

* ``residuals.png`` — residual norm per measurement row, baseline vs extended model;
* ``errors_per_pose.png`` — mean relative error per pose, baseline vs extended, held-out poses
  marked;
* ``effects.png`` — the evidence for every candidate effect (first-step F-test p-values), with
  the named effects highlighted.

The report is built under a temporary name and moved into ``out_dir`` at the end, so a failure
never leaves a half-written report, and a file the package did not write is never replaced
(see :func:`write_report`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from ._arguments import checked
from ._errors import ArgumentTypeError, InvalidValueError
from ._outputs import Outputs

__all__ = ["write_report", "story", "percent", "atomic_directory", "REPORT_FILES", "CSJM_REPORT_FILES"]

#: The files of a VJM report (relative to its folder).
REPORT_FILES = ("report.md", "residuals.png", "errors_per_pose.png", "effects.png")
#: The files of a CSJM report.
CSJM_REPORT_FILES = ("report.md", "residuals.png", "effects.png")

PathLike = Union[str, "os.PathLike[str]"]


def percent(x: Optional[float]) -> str:
    """``0.0775`` → ``"7.75 %"``; None/NaN → ``"n/a"``."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{100.0 * x:.2f} %"


def _pval(p: Optional[float]) -> str:
    if p is None or not math.isfinite(p):
        return "n/a"
    return f"{p:.1e}" if p < 1e-3 else f"{p:.3f}"


def _where(f: Dict[str, Any]) -> str:
    parts = []
    if f.get("joint") is not None:
        parts.append(f"joint {f['joint']}")
    if f.get("axis") is not None:
        parts.append(f"axis {f['axis']}")
    return f" at {', '.join(parts)}" if parts else ""


def _alias_text(f: Dict[str, Any]) -> str:
    aliases = f.get("aliases") or []
    if not aliases:
        return ""
    names = []
    for a in aliases:
        label = a.get("effect", f.get("effect", ""))
        names.append(label + _where(a))
    return "; indistinguishable on these data from " + ", ".join(names)


def _what_is_wrong(r: Dict[str, Any], alpha: float = 0.01) -> str:
    """The residual-structure statistics of one fit, in words, significant ones only."""
    parts = []
    rms = r.get("scaled_rms")
    if rms is not None and math.isfinite(rms):
        parts.append(f"its residuals are {rms:.1f}× the noise level")
    anova = r.get("per_pose_anova", {}).get("p_value")
    if anova is not None and anova < alpha:
        parts.append(f"they differ between configurations (per-pose ANOVA p = {_pval(anova)})")
    mag = r.get("load_magnitude")
    if mag and mag.get("p_value", 1.0) < alpha:
        parts.append(f"they grow with the load magnitude (Spearman ρ = {mag['rho']:+.2f}, p = {_pval(mag['p_value'])})")
    best = None
    for t in r.get("torque", []):
        c = t.get("correlation")
        if c and c.get("p_value", 1.0) < alpha and (best is None or c["p_value"] < best[1]["p_value"]):
            best = (t["joint"], c)
    if best is not None:
        parts.append(f"they correlate with the torque of joint {best[0]} (ρ = {best[1]['rho']:+.2f}, p = {_pval(best[1]['p_value'])})")
    d = r.get("load_direction")
    if d and d.get("p_bonferroni", 1.0) < alpha:
        parts.append(f"residual {d['residual_axis']} depends on the force direction {d['force_axis']} "
                     f"(ρ = {d['correlation']['rho']:+.2f}, p = {_pval(d['p_bonferroni'])})")
    return "; ".join(parts)


def is_csjm(result: Dict[str, Any]) -> bool:
    """True for a CSJM diagnosis (rows carry Δζ and Δτ), False for a VJM one."""
    rows = result.get("rows") or [{}]
    return "dzeta" in rows[0] or "connection_term" in result


def _what_is_wrong_csjm(r: Dict[str, Any], alpha: float = 0.01) -> str:
    parts = []
    rms = r.get("scaled_rms")
    if rms is not None and math.isfinite(rms):
        parts.append(f"its moment residuals are {rms:.1f}× the noise level")
    mag = r.get("load_magnitude")
    if mag and mag.get("p_value", 1.0) < alpha:
        parts.append(f"they grow with the load (Spearman ρ = {mag['rho']:+.2f}, p = {_pval(mag['p_value'])})")
    d = r.get("load_direction")
    if d and d.get("p_value", 1.0) < alpha:
        parts.append(f"they depend on the load direction (ANOVA p = {_pval(d['p_value'])})")
    lu = [x for x in r.get("loading_unloading", []) if x.get("test") and x["test"].get("p_value", 1.0) < alpha]
    if lu:
        parts.append("they differ between loading and unloading about " + ", ".join(x["axis"] for x in lu)
                     + f" (p = {_pval(min(x['test']['p_value'] for x in lu))})")
    return "; ".join(parts)


def story(result: Dict[str, Any]) -> List[str]:
    """A few sentences: what the baseline got wrong, the named cause, the gain on held-out rows."""
    base = result["baseline"]
    ext = result["extended"]
    lines = [
        f"Baseline ({base['model']}, {base['n_params']} parameters): mean relative error "
        f"{percent(base['test_mean_rel_error'])} on held-out data."
    ]
    structure = result.get("residuals", {}).get("baseline", {})
    wrong = _what_is_wrong_csjm(structure) if is_csjm(result) else _what_is_wrong(structure)
    if wrong:
        lines.append("What it gets wrong: " + wrong + ".")
    findings = result.get("findings", [])
    if findings:
        for f in findings:
            ev = f.get("evidence", {})
            if f["effect"] == "connection_term":
                lines.append(
                    "K_D is measurably asymmetric as the connection term −½hat(τ₀) predicts "
                    "(connection_term): the symmetric covariant K = K_D − ½hat(τ₀) is the stiffness."
                )
                continue
            p = ev.get("f_test", {}).get("p_value")
            lines.append(
                f"Named cause: {f['effect']}{_where(f)} (F-test p = {_pval(p)}, confirmed on "
                f"held-out rows){_alias_text(f)}."
            )
    else:
        lines.append("No effect of the catalogue improves the baseline significantly.")
    gain = result.get("gain")
    lines.append(
        f"Extended model ({ext['model']}, {ext['n_params']} parameters): "
        f"{percent(ext['test_mean_rel_error'])} on held-out data"
        + (f", {percent(gain)} lower than the baseline." if gain is not None and math.isfinite(gain) else ".")
    )
    if result.get("unexplained"):
        lines.append(
            "Structured residual remains that no candidate explains (per-pose ANOVA still significant)."
        )
    return lines


def _plot_residuals(result: Dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result.get("rows", [])
    meas = np.array([r["measured"] for r in rows], dtype=float).reshape(-1, 3)
    base = np.array([r["baseline"] for r in rows], dtype=float).reshape(-1, 3)
    ext = np.array([r["extended"] for r in rows], dtype=float).reshape(-1, 3)
    test = np.array([r["set"] == "test" for r in rows], dtype=bool)
    idx = np.arange(len(rows))
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, sharey=True)
    for ax, pred, title in ((axes[0], base, "baseline"), (axes[1], ext, "extended")):
        err = 1e6 * np.linalg.norm(pred - meas, axis=1)
        # One line collection per set, not one rectangle per row: ax.bar costs ~0.5 ms a bar
        # (2.2 s for 2000 rows, minutes for a big campaign).
        width = float(np.clip(500.0 / max(len(rows), 1), 0.3, 4.0))  # points
        ax.vlines(idx[~test], 0.0, err[~test], color="tab:blue", label="training rows", linewidth=width)
        ax.vlines(idx[test], 0.0, err[test], color="tab:orange", label="held-out rows", linewidth=width)
        ax.set_ylim(bottom=0.0)
        ax.set_ylabel("‖d_pred − d_meas‖ (µm)")
        ax.set_title(f"Residuals, {title}: {result[title]['model']}", fontsize=10)
        ax.legend(loc="upper right", fontsize=8)
    axes[1].set_xlabel("measurement row")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: Up to this many poses the per-pose plot has a labelled bar pair per pose.
_LABELLED_POSES = 60


def _plot_per_pose(result: Dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    poses = result.get("per_pose", [])
    x = np.arange(len(poses))
    b = np.array([100.0 * p["baseline"] for p in poses], dtype=float)
    e = np.array([100.0 * p["extended"] for p in poses], dtype=float)
    test = np.array([p["set"] == "test" for p in poses], dtype=bool)
    fig, ax = plt.subplots(figsize=(9, 3.8))
    if len(poses) <= _LABELLED_POSES:
        ax.bar(x - 0.2, b, width=0.4, label="baseline", color="tab:red")
        ax.bar(x + 0.2, e, width=0.4, label="extended", color="tab:green")
        ax.set_xticks(x)
        ax.set_xticklabels([str(p["pose"]) for p in poses], fontsize=7)
        ax.set_xlabel("pose (shaded: held out)")
    else:
        # Many poses: one line collection per model instead of one rectangle per pose (ax.bar
        # and a span per held-out pose took 5 s for 1500 poses), no per-pose tick labels.
        width = float(np.clip(250.0 / len(poses), 0.3, 4.0))  # points
        ax.vlines(x - 0.2, 0.0, b, color="tab:red", label="baseline", linewidth=width)
        ax.vlines(x + 0.2, 0.0, e, color="tab:green", label="extended", linewidth=width)
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("pose, in file order (shaded: held out)")
    # Held-out poses: one shaded span per run of consecutive poses, in one collection.
    edges = np.flatnonzero(np.diff(np.concatenate([[0], test.astype(np.int8), [0]])))
    runs = [(float(a) - 0.5, float(b - a)) for a, b in zip(edges[::2], edges[1::2])]
    if runs:
        ax.broken_barh(runs, (0.0, 1.0), color="0.9", zorder=0, transform=ax.get_xaxis_transform())
    ax.set_ylabel("mean relative error (%)")
    ax.set_title("Error per pose", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_effects(result: Dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scores = [s for s in result.get("scores", []) if s.get("testable") and s.get("f_test")]
    scores.sort(key=lambda s: s["f_test"]["p_value"])
    scores = scores[:20]
    found = {(f["effect"], f.get("joint"), f.get("axis")) for f in result.get("findings", [])}
    labels = [s["label"] for s in scores]
    vals = [-math.log10(max(s["f_test"]["p_value"], 1e-300)) for s in scores]
    colors = [
        "tab:green" if (s["effect"], s.get("joint"), s.get("axis")) in found else "tab:gray"
        for s in scores
    ]
    fig, ax = plt.subplots(figsize=(9, max(2.5, 0.3 * len(scores) + 1)))
    y = np.arange(len(scores))
    ax.barh(y, vals, color=colors)
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=8)
    ax.invert_yaxis()
    fdr = result.get("fdr", 0.01)
    n = max(1, len([s for s in result.get("scores", []) if s.get("testable")]))
    ax.axvline(-math.log10(fdr / n), color="k", linestyle="--", linewidth=0.8,
               label=f"strictest BH threshold (q = {fdr})")
    ax.set_xlabel("−log10 p (first-step F test against the baseline)")
    ax.set_title("Candidate effects (green: named)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _markdown(result: Dict[str, Any], title: str, source: Optional[str]) -> str:
    base, ext = result["baseline"], result["extended"]
    out = [f"# {title}", ""]
    if source:
        out += [f"Data: `{source}` — {result.get('n_train', '?')} training rows, "
                f"{result.get('n_test', '?')} held-out rows.", ""]
    out += ["## Summary", ""] + [f"- {s}" for s in story(result)] + [""]
    gain = result.get("gain")
    if gain is not None and math.isfinite(gain):
        out += [f"**The extended model's held-out error is {percent(gain)} lower than the baseline's** "
                f"({percent(base['test_mean_rel_error'])} → {percent(ext['test_mean_rel_error'])}).", ""]
    out += [
        "## Models", "",
        "| model | parameters | held-out mean rel. error | training mean rel. error |",
        "|---|---|---|---|",
        f"| baseline: {base['model']} | {base['n_params']} | {percent(base['test_mean_rel_error'])} | {percent(base.get('train_mean_rel_error'))} |",
        f"| extended: {ext['model']} | {ext['n_params']} | {percent(ext['test_mean_rel_error'])} | {percent(ext.get('train_mean_rel_error'))} |",
        "",
        "The error is the mean over rows of ‖d_pred − d_meas‖ / ‖d_meas‖ (translation only).",
        "",
        "![Residuals before and after](residuals.png)", "",
        "![Error per pose](errors_per_pose.png)", "",
        "## What the baseline gets wrong", "",
    ]
    rs = result.get("residuals", {})
    out += ["| statistic | baseline | extended |", "|---|---|---|"]

    def stat(which: str, key: str) -> str:
        r = rs.get(which, {})
        if key == "scaled_rms":
            v = r.get("scaled_rms")
            return "n/a" if v is None else f"{v:.2f}"
        if key == "anova":
            return f"p = {_pval(r.get('per_pose_anova', {}).get('p_value'))}"
        if key == "magnitude":
            c = r.get("load_magnitude")
            return "n/a" if not c else f"ρ = {c['rho']:+.2f}, p = {_pval(c['p_value'])}"
        if key == "direction":
            c = r.get("load_direction")
            if not c:
                return "n/a"
            return (f"residual {c['residual_axis']} vs force {c['force_axis']}: ρ = "
                    f"{c['correlation']['rho']:+.2f}, p = {_pval(c['p_bonferroni'])}")
        if key == "torque":
            best = None
            for t in r.get("torque", []):
                c = t.get("correlation")
                if c and (best is None or c["p_value"] < best[1]["p_value"]):
                    best = (t["joint"], c)
            return "n/a" if best is None else f"joint {best[0]}: ρ = {best[1]['rho']:+.2f}, p = {_pval(best[1]['p_value'])}"
        return "n/a"

    for label, key in (
        ("scaled residual RMS (1 = noise only)", "scaled_rms"),
        ("per-pose ANOVA (configuration)", "anova"),
        ("strongest joint-torque correlation", "torque"),
        ("correlation with load magnitude", "magnitude"),
        ("strongest load-direction correlation (Bonferroni)", "direction"),
    ):
        out.append(f"| {label} | {stat('baseline', key)} | {stat('extended', key)} |")
    out += ["", "## Named effects", "", "![Candidate effects](effects.png)", ""]
    findings = result.get("findings", [])
    if not findings:
        out += ["No candidate effect passed the false-discovery-rate selection and the held-out check.", ""]
    for f in findings:
        ev = f.get("evidence", {})
        ft = ev.get("f_test", {})
        out += [
            f"### {f['effect']}{_where(f)}", "",
            f"- selection step {ev.get('step')}: F = {ft.get('f', float('nan')):.1f} "
            f"({ft.get('df_num')}, {ft.get('df_den')}), p = {_pval(ft.get('p_value'))}, "
            f"Benjamini–Hochberg threshold {_pval(ev.get('bh_threshold'))} over {ev.get('n_candidates')} candidates;",
            f"- removes {percent(ev.get('sse_reduction'))} of the training whitened SSE; held-out whitened SSE "
            f"{ev.get('heldout_sse_before', float('nan')):.1f} → {ev.get('heldout_sse_after', float('nan')):.1f};",
            f"- estimate: {', '.join(f'{v:.3e}' for v in ev.get('estimate', []))} {ev.get('unit', '')}.",
        ]
        if f.get("aliases"):
            out.append("- cannot be told apart on these data from: " + ", ".join(
                f"{a.get('effect', f['effect'])}{_where(a)} (Δχ² = {a.get('delta_chi2', float('nan')):.2f})"
                for a in f["aliases"]
            ) + ".")
        out.append("")
    rejected = result.get("rejected_on_holdout") or []
    if rejected:
        out += ["Significant on the training rows but not confirmed on held-out rows: "
                + ", ".join(rejected) + ".", ""]
    out += ["## Unexplained structure", ""]
    out.append(
        "Structured residual remains after the extension that no candidate explains."
        if result.get("unexplained")
        else "No significant structure remains in the extended model's residuals."
    )
    out += ["", "## Fitted parameters (extended model)", "", "| parameter | value | unit |", "|---|---|---|"]
    for p in ext.get("parameters", []):
        value = "not identifiable" if p["value"] is None else f"{p['value']:.4e}"
        out.append(f"| {p['label']} | {value} | {p['unit']} |")
    out.append("")
    return "\n".join(out)


class atomic_directory:
    """Context manager: yields a temporary folder to fill; on success its files are moved into
    ``path`` under the rules of :mod:`robot_stiffness._outputs` (a missing folder is created, an
    empty one filled, a non-empty one refused unless ``force``, and then only the files this
    package wrote there earlier are replaced); on failure the temporary folder is removed and
    nothing else is touched."""

    def __init__(self, path: PathLike, *, force: bool = False, expected: Sequence[str] = ()) -> None:
        self._outputs = Outputs()
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


def _plot_csjm_residuals(result: Dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result.get("rows", [])
    base = np.array([r["baseline_residual"] for r in rows], dtype=float).reshape(-1, 3)
    ext = np.array([r["extended_residual"] for r in rows], dtype=float).reshape(-1, 3)
    test = np.array([r["set"] == "test" for r in rows], dtype=bool)
    idx = np.arange(len(rows))
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, sharey=True)
    for ax, res, title in ((axes[0], base, "baseline"), (axes[1], ext, "extended")):
        err = np.linalg.norm(res, axis=1)
        # One line collection per set, not one rectangle per row: ax.bar costs ~0.5 ms a bar
        # (2.2 s for 2000 rows, minutes for a big campaign).
        width = float(np.clip(500.0 / max(len(rows), 1), 0.3, 4.0))  # points
        ax.vlines(idx[~test], 0.0, err[~test], color="tab:blue", label="training rows", linewidth=width)
        ax.vlines(idx[test], 0.0, err[test], color="tab:orange", label="held-out rows", linewidth=width)
        ax.set_ylim(bottom=0.0)
        ax.set_ylabel("‖Δτ − Δτ_pred‖ (N·m)")
        ax.set_title(f"Moment residuals, {title}: {result[title]['model']}", fontsize=10)
        ax.legend(loc="upper right", fontsize=8)
    axes[1].set_xlabel("load increment (file order)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_csjm_effects(result: Dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scores = [s for s in result.get("scores", []) if s.get("f_test")]
    found = {f["effect"] for f in result.get("findings", [])}
    labels = [s["effect"] for s in scores]
    vals = [-math.log10(max(s["f_test"]["p_value"], 1e-300)) for s in scores]
    colors = ["tab:green" if s["effect"] in found else "tab:gray" for s in scores]
    fig, ax = plt.subplots(figsize=(8, 2.5))
    y = np.arange(len(scores))
    ax.barh(y, vals, color=colors)
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=9)
    ax.invert_yaxis()
    fdr = result.get("fdr", 0.05)
    ax.axvline(-math.log10(fdr / max(1, len(scores))), color="k", linestyle="--", linewidth=0.8,
               label=f"strictest BH threshold (q = {fdr})")
    ax.set_xlabel("−log10 p (first-step F test against the baseline)")
    ax.set_title("Candidate effects (green: named)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _matrix(m: Any) -> List[str]:
    return ["| " + " | ".join(f"{v:.3f}" for v in row) + " |" for row in m]


def _markdown_csjm(result: Dict[str, Any], title: str, source: Optional[str]) -> str:
    base, ext = result["baseline"], result["extended"]
    out = [f"# {title}", ""]
    if source:
        out += [f"Data: `{source}` — {result.get('n_train', '?')} training rows, "
                f"{result.get('n_test', '?')} held-out rows.", ""]
    out += ["## Summary", ""] + [f"- {s}" for s in story(result)] + [""]
    out += [
        "## Models", "",
        "| model | parameters | held-out mean rel. error of Δζ | training |",
        "|---|---|---|---|",
        f"| baseline: {base['model']} | {base['n_params']} | {percent(base['test_mean_rel_error'])} | {percent(base.get('train_mean_rel_error'))} |",
        f"| extended: {ext['model']} | {ext['n_params']} | {percent(ext['test_mean_rel_error'])} | {percent(ext.get('train_mean_rel_error'))} |",
        "",
        "![Moment residuals before and after](residuals.png)", "",
        "Covariant stiffness K of the extended model (N·m/rad, frame A at R₀):", "",
        "| | | |", "|---|---|---|", *_matrix(ext.get("k", [])), "",
        "## Named effects", "", "![Candidate effects](effects.png)", "",
    ]
    for f in result.get("findings", []):
        ev = f.get("evidence", {})
        out.append(f"### {f['effect']}")
        out.append("")
        if "f_test" in ev:
            ft = ev["f_test"]
            out.append(f"- F = {ft.get('f', float('nan')):.1f}, p = {_pval(ft.get('p_value'))}; held-out whitened SSE "
                       f"{ev.get('heldout_sse_before', float('nan')):.1f} → {ev.get('heldout_sse_after', float('nan')):.1f}.")
            if ev.get("interpretation"):
                out.append(f"- {ev['interpretation']}")
        else:
            out.append("- " + ", ".join(f"{k} = {v}" for k, v in ev.items() if not isinstance(v, (list, dict))))
        if f.get("aliases"):
            out.append("- indistinguishable on these data from: " + ", ".join(a["effect"] for a in f["aliases"]) + ".")
        out.append("")
    out += ["## Unexplained structure", "",
            "Structured residual remains that no candidate explains." if result.get("unexplained")
            else "No significant structure remains in the extended model's residuals.", ""]
    return "\n".join(out)


def render_report(result: Dict[str, Any], directory: PathLike, *, title: str = "Stiffness diagnosis",
                  source: Optional[str] = None) -> Path:
    """Writes ``report.md`` and the plots into an existing ``directory`` (no atomicity)."""
    d = Path(directory)
    if is_csjm(result):
        _plot_csjm_residuals(result, d / "residuals.png")
        _plot_csjm_effects(result, d / "effects.png")
        md = d / "report.md"
        md.write_text(_markdown_csjm(result, title, source), encoding="utf-8")
        return md
    _plot_residuals(result, d / "residuals.png")
    _plot_per_pose(result, d / "errors_per_pose.png")
    _plot_effects(result, d / "effects.png")
    md = d / "report.md"
    md.write_text(_markdown(result, title, source), encoding="utf-8")
    return md


@checked
def write_report(result: Any, out_dir: PathLike, *, title: str = "Stiffness diagnosis",
                 source: Optional[str] = None, force: bool = False) -> Path:
    """Write the report of a diagnosis (a :class:`~robot_stiffness.vjm.Diagnosis` or its dict)
    into ``out_dir``; returns the path of ``report.md``.

    ``out_dir`` is created if missing and filled if empty. A non-empty folder raises
    :class:`~robot_stiffness.OutputPathError` unless ``force``; then only the files an earlier
    report wrote there (listed in its ``.robot-stiffness-manifest.json``, unchanged since) are
    replaced or removed, and every other file is left alone. Nothing is written unless the
    whole report was rendered."""
    data = result.to_dict() if hasattr(result, "to_dict") else result
    if not isinstance(data, dict) or not {"baseline", "findings", "extended"} <= set(data):
        raise ArgumentTypeError(
            "result must be a diagnosis: the value returned by vjm.diagnose / csjm.diagnose or its to_dict(), "
            f"got {type(result).__name__}"
        )
    files = CSJM_REPORT_FILES if is_csjm(data) else REPORT_FILES
    with atomic_directory(out_dir, force=force, expected=files) as tmp:
        try:
            render_report(data, tmp, title=title, source=source)
        except (KeyError, IndexError, TypeError) as e:
            raise InvalidValueError(f"result is not a complete diagnosis ({type(e).__name__}: {e})") from None
    return Path(out_dir) / "report.md"
