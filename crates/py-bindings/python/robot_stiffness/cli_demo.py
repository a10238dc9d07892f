"""``demo``: simulate → diagnose → report on the bundled arm, in under a minute.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any, Dict, List

from . import _cli_types as T
from ._cli_context import (
    FORCE_HELP,
    add_gravity_args,
    gravity_of,
    gravity_words,
    json_text,
)
from ._interrupt import in_worker
from ._outputs import Outputs
from .cli_diagnose import diagnose_data, render_report

DEMO_EFFECTS: List[Dict[str, Any]] = [
    {"effect": "joint_tilt", "joint": 2, "axis": "x", "compliance": 6e-5},
]


def _paper_study_lines(study: Any) -> List[str]:
    """The demo's two lines on the seed study: ours next to the seed's for the same metric
    (the seed's is the error of the deflection magnitude), then the vector error."""
    paper, trad, ext = study.paper, study.traditional, study.extended
    return [
        f"Seed study (Table I poses, truth at the seed's {100 * study.torsion_share:.1f} % torsion share), "
        f"error of the deflection magnitude (the seed's metric): traditional {100 * trad.magnitude.all:.2f} % → "
        f"extended {100 * ext.magnitude.all:.2f} % over the 26 tests (seed: {100 * paper.traditional_all:.2f} % → "
        f"{100 * paper.extended_all:.2f} %); worst verification test, extended: "
        f"{100 * ext.magnitude.verification_max:.1f} % at test {ext.magnitude.verification_max_test} "
        f"(seed: {100 * paper.extended_verification_max:.1f} % at test {paper.extended_verification_max_test}).",
        f"Seed study, error of the deflection vector ‖d_pred − d‖/‖d‖ (the seed does not report it): "
        f"traditional {100 * trad.vector.all:.2f} % → extended {100 * ext.vector.all:.2f} % over the 26 tests; "
        f"worst verification test, extended: {100 * ext.vector.verification_max:.1f} % at test "
        f"{ext.vector.verification_max_test}.",
    ]


def _structural_study_lines(study: Any) -> List[str]:
    """The demo's line on the seed study with compliant links: the three models in the seed's
    metric next to the seed's two figures."""
    paper, trad, ext, full = study.paper, study.traditional, study.extended, study.full
    return [
        f"Seed study with compliant links (truth: {100 * study.torsion_share:.1f} % torsion, links "
        f"{100 * study.link_share:.1f} %, sized so the extended model keeps the seed's "
        f"{100 * paper.extended_all:.2f} % without noise), magnitude error over the 26 tests: "
        f"traditional {100 * trad.magnitude.all:.2f} % → extended {100 * ext.magnitude.all:.2f} % → "
        f"full {100 * full.magnitude.all:.2f} % (6-D link springs, {study.full_rank} identifiable of 42; "
        f"seed: {100 * paper.traditional_all:.2f} % → {100 * paper.extended_all:.2f} %); worst "
        f"verification test: extended {100 * ext.magnitude.verification_max:.1f} % at test "
        f"{ext.magnitude.verification_max_test}, full {100 * full.magnitude.verification_max:.1f} % at "
        f"test {full.magnitude.verification_max_test}.",
    ]


def cmd_demo(args: argparse.Namespace, out: Outputs) -> int:
    from .report import REPORT_FILES, story
    from .vjm import Robot, paper_study, simulate

    t0 = time.monotonic()
    directory = Path(args.out)
    files = ["campaign.csv", "truth.json", "diagnosis.json"] + [f"report/{f}" for f in REPORT_FILES]
    staged = out.directory(directory, force=args.force, flag="--out", expected=files).path
    robot = Robot.bundled()
    gravity = gravity_of(args)
    campaign = in_worker(simulate, robot, DEMO_EFFECTS, n_poses=40, wrenches_per_pose=4, seed=args.seed,
                         gravity=gravity)
    # The report's residual plot draws the per-row predictions: keep them.
    result = diagnose_data(robot, campaign.measurements, args, per_row=True)
    study = in_worker(paper_study, robot, seed=args.seed)
    structural = in_worker(paper_study, robot, links=True, seed=args.seed)
    (staged / "campaign.csv").write_text(campaign.csv, encoding="utf-8")
    (staged / "truth.json").write_text(json_text({"truth": campaign.truth.to_dict(), "spec": campaign.spec.to_dict()}), encoding="utf-8")
    (staged / "diagnosis.json").write_text(json_text(result.to_dict()), encoding="utf-8")
    report_dir = staged / "report"
    report_dir.mkdir()
    render_report(result, report_dir, args, title="Stiffness diagnosis — demo on the bundled Panda",
            source="campaign.csv (simulated)")
    out.commit()
    hidden = ", ".join(
        f"{e['effect']} at joint {e['joint']} about {e['axis']} ({e['compliance']:.0e} rad/(N·m))" for e in DEMO_EFFECTS
    )
    print(f"Simulated {len(campaign.measurements)} measurements (40 poses × 4 wrenches, laser-tracker and F/T noise, "
          f"{gravity_words(gravity)}) on the bundled Franka Panda; hidden in the truth: {hidden}.")
    for line in story(result):
        print(line)
    for line in _paper_study_lines(study) + _structural_study_lines(structural):
        print(line)
    print(f"Wrote {directory}/ (campaign.csv, diagnosis.json, report/report.md) in {time.monotonic() - t0:.1f} s.")
    return 0


def register(sub: Any) -> None:
    """Adds ``demo`` to the subcommand set ``sub``."""
    demo = sub.add_parser(
        "demo",
        help="simulate → diagnose → report on the bundled arm (< 1 min)",
        description="Simulate a campaign on the bundled Franka Panda with a hidden tilting compliance under "
        "standard gravity, diagnose it under the same gravity, write a report, and print the story.",
    )
    demo.add_argument("--out", default="robot-stiffness-demo", metavar="DIR",
                      help="output folder (default ./robot-stiffness-demo); created if missing, an "
                      "existing non-empty folder needs --force")
    demo.add_argument("--force", action="store_true", help=FORCE_HELP)
    demo.add_argument("--seed", type=T.seed, default=1, help="campaign seed (default 1)")
    demo.add_argument("--quiet", action="store_true", help="no progress display")
    add_gravity_args(demo)
    demo.set_defaults(func=cmd_demo, baseline=None, fdr=None, split_seed=None)
