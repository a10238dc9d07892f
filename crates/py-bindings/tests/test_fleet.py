"""robot_stiffness.fleet on a real Dask cluster (2 worker processes): a fleet of 50 robots'
measurement files diagnosed, and one campaign identified from parts, identical to the serial
results. Skipped only when Dask (the ``robot-stiffness[dask]`` extra) is not installed."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator, List, Tuple

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from robot_stiffness import DataFileError, fleet  # noqa: E402
from robot_stiffness.vjm import Measurements, Robot, diagnose, simulate  # noqa: E402

N_ROBOTS = 50


@pytest.fixture(scope="module")
def client() -> Iterator[Any]:
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def fleet_files(tmp_path_factory: pytest.TempPathFactory) -> Tuple[List[Robot], List[Path]]:
    """One simulated campaign per robot, each with its own seed and hidden effect; the robots
    alternate between the flange and the TCP of the bundled arm (two different kinematics)."""
    folder = tmp_path_factory.mktemp("fleet")
    flange, tcp = Robot.bundled(), Robot.bundled("panda_hand_tcp")
    robots, paths = [], []
    for i in range(N_ROBOTS):
        robot = flange if i % 2 == 0 else tcp
        effects = [{"effect": "joint_tilt", "joint": 2 + i % 5, "axis": "xy"[i % 2], "compliance": 4e-5}] if i % 3 else []
        c = simulate(robot, effects, n_poses=24, wrenches_per_pose=4, seed=100 + i, test_fraction=0.25)
        path = folder / f"robot_{i:02d}.csv"
        path.write_text(c.csv)
        robots.append(robot)
        paths.append(path)
    return robots, paths


def test_fleet_diagnosis_equals_the_serial_one(client, fleet_files):
    robots, paths = fleet_files
    serial = [diagnose(r, p).to_dict() for r, p in zip(robots, paths)]
    seen: List[Tuple[int, int]] = []
    results = fleet.diagnose_files(robots, paths, client=client, progress=lambda d, t: seen.append((d, t)))
    assert len(results) == N_ROBOTS
    for i, (got, expect) in enumerate(zip(results, serial)):
        assert got.to_dict() == expect, f"robot {i}"
    assert seen[-1] == (N_ROBOTS, N_ROBOTS)
    # The hidden effects were found somewhere (the comparison above is not between two empties).
    assert sum(bool(r.findings) for r in results) >= N_ROBOTS // 4


def test_a_bad_file_is_named_and_the_rest_cancelled(client, fleet_files, tmp_path: Path):
    robots, paths = fleet_files
    bad = tmp_path / "broken.csv"
    lines = paths[0].read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[1].split(",")
    cells[header.index("dx")] = "nan"
    bad.write_text("\n".join([lines[0], ",".join(cells)] + lines[2:]) + "\n")
    with pytest.raises(DataFileError, match="broken.csv"):
        fleet.diagnose_files(robots[:3], [paths[1], bad, paths[2]], client=client)


@pytest.fixture(scope="module")
def campaign() -> Tuple[Robot, Measurements]:
    robot = Robot.bundled()
    effects = [{"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 5e-5}]
    return robot, simulate(robot, effects, n_poses=300, wrenches_per_pose=4, seed=9).measurements


def _rows(m: Measurements, s: int, e: int) -> Measurements:
    return Measurements(q=m.q[s:e], wrench=m.wrench[s:e], displacement=m.displacement[s:e],
                        pose=None if m.pose is None else m.pose[s:e])


def test_campaign_in_parts_equals_serial_identify(client, campaign, tmp_path: Path):
    robot, m = campaign
    cuts = [0, 150, 333, 700, 901, 1200]
    parts: List[Any] = []
    for k, (s, e) in enumerate(zip(cuts, cuts[1:])):
        rows = _rows(m, s, e)
        if k % 2 == 0:  # files, read by the workers
            path = tmp_path / f"part_{k}.csv"
            path.write_text(rows.to_csv_text())
            parts.append(path)
        else:  # loaded tables, sent to them
            parts.append(rows)
    got = fleet.identify_parts(robot, parts, "extended", client=client, split_every=2)
    # The same tree, in this process: identical to the last bit.
    local = fleet.merge_tree(
        [robot.identify_partial(_rows(m, s, e).q, _rows(m, s, e).wrench, _rows(m, s, e).displacement, "extended")
         for s, e in zip(cuts, cuts[1:])],
        split_every=2,
    ).finish()
    assert got.to_dict() == local.to_dict()
    # And the single pass over all the rows, to 1e-12 relative to the largest value.
    single = robot.identify(m.q, m.wrench, m.displacement, "extended", method="qr", gravity=None)
    assert (got.rank, got.aliases, got.n_equations) == (single.rank, single.aliases, single.n_equations)
    ok = single.identifiable
    assert np.array_equal(got.identifiable, ok)
    scale = np.max(np.abs(single.compliance[ok]))
    assert np.max(np.abs(got.compliance[ok] - single.compliance[ok])) <= 1e-12 * scale
    assert np.all(np.abs(got.stderr[ok] - single.stderr[ok]) <= 1e-12 * single.stderr[ok])


def test_a_bad_part_is_named(client, campaign):
    robot, m = campaign
    bad = _rows(m, 0, 50)
    bad.q = bad.q.copy()
    bad.q[4, 1] = 7.0  # outside joint 2's limits
    with pytest.raises(DataFileError, match=r"parts\[1\]"):
        fleet.identify_parts(robot, [_rows(m, 50, 100), bad], client=client)
