#!/usr/bin/env python3
"""Diagnose at scale through the Python package, next to identification and a numpy peer.

For each size N (``--sizes``, default 1e4, 1e5, 1e6 rows) the script simulates a seeded campaign
of the bundled Panda (``robot_stiffness.vjm.simulate``: nominal torsions plus one hidden tilt,
``HIDDEN_TILT``; 10 loads per pose; instrument noise; a quarter of the poses written as
``set = test``), saves it to a temporary ``.npz`` and, in a **fresh subprocess per size**:

* loads the arrays and builds the :class:`Measurements` (this is "the input"), warms the library
  up on the first 2000 rows, then reads the resident set size ``VmRSS`` and resets the peak
  (``echo 5 > /proc/self/clear_refs``);
* times ``vjm.diagnose(robot, data, per_row=False)`` (``--repeat`` runs, the median is reported)
  and reads ``VmHWM``: peak memory beyond the input = ``VmHWM - VmRSS`` before the call;
* the same for ``robot.identify(q, wrench, displacement, model="traditional")`` on the same rows
  (all of them: identification has no hold-out);
* checks that the diagnosis names the hidden tilt first.

``--gravity standard`` (the default) runs all of it under standard gravity with the URDF's link
masses, as the library does by default; ``--gravity none`` on a weightless arm, the problem the
numpy peer solves.

It prints a markdown table (time, per-row cost, ratio diagnose/identify, memory) and checks the
issue-12 targets: at 1e6 rows diagnose ≤ 2 s and ≤ 20 × identify, memory beyond the input
≤ 256 MB, time per row at the largest size within 1.25 × that at the next size (linearity).

**The peer** (sizes ``--peer-sizes``, default 1e4 and 1e5; same campaign files, own subprocess)
is the forward selection written the way a Python user would, with numpy only:

* Jacobians from the library (``Robot.jacobian(q, "extended")``, batched), spring torques
  τ = Jᵀ W;
* the same whitening formula as the library (docs/diagnose.md §3.1):
  Σ_i = σ_d² I₃ + G_i Σ_W G_iᵀ, G_i = J_t C Jᵀ, C from an unweighted fit of the traditional
  model on the training rows, σ from the library's default ``NoiseAssumption``; rows whitened
  by the inverse Cholesky factor of Σ_i;
* the candidate columns of §3.4 for the **joint and bias part of the catalogue only**: every
  tilt (14), every torsion hinge pair at knots {0.33, 1.0} × RMS(τ) (7), every backlash
  erf column (7) and the wrench bias (6 columns) — 29 candidates. *Not covered*: frame
  misalignment, geometric nonlinearity, mount translation/rotation (and their guard), the
  re-linearisation of bilinear columns after a finding (the peer keeps C of the first fit),
  the verdict (lack of fit, per-pose offsets), the cluster-robust test and the residual-
  structure statistics;
* per step, one ``np.linalg.lstsq`` refit per candidate on the explicit training columns,
  nested F test (p from the regularised incomplete beta function below; scipy is not
  assumed), Benjamini–Hochberg at fdr 0.01, held-out confirmation (refit must lower the
  held-out whitened SSE), aliases by |cos| ≥ 0.99 of the orthogonalised columns and by the
  F test of the finding given each other significant candidate (p > 0.05), ≤ 6 findings.

The check: the peer's first finding equals the library's on the hidden-tilt campaign (the
script exits with status 1 when it does not).

Usage (from the workspace root, with the release extension installed in the interpreter):
    python benches/diagnose_scale.py                          # 1e4, 1e5, 1e6 + peer at 1e4, 1e5
    python benches/diagnose_scale.py --sizes 10000 --peer-sizes 10000 --repeat 1   # quick
    python benches/diagnose_scale.py --stages 1000000    # where one diagnosis spends time/memory
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
SEED = 20261201
WRENCHES_PER_POSE = 10
#: The hidden effect of every campaign: a tilt of joint 3 about its x axis at 0.3 × the joint's
#: nominal torsional compliance (1.5e-4 rad/(N·m), docs/diagnose.md §2). (A J2x tilt is an exact
#: alias of J1x on this arm: both tools then name J1x, with J2x as its alias.)
HIDDEN_TILT = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 0.45e-4}
#: The library's default noise assumption (vjm::diagnose::NoiseAssumption::default()).
SIGMA_D = math.sqrt(2.0) * 0.5 * (15e-6 + 6e-6 * 2.5)
SIGMA_W = np.array([0.5, 0.5, 0.5, 0.05, 0.05, 0.05])
FDR = 0.01
ALIAS_ALPHA = 0.05
ALIAS_COSINE = 0.99
MAX_FINDINGS = 6
RANK_RTOL = 1e-7  # a candidate adds no rank when its orthogonalised norm is below this
WARMUP_ROWS = 2000
#: Targets of issue 12 (checked, printed, never asserted: this is a benchmark).
TARGET_SECONDS_1E6 = 2.0
TARGET_RATIO = 20.0
TARGET_MEMORY_MB = 256.0
LINEARITY_TOLERANCE = 1.25


# ----------------------------------------------------------------------------------------------
# Memory (Linux /proc)
# ----------------------------------------------------------------------------------------------
def _status_kb(field: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"/proc/self/status has no {field}")


def reset_peak() -> None:
    """Reset VmHWM to the current RSS (Linux ≥ 4.0)."""
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def peak_beyond(baseline_kb: int) -> float:
    return (_status_kb("VmHWM") - baseline_kb) / 1024.0


# ----------------------------------------------------------------------------------------------
# Campaign files
# ----------------------------------------------------------------------------------------------
#: Keyword arguments of ``simulate``, ``diagnose`` and ``identify`` for ``--gravity``: the
#: library's default (standard gravity along -z of the base, link masses from the URDF) or a
#: weightless arm (``gravity=None``), which is the problem the numpy peer solves and the one the
#: figures before gravity became the default (2026-12-02) were measured on.
GRAVITY_KW: Dict[str, Any] = {}


def make_campaign(n_rows: int, path: Path) -> float:
    """Simulate the seeded hidden-tilt campaign of ``n_rows`` rows into ``path`` (.npz)."""
    from robot_stiffness import vjm

    robot = vjm.Robot.bundled()
    t0 = time.perf_counter()
    c = vjm.simulate(robot, [HIDDEN_TILT], n_poses=n_rows // WRENCHES_PER_POSE,
                     wrenches_per_pose=WRENCHES_PER_POSE, seed=SEED, **GRAVITY_KW)
    elapsed = time.perf_counter() - t0
    m = c.measurements
    assert m.pose is not None and m.set is not None, "the testbed writes pose and set columns"
    np.savez(path, q=m.q, wrench=m.wrench, displacement=m.displacement, pose=m.pose,
             test=np.array([s == "test" for s in m.set]))
    return elapsed


def load_campaign(path: Path) -> Dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


# ----------------------------------------------------------------------------------------------
# Worker: the library
# ----------------------------------------------------------------------------------------------
def finding_key(effect: str, joint: Optional[int], axis: Optional[str]) -> str:
    return effect + ("" if joint is None else f" J{joint}") + ("" if axis is None else axis)


def worker_library(path: Path, repeat: int) -> Dict[str, Any]:
    from robot_stiffness import vjm

    z = load_campaign(path)
    robot = vjm.Robot.bundled()
    sets = ["test" if t else "train" for t in z["test"]]

    def measurements(rows: slice) -> "vjm.Measurements":
        return vjm.Measurements(q=z["q"][rows], wrench=z["wrench"][rows],
                                displacement=z["displacement"][rows], pose=z["pose"][rows],
                                set=sets[rows])

    data = measurements(slice(None))
    warm = measurements(slice(0, WARMUP_ROWS))
    vjm.diagnose(robot, warm, per_row=False, **GRAVITY_KW)
    robot.identify(warm.q, warm.wrench, warm.displacement, model="traditional", **GRAVITY_KW)

    rss = _status_kb("VmRSS")
    reset_peak()
    times, cpu = [], []
    d = None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        d = vjm.diagnose(robot, data, per_row=False, **GRAVITY_KW)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    mem_diag = peak_beyond(rss)

    rss = _status_kb("VmRSS")
    reset_peak()
    id_times, id_cpu = [], []
    for _ in range(max(repeat, 3)):
        t0, c0 = time.perf_counter(), time.process_time()
        robot.identify(data.q, data.wrench, data.displacement, model="traditional", **GRAVITY_KW)
        id_times.append(time.perf_counter() - t0)
        id_cpu.append(time.process_time() - c0)
    mem_id = peak_beyond(rss)
    assert d is not None
    return {
        "rows": len(data),
        "diagnose_s": times,
        "diagnose_cpu_s": cpu,
        "identify_s": id_times,
        "identify_cpu_s": id_cpu,
        "diagnose_mem_mb": mem_diag,
        "identify_mem_mb": mem_id,
        "findings": [finding_key(f.effect, f.joint, f.axis) for f in d.findings],
        "unexplained": bool(d.unexplained),
    }


def worker_stages(path: Path) -> Dict[str, Any]:
    """One diagnosis with a progress callback: wall, CPU and peak memory beyond the input per
    stage (the stage named by a report ends at that report; "kinematics" is the preparation:
    split, torque scales, pre-fit and the baseline fit that compresses the whole design)."""
    from robot_stiffness import vjm

    z = load_campaign(path)
    data = vjm.Measurements(q=z["q"], wrench=z["wrench"], displacement=z["displacement"],
                            pose=z["pose"], set=["test" if t else "train" for t in z["test"]])
    robot = vjm.Robot.bundled()
    rss = _status_kb("VmRSS")
    reset_peak()
    stages: List[Dict[str, Any]] = []
    t0, c0 = time.perf_counter(), time.process_time()
    last = [t0, c0]

    def progress(stage: str, done: int, total: int) -> None:
        t, c = time.perf_counter(), time.process_time()
        prev = stages[-1] if stages else None
        if prev is not None and prev["name"] == stage and stage == "pass over the rows" and done > prev["done"]:
            # The reports of one pass over the rows (every 4096 rows) make one line.
            prev.update(stage=f"{stage} (to {done}/{total})", done=done, wall_s=prev["wall_s"] + t - last[0],
                        cpu_s=prev["cpu_s"] + c - last[1], peak_mb=peak_beyond(rss))
        else:
            stages.append({"stage": f"{stage} {done}/{total}", "name": stage, "done": done, "wall_s": t - last[0],
                           "cpu_s": c - last[1], "peak_mb": peak_beyond(rss)})
        last[:] = [t, c]

    vjm.diagnose(robot, data, per_row=False, progress=progress, **GRAVITY_KW)
    stages.append({"stage": "returned to Python", "wall_s": time.perf_counter() - last[0],
                   "cpu_s": time.process_time() - last[1], "peak_mb": peak_beyond(rss)})
    return {"rows": len(data), "stages": stages}


# ----------------------------------------------------------------------------------------------
# Worker: the numpy peer
# ----------------------------------------------------------------------------------------------
def _betacf(a: float, b: float, x: float) -> float:
    """Continued fraction of the incomplete beta function (modified Lentz), capped."""
    tiny = 1e-300
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 100_000):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-15:
            return h
    raise RuntimeError(f"incomplete beta did not converge (a={a}, b={b}, x={x})")


def betainc(a: float, b: float, x: float) -> float:
    """Regularised incomplete beta I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    lbt = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(lbt) * _betacf(a, b, x) / a
    return 1.0 - math.exp(lbt) * _betacf(b, a, 1.0 - x) / b


def f_sf(f: float, d1: float, d2: float) -> float:
    """P(F(d1, d2) > f)."""
    if not f > 0.0:
        return 1.0
    return betainc(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f))


def benjamini_hochberg(p: List[float], q: float) -> List[bool]:
    m = len(p)
    order = sorted(range(m), key=lambda i: p[i])
    k = 0
    for rank, i in enumerate(order, start=1):
        if p[i] <= q * rank / m:
            k = rank
    keep = [False] * m
    for i in order[:k]:
        keep[i] = True
    return keep


def peer_candidates(J: np.ndarray, tau: np.ndarray, C: np.ndarray, train: np.ndarray
                    ) -> Dict[str, np.ndarray]:
    """Raw (unwhitened) candidate columns, each (N, 3, k), docs/diagnose.md §3.4."""
    n_joints = J.shape[2] // 3
    Jt = J[:, :3, :]
    out: Dict[str, np.ndarray] = {}
    for j in range(n_joints):
        for a, name in ((1, "x"), (2, "y")):
            s = 3 * j + a
            out[finding_key("joint_tilt", j + 1, name)] = (Jt[:, :, s] * tau[:, s, None])[:, :, None]
    for j in range(n_joints):
        s = 3 * j
        t = tau[:, s]
        rms = math.sqrt(float(np.mean(t[train] ** 2)))
        hinges = [np.sign(t) * np.maximum(np.abs(t) - k * rms, 0.0) for k in (0.33, 1.0)]
        out[finding_key("joint_torsion_nonlinear", j + 1, None)] = np.stack(
            [Jt[:, :, s] * h[:, None] for h in hinges], axis=2)
    erf = np.vectorize(math.erf, otypes=[float])
    for j in range(n_joints):
        s = 3 * j
        sigma_tau = np.sqrt(np.einsum("nk,k->n", J[:, :, s] ** 2, SIGMA_W ** 2))
        out[finding_key("joint_backlash", j + 1, None)] = (
            Jt[:, :, s] * (0.5 * erf(tau[:, s] / (math.sqrt(2.0) * sigma_tau)))[:, None])[:, :, None]
    G = np.einsum("nam,m,nkm->nak", Jt, C, J)  # (N, 3, 6) = J_t C Jᵀ
    out["wrench_bias"] = -G
    return out


def worker_peer(path: Path) -> Dict[str, Any]:
    from robot_stiffness import vjm

    z = load_campaign(path)
    robot = vjm.Robot.bundled()
    t_start, c_start = time.perf_counter(), time.process_time()
    q, W, d, test = z["q"], z["wrench"], z["displacement"], z["test"]
    train = ~test
    n_rows = q.shape[0]
    J = robot.jacobian(q, "extended")  # (N, 6, 21), columns [z, x, y] per joint
    t_jac = time.perf_counter() - t_start
    tau = np.einsum("nkm,nk->nm", J, W)
    Jt = J[:, :3, :]
    z_cols = np.arange(0, J.shape[2], 3)

    # Baseline design (traditional model): column j = J_t[:, jz] τ_jz.
    X0 = Jt[:, :, z_cols] * tau[:, None, z_cols]  # (N, 3, 7)
    tr3 = np.repeat(train, 3)
    c0, *_ = np.linalg.lstsq(X0.reshape(-1, X0.shape[2])[tr3], d.reshape(-1)[tr3], rcond=None)
    C = np.zeros(J.shape[2])
    C[z_cols] = c0

    # Whitening: Σ_i = σ_d² I + G Σ_W Gᵀ, rows multiplied by L_i⁻¹ (Σ_i = L_i L_iᵀ).
    G = np.einsum("nam,m,nkm->nak", Jt, C, J)
    Sigma = SIGMA_D ** 2 * np.eye(3) + np.einsum("nak,k,nbk->nab", G, SIGMA_W ** 2, G)
    Linv = np.linalg.inv(np.linalg.cholesky(Sigma))

    def whiten(cols: np.ndarray) -> np.ndarray:  # (N, 3, k) -> (3N, k)
        return np.einsum("nab,nbk->nak", Linv, cols).reshape(3 * n_rows, cols.shape[2])

    y = whiten(d[:, :, None])[:, 0]
    X = whiten(X0)
    cands = {k: whiten(v) for k, v in peer_candidates(J, tau, C, train).items()}
    t_build = time.perf_counter() - t_start

    te3 = ~tr3
    y_tr, y_te = y[tr3], y[te3]
    n_obs = int(tr3.sum())

    def fit(Xm: np.ndarray) -> Tuple[float, int, float]:
        """Training SSE, rank and held-out SSE of the least-squares fit on columns Xm."""
        coef, _, rank, _ = np.linalg.lstsq(Xm[tr3], y_tr, rcond=None)
        r = y_tr - Xm[tr3] @ coef
        e = y_te - Xm[te3] @ coef
        return float(r @ r), int(rank), float(e @ e)

    def orthogonal(Xm: np.ndarray, Zc: np.ndarray) -> np.ndarray:
        """Training rows of Zc with the span of Xm removed."""
        Q, _ = np.linalg.qr(Xm[tr3])
        Zt = Zc[tr3]
        return Zt - Q @ (Q.T @ Zt)

    findings: List[str] = []
    pool = list(cands)
    n_fits = 0
    for _step in range(MAX_FINDINGS):
        sse0, r0, hold0 = fit(X)
        n_fits += 1
        tested: List[Tuple[str, float]] = []
        for name in pool:
            sse1, r1, _ = fit(np.hstack([X, cands[name]]))
            n_fits += 1
            k = r1 - r0
            if k <= 0:
                continue  # not testable: in the model's span
            F = ((sse0 - sse1) / k) / (sse1 / (n_obs - r1))
            tested.append((name, f_sf(F, k, n_obs - r1)))
        if not tested:
            break
        keep = benjamini_hochberg([p for _, p in tested], FDR)
        significant = sorted([t for t, s in zip(tested, keep) if s], key=lambda t: t[1])
        accepted = None
        for name, _p in significant:
            _, _, hold1 = fit(np.hstack([X, cands[name]]))
            n_fits += 1
            if hold1 < hold0:
                accepted = name
                break
            pool.remove(name)  # rejected on the held-out rows
        if accepted is None:
            break
        A = cands[accepted]
        aliases = []
        a_orth = orthogonal(X, A)
        for name, _p in significant:
            if name == accepted:
                continue
            B = cands[name]
            if A.shape[1] == 1 and B.shape[1] == 1:
                b_orth = orthogonal(X, B)
                cos = float(a_orth[:, 0] @ b_orth[:, 0]) / (
                    np.linalg.norm(a_orth) * np.linalg.norm(b_orth))
                if abs(cos) >= ALIAS_COSINE:
                    aliases.append(name)
                    continue
            XB = np.hstack([X, B])
            s_b, r_b, _ = fit(XB)
            s_ab, r_ab, _ = fit(np.hstack([XB, A]))
            n_fits += 2
            k = r_ab - r_b
            if k <= 0 or f_sf(((s_b - s_ab) / k) / (s_ab / (n_obs - r_ab)), k, n_obs - r_ab) > ALIAS_ALPHA:
                aliases.append(name)
        findings.append(accepted)
        X = np.hstack([X, A])
        pool = [p for p in pool if p != accepted and p not in aliases]
    total = time.perf_counter() - t_start
    return {
        "rows": n_rows,
        "peer_s": total,
        "peer_cpu_s": time.process_time() - c_start,
        "jacobian_s": t_jac,
        "build_s": t_build,
        "lstsq_fits": n_fits,
        "candidates": len(cands),
        "findings": findings,
    }


# ----------------------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------------------
def run_worker(kind: str, path: Path, repeat: int) -> Dict[str, Any]:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", kind, "--file", str(path),
           "--repeat", str(repeat), "--gravity", "none" if GRAVITY_KW else "standard"]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def fmt_rows(n: int) -> str:
    e = int(round(math.log10(n)))
    return f"10^{e}" if 10 ** e == n else f"{n:,}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--peer-sizes", default="10000,100000")
    ap.add_argument("--repeat", type=int, default=3, help="diagnose runs per size (median)")
    ap.add_argument("--out", default=str(RESULTS / "diagnose_scale.md"))
    ap.add_argument("--stages", type=int, metavar="N",
                    help="only: one diagnosis of N rows, time and peak memory per stage")
    ap.add_argument("--gravity", choices=["standard", "none"], default="standard",
                    help="standard: the library's default, under standard gravity with the URDF's "
                    "link masses; none: a weightless arm, the problem the numpy peer solves")
    ap.add_argument("--worker", choices=["library", "peer", "stages"], help=argparse.SUPPRESS)
    ap.add_argument("--file", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be >= 1")
    if args.gravity == "none":
        GRAVITY_KW["gravity"] = None

    if args.worker:
        workers = {"library": lambda: worker_library(Path(args.file), args.repeat),
                   "peer": lambda: worker_peer(Path(args.file)),
                   "stages": lambda: worker_stages(Path(args.file))}
        print(json.dumps(workers[args.worker]()))
        return 0
    if args.stages:
        with tempfile.TemporaryDirectory(prefix="diagnose_scale_") as tmp:
            path = Path(tmp) / "campaign.npz"
            make_campaign(args.stages, path)
            res = run_worker("stages", path, 1)
        print(f"# diagnose of {fmt_rows(args.stages)} rows per stage (load average {os.getloadavg()[0]:.2f})")
        print("| stage (ends at) | wall (s) | CPU (s) | peak beyond input so far (MB) |")
        print("|---|---:|---:|---:|")
        for st in res["stages"]:
            print(f"| {st['stage']} | {st['wall_s']:.2f} | {st['cpu_s']:.2f} | {st['peak_mb']:.0f} |")
        return 0

    sizes = [int(s) for s in args.sizes.split(",") if s]
    peer_sizes = [int(s) for s in args.peer_sizes.split(",") if s]
    lines: List[str] = []

    def say(s: str = "") -> None:
        print(s, flush=True)
        lines.append(s)

    say(f"# diagnose at scale — {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    say(f"machine: {platform.machine()}, {os.cpu_count()} logical cores (shared with other jobs), "
        f"load average {os.getloadavg()[0]:.2f} at start; python {platform.python_version()}, "
        f"numpy {np.__version__}")
    say(f"campaign: bundled Panda, nominal torsions + hidden tilt {HIDDEN_TILT}, "
        f"{WRENCHES_PER_POSE} loads per pose, seed {SEED}; diagnose repeat {args.repeat} (median); "
        f"gravity: {'none (weightless arm)' if GRAVITY_KW else 'standard (the default)'}")
    say()
    lib: Dict[int, Dict[str, Any]] = {}
    peer: Dict[int, Dict[str, Any]] = {}
    disagree = False
    with tempfile.TemporaryDirectory(prefix="diagnose_scale_") as tmp:
        for n in sorted(set(sizes) | set(peer_sizes)):
            path = Path(tmp) / f"campaign_{n}.npz"
            sim_s = make_campaign(n, path)
            print(f"  simulated {n} rows in {sim_s:.1f} s", flush=True)
            if n in sizes:
                lib[n] = run_worker("library", path, args.repeat)
                print(f"  library {n}: {json.dumps(lib[n])}", flush=True)
            if n in peer_sizes:
                peer[n] = run_worker("peer", path, args.repeat)
                print(f"  peer {n}: {json.dumps(peer[n])}", flush=True)
                if n not in lib:
                    lib[n] = run_worker("library", path, 1)
            path.unlink()

    say("| rows | diagnose wall (s) | diagnose CPU (s) | per row wall (µs) | identify wall (s) | "
        "diagnose / identify (wall) | diagnose mem beyond input (MB) | identify mem (MB) | findings |")
    say("|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for n in sorted(lib):
        r = lib[n]
        td, ti = float(np.median(r["diagnose_s"])), float(np.median(r["identify_s"]))
        tc = float(np.median(r["diagnose_cpu_s"]))
        say(f"| {fmt_rows(n)} | {td:.3f} | {tc:.3f} | {td / n * 1e6:.2f} | {ti:.4f} | {td / ti:.1f} | "
            f"{r['diagnose_mem_mb']:.0f} | {r['identify_mem_mb']:.0f} | "
            f"{', '.join(r['findings']) or '—'}{' (unexplained)' if r['unexplained'] else ''} |")
    say()
    if peer:
        say("| rows | peer numpy wall (s) | of which Jacobians (s) | columns + whitening (s) | "
            "lstsq refits | library diagnose wall (s) | peer / library (wall) | peer / library (CPU) | "
            "peer findings | first finding equal |")
        say("|---:|---:|---:|---:|---:|---:|---:|---:|---|---|")
        for n in sorted(peer):
            p, r = peer[n], lib[n]
            td = float(np.median(r["diagnose_s"]))
            tc = float(np.median(r["diagnose_cpu_s"]))
            same = bool(p["findings"]) and bool(r["findings"]) and p["findings"][0] == r["findings"][0]
            disagree = disagree or not same
            say(f"| {fmt_rows(n)} | {p['peer_s']:.2f} | {p['jacobian_s']:.3f} | {p['build_s']:.2f} | "
                f"{p['lstsq_fits']} | {td:.3f} | {p['peer_s'] / td:.1f} | {p['peer_cpu_s'] / tc:.1f} | "
                f"{', '.join(p['findings']) or '—'} | {'yes' if same else 'NO'} |")
        say()

    say("checks (issue 12 targets; reported, not asserted):")
    hidden = finding_key(HIDDEN_TILT["effect"], HIDDEN_TILT["joint"], HIDDEN_TILT["axis"])  # type: ignore[arg-type]
    for n in sorted(lib):
        first = lib[n]["findings"][0] if lib[n]["findings"] else None
        say(f"- {fmt_rows(n)}: library's first finding is the hidden tilt {hidden}: "
            f"{'yes' if first == hidden else f'NO ({first})'}")
    if 1_000_000 in lib:
        r = lib[1_000_000]
        td, ti = float(np.median(r["diagnose_s"])), float(np.median(r["identify_s"]))
        say(f"- 10^6 diagnose ≤ {TARGET_SECONDS_1E6} s: {td:.2f} s → {'PASS' if td <= TARGET_SECONDS_1E6 else 'FAIL'}")
        say(f"- 10^6 diagnose/identify ≤ {TARGET_RATIO}: {td / ti:.1f} → {'PASS' if td / ti <= TARGET_RATIO else 'FAIL'}")
    worst = max(lib[n]["diagnose_mem_mb"] for n in lib)
    say(f"- memory beyond the input ≤ {TARGET_MEMORY_MB:.0f} MB at every size: worst {worst:.0f} MB → "
        f"{'PASS' if worst <= TARGET_MEMORY_MB else 'FAIL'}")
    big = sorted(n for n in lib if n >= 10_000)
    for a, b in zip(big, big[1:]):
        pa = float(np.median(lib[a]["diagnose_s"])) / a
        pb = float(np.median(lib[b]["diagnose_s"])) / b
        say(f"- linear {fmt_rows(a)} → {fmt_rows(b)}: per-row time ratio {pb / pa:.2f} "
            f"(≤ {LINEARITY_TOLERANCE}) → {'PASS' if pb / pa <= LINEARITY_TOLERANCE else 'FAIL'}")

    say(f"load average at the end: {os.getloadavg()[0]:.2f} (wall times above include waiting for "
        f"cores held by other processes; CPU time is process CPU of all threads)")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    out.with_suffix(".json").write_text(json.dumps({"library": lib, "peer": peer}, indent=1) + "\n")
    print(f"wrote {out} and {out.with_suffix('.json')}")
    if disagree:
        print("the peer's first finding differs from the library's (table above)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
