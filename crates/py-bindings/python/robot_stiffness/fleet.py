"""Many robots, or one large campaign, on a Dask cluster (``docs/fleet.md``).

Requires the optional extra ``robot-stiffness[dask]`` (``dask[distributed]``); the rest of the
package never imports Dask. Every function takes a ``distributed.Client`` (default: the current
one, ``distributed.get_client()``) and runs the same code as the serial calls, on the workers:

* :func:`diagnose_files` — :func:`robot_stiffness.vjm.diagnose` of one measurement file per
  robot, results in input order, identical to the serial ones;
* :func:`identify_parts` — one campaign split into parts (files, tables or arrays): each
  part's :class:`~robot_stiffness.vjm.IdentificationPartial` is computed where it is loaded,
  the parts are merged by a tree reduction on the cluster, and the result equals
  ``Robot.identify(..., method="qr")`` on all the rows to rounding (1e-12 relative is tested).

Robots, partials and results travel by pickle; a robot carries its URDF text, so workers need no
URDF file. Measurement *files* are opened by the workers: on a multi-machine cluster their paths
must be readable there (shared storage), or pass the loaded tables instead.

Example (a local cluster of two worker processes)::

    from distributed import Client, LocalCluster
    from robot_stiffness import fleet
    from robot_stiffness.vjm import Robot

    with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
        results = fleet.diagnose_files(Robot.bundled(), ["robot_01.csv", "robot_02.csv"], client=client)
        fit = fleet.identify_parts(Robot.bundled(), ["day1.csv", "day2.csv", "day3.csv"],
                                   model="extended", client=client)
"""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Union

from ._arguments import checked
from ._errors import ArgumentTypeError, InvalidValueError, StiffnessError
from ._identify_partial import IdentificationPartial
from ._vjm_data import as_measurements, diagnose
from .results import Diagnosis
from .vjm import Identification, ModelSpec, Robot

PathLike = Union[str, "os.PathLike[str]"]
ProgressCallback = Callable[[int, int], None]

__all__ = ["diagnose_files", "identify_parts", "merge_tree"]

#: Partials merged per task of the tree reduction in :func:`identify_parts` and :func:`merge_tree`.
DEFAULT_SPLIT_EVERY = 8


def _client(client: Any) -> Any:
    """``client``, or the current Dask client; a clear error when Dask is not installed."""
    if client is not None:
        if not all(hasattr(client, a) for a in ("submit", "gather", "scatter", "cancel")):
            raise ArgumentTypeError(f"client must be a distributed.Client, got {type(client).__name__}")
        return client
    try:
        from distributed import get_client  # type: ignore[import-not-found,import-untyped,unused-ignore]
    except ImportError:
        raise ImportError(
            "robot_stiffness.fleet needs Dask: pip install 'robot-stiffness[dask]'"
        ) from None
    try:
        return get_client()
    except ValueError:
        raise InvalidValueError(
            "no Dask client: start one (distributed.Client(...)) or pass client=..."
        ) from None


def _robots(robot: Union[Robot, Sequence[Robot]], n: int) -> List[Robot]:
    if isinstance(robot, Robot):
        return [robot] * n
    robots = list(robot)
    if len(robots) != n:
        raise InvalidValueError(f"got {len(robots)} robots for {n} measurement files: one robot, or one per file")
    for i, r in enumerate(robots):
        if not isinstance(r, Robot):
            raise ArgumentTypeError(f"robot[{i}] must be a robot_stiffness.vjm.Robot, got {type(r).__name__}")
    return robots


def _naming(what: str, run: Callable[[], Any]) -> Any:
    """``run()``; a package error raised by it names ``what`` (the file or part) first."""
    try:
        return run()
    except StiffnessError as e:
        if what in str(e):
            raise
        raise type(e)(f"{what}: {e}") from None


def _diagnose_file(robot: Robot, path: str, options: Dict[str, Any]) -> Diagnosis:
    """Runs on a worker: the serial :func:`diagnose` of one file."""
    return _naming(path, lambda: diagnose(robot, path, **options))


def _gather(client: Any, futures: List[Any], progress: Optional[ProgressCallback]) -> List[Any]:
    """The futures' results in order; Ctrl-C or an error cancels what is still running."""
    try:
        if progress is not None:
            from distributed import as_completed  # type: ignore[import-not-found,import-untyped,unused-ignore]

            done = 0
            for _ in as_completed(futures):
                done += 1
                progress(done, len(futures))
        return list(client.gather(futures))
    except BaseException:
        client.cancel(futures)
        raise


@checked
def diagnose_files(
    robot: Union[Robot, Sequence[Robot]],
    paths: Sequence[PathLike],
    *,
    client: Any = None,
    baseline: Any = None,
    fdr: Optional[float] = None,
    test_fraction: Optional[float] = None,
    split_seed: Optional[int] = None,
    max_findings: Optional[int] = None,
    allow_outside_limits: bool = False,
    progress: Optional[ProgressCallback] = None,
) -> List[Diagnosis]:
    """:func:`robot_stiffness.vjm.diagnose` of each measurement file, one task per file on the
    Dask ``client``; the results in the order of ``paths``, identical to the serial calls.

    ``robot``: one :class:`~robot_stiffness.vjm.Robot` for every file, or one per file. The
    diagnosis options are those of :func:`~robot_stiffness.vjm.diagnose`. ``progress(done,
    total)`` is called on this process as files finish. The first failure (its message names
    the file) is raised and the remaining tasks are cancelled; so does Ctrl-C.
    """
    if isinstance(paths, (str, os.PathLike)):
        raise ArgumentTypeError("paths must be a sequence of measurement-file paths, not one path")
    files = [os.fspath(p) for p in paths]
    robots = _robots(robot, len(files))
    options: Dict[str, Any] = dict(
        baseline=baseline, fdr=fdr, test_fraction=test_fraction, split_seed=split_seed,
        max_findings=max_findings, allow_outside_limits=bool(allow_outside_limits),
    )
    c = _client(client)
    # Each distinct robot is sent once and shared by its tasks.
    sent: Dict[int, Any] = {}
    for r in robots:
        if id(r) not in sent:
            sent[id(r)] = c.scatter(r, hash=False)
    futures = [
        c.submit(_diagnose_file, sent[id(r)], f, options, pure=False, key=f"diagnose-{i}-{os.path.basename(f)}")
        for i, (r, f) in enumerate(zip(robots, files))
    ]
    return _gather(c, futures, progress)


def _part_statistics(robot: Robot, index: int, part: Any, model: ModelSpec,
                     options: Dict[str, Any]) -> IdentificationPartial:
    """Runs on a worker: loads one part (a file is read there) and returns its statistics."""
    name = part if isinstance(part, str) else f"parts[{index}]"

    def run() -> IdentificationPartial:
        m = as_measurements(part, robot.n_joints)
        opts = dict(options)
        use_rotation = opts.pop("use_rotation")
        if use_rotation and m.rotation is None:
            raise InvalidValueError("rotations=True but this part has no rx, ry, rz columns")
        return robot.identify_partial(
            m.q, m.wrench, m.displacement, model,
            rotation=m.rotation if use_rotation else None, **opts,
        )

    return _naming(name, run)


def _merge(*parts: IdentificationPartial) -> IdentificationPartial:
    return IdentificationPartial.merge_all(parts)


def merge_tree(
    parts: Sequence[Any],
    merge: Callable[..., Any] = _merge,
    split_every: int = DEFAULT_SPLIT_EVERY,
) -> Any:
    """Reduces ``parts`` by merging consecutive groups of ``split_every`` until one is left:
    the tree :func:`identify_parts` builds on the cluster. With Dask futures and
    ``merge=lambda *g: client.submit(_merge, *g)`` it runs there; with partials, here — the
    same grouping, so the same result to the last bit."""
    if split_every < 2:
        raise InvalidValueError(f"split_every must be at least 2, got {split_every}")
    level = list(parts)
    if not level:
        raise InvalidValueError("nothing to merge: no parts")
    while len(level) > 1:
        level = [merge(*level[i:i + split_every]) if len(level[i:i + split_every]) > 1 else level[i]
                 for i in range(0, len(level), split_every)]
    return level[0]


@checked
def identify_parts(
    robot: Robot,
    parts: Sequence[Any],
    model: ModelSpec = "traditional",
    *,
    client: Any = None,
    rotations: bool = False,
    noise_sigma: Any = None,
    noise_scale_known: bool = False,
    nonnegative: bool = False,
    allow_outside_limits: bool = False,
    split_every: int = DEFAULT_SPLIT_EVERY,
) -> Identification:
    """Identifies one campaign split into ``parts`` on the Dask ``client``.

    Each part — a measurement-file path (read by the worker), a
    :class:`~robot_stiffness.vjm.Measurements` or a table — becomes an
    :class:`~robot_stiffness.vjm.IdentificationPartial` on a worker; partials are merged in
    groups of ``split_every`` (a tree, on the cluster) and the last one is solved here. The
    result equals ``robot.identify(all rows, model, method="qr")`` to rounding.
    ``rotations=True`` uses the parts' ``rx, ry, rz`` (every part must have them); the other
    options are those of :meth:`~robot_stiffness.vjm.Robot.identify`.
    """
    if not isinstance(robot, Robot):
        raise ArgumentTypeError(f"robot must be a robot_stiffness.vjm.Robot, got {type(robot).__name__}")
    if isinstance(parts, (str, os.PathLike)):
        raise ArgumentTypeError("parts must be a sequence of parts (paths, tables…), not one path")
    items = [os.fspath(p) if isinstance(p, os.PathLike) else p for p in parts]
    if not items:
        raise InvalidValueError("identify_parts needs at least one part")
    if split_every < 2:
        raise InvalidValueError(f"split_every must be at least 2, got {split_every}")
    options: Dict[str, Any] = dict(
        use_rotation=bool(rotations), noise_sigma=noise_sigma, noise_scale_known=bool(noise_scale_known),
        nonnegative=bool(nonnegative), allow_outside_limits=bool(allow_outside_limits),
    )
    if isinstance(model, str):
        spec: ModelSpec = model
    else:
        spec = [str(s) for s in model]
    c = _client(client)
    sent = c.scatter(robot, hash=False)
    futures = [c.submit(_part_statistics, sent, i, p, spec, options, pure=False) for i, p in enumerate(items)]
    submitted: List[Any] = list(futures)

    def merge_on_cluster(*group: Any) -> Any:
        f = c.submit(_merge, *group, pure=False)
        submitted.append(f)
        return f

    try:
        merged = c.gather(merge_tree(futures, merge_on_cluster, split_every))
    except BaseException:
        c.cancel(submitted)
        raise
    return merged.finish()
