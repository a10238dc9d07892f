"""The README quotes the demo's printed figures; they must be what the demo prints now.

Regenerate with `python3 scripts/figures.py` (after any change that moves the numbers).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def _figures_module():
    spec = importlib.util.spec_from_file_location("figures", ROOT / "scripts" / "figures.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("figures", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_readme_demo_block_is_what_the_demo_prints():
    figures = _figures_module()
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    quoted = figures.text_block(readme, figures.README_DEMO_HEADING)
    printed = figures.demo_output()
    assert quoted.splitlines() == printed.splitlines(), (
        "README.md 'What the demo shows' differs from `robot-stiffness demo`; "
        "run `python3 scripts/figures.py`\n--- README\n" + quoted + "--- demo\n" + printed
    )


def test_the_check_fails_on_a_changed_figure():
    # The comparison can fail: one changed digit in the quoted block is caught.
    figures = _figures_module()
    doc = "## What the demo shows\n\n```text\nBaseline: 16.03 %\n```\n"
    assert figures.text_block(doc, figures.README_DEMO_HEADING) == "Baseline: 16.03 %\n"
    replaced = figures.replace_text_block(doc, figures.README_DEMO_HEADING, "Baseline: 15.78 %\n")
    assert figures.text_block(replaced, figures.README_DEMO_HEADING) == "Baseline: 15.78 %\n"
    assert replaced != doc
