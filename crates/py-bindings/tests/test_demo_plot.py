"""The report's residual plot is drawn, checked on its pixels (issue 24): ``robot-stiffness demo``
once wrote a ``residuals.png`` holding only axes and a legend, because it diagnosed without
the per-row data, and a test of the PNG header could not see it.

:func:`assert_residuals_drawn` checks the demo's own output in ``test_cli.py``."""

from __future__ import annotations

from pathlib import Path
from typing import Dict

import numpy as np
import pytest

from robot_stiffness import vjm
from robot_stiffness.report import render_files

#: Pixels of each series' colour a drawn residual plot has at least (the demo's 160 rows draw
#: ~1.5·10⁴ blue and ~5·10³ orange ones at 110 dpi; the legend alone has 252 of each).
MIN_SERIES_PIXELS = 1500


def series_pixels(png: Path) -> Dict[str, int]:
    """Count of strongly coloured pixels of the two row sets: training rows (tab:blue and its
    dark median line) and held-out rows (tab:orange and its dark median line)."""
    import matplotlib.image as mpimg

    rgb = np.asarray(mpimg.imread(str(png)), dtype=np.float64)[..., :3]
    red, blue = rgb[..., 0], rgb[..., 2]
    saturated = rgb.max(axis=-1) - rgb.min(axis=-1) > 0.3
    return {"training": int((saturated & (blue > red + 0.3)).sum()),
            "held_out": int((saturated & (red > blue + 0.3)).sum())}


def assert_residuals_drawn(png: Path) -> None:
    """The plot shows residual bars of both row sets, not only its axes and legend."""
    counts = series_pixels(png)
    assert all(v >= MIN_SERIES_PIXELS for v in counts.values()), (
        f"{png}: the residual plot looks empty (coloured pixels per series: {counts}; "
        f"at least {MIN_SERIES_PIXELS} each expected)")


@pytest.fixture(scope="module")
def campaign(panda):
    effects = [{"effect": "joint_tilt", "joint": 2, "axis": "x", "compliance": 6e-5}]
    return vjm.simulate(panda, effects, n_poses=20, wrenches_per_pose=4, seed=1).measurements


def _residuals_png(diagnosis, tmp_path: Path) -> Path:
    files = render_files(diagnosis, title="t", source="s")
    path = tmp_path / "residuals.png"
    path.write_bytes(files["residuals.png"])
    return path


def test_a_diagnosis_with_rows_draws_both_sets(panda, campaign, tmp_path):
    diagnosis = vjm.diagnose(panda, campaign, per_row=True)
    assert_residuals_drawn(_residuals_png(diagnosis, tmp_path))


def test_the_check_fails_on_a_plot_with_only_axes(panda, campaign, tmp_path):
    """The control: without per-row data the plot has axes, a legend and a note, and the
    pixel check must refuse it (the header check passed it)."""
    diagnosis = vjm.diagnose(panda, campaign, per_row=False)
    png = _residuals_png(diagnosis, tmp_path)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(AssertionError, match="looks empty"):
        assert_residuals_drawn(png)

