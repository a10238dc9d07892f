#!/usr/bin/env python3
"""Peer comparison: the 21-parameter VJM identification in robot-stiffness vs numpy + pinocchio.

The peer is the pipeline a careful Python user would write today (seed 002, eqs. 8-12):

* kinematics with pinocchio (``pin.buildModelFromUrdf``), in two variants:
  - ``loop``: ``pin.forwardKinematics`` per configuration, reading ``data.oMi`` / ``data.oMf``;
  - ``vectorised``: forward kinematics over all N configurations at once in numpy, composed
    from pinocchio's ``model.jointPlacements`` and joint axes (checked against ``loop``);
* virtual-joint Jacobian columns per docs/conventions.md: every actuated joint j carries
  springs ``[z, x, y]`` in its child frame (z the joint axis a, x = normalize(x̂ - (x̂·a)a),
  y = a × x); a unit rotation about world axis w through the joint origin p_j moves the tip
  point by w × (p_tip - p_j);
* the regressor A = J_lin diag(Jᵀ F) stacked over the measurements (3N × 21, eq. 10),
  vectorised with numpy;
* a rank-revealing least-squares solve (column equilibration + thin SVD, singular values
  below ``RCOND · s_max`` dropped), which also tells which compliances are identifiable
  (those whose unit vector lies in the row space of A).

Both tools get the same seeded data (``numpy.random.default_rng(SEED)``); the displacements are
generated from known compliances with the peer's Jacobian plus seeded 1 µm sensor noise.  The
script checks that both tools report the same identifiable set and agree on every identifiable
compliance to ``AGREE_RTOL`` (relative to the largest true compliance), prints a table of
times and ratios and writes ``results/peer_table.md`` and ``results/scaling.png``.

The Rust side is called through the Python package (``robot_stiffness``) when it is importable,
otherwise through the ``vjm-identify-raw`` binary of this package (raw little-endian f64 files);
``--rust bin`` forces the binary.  Every figure printed is measured in this run: when a size is
skipped for the peer (``--peer-loop-max``), the table says so instead of extrapolating.

Usage (from the workspace root):
    python3 benches/peer_compare.py                       # N = 1e3 .. 1e6
    python3 benches/peer_compare.py --sizes 1000,10000    # quick check
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parent.parent
BUNDLED_URDF = ROOT / "crates" / "vjm" / "data" / "panda_arm.urdf"
RESULTS = Path(__file__).resolve().parent / "results"
SEED = 20240607
RCOND = 1e-10  # relative singular-value cut-off of the equilibrated regressor
AGREE_RTOL = 1e-6  # identifiable compliances: |c_rust - c_peer| <= AGREE_RTOL * max|c_true|
NOISE_STD = 1e-6  # m, per displacement component (seeded)


# ----------------------------------------------------------------------------------------------
# Chain and spring axes
# ----------------------------------------------------------------------------------------------
@dataclass
class Chain:
    """A serial chain from the URDF root to ``tip``, as pinocchio sees it."""

    model: pin.Model
    data: pin.Data
    tip_frame: int
    joints: list[int]  # pinocchio joint ids, base -> tip
    axes: np.ndarray  # (n, 3) joint axis a in the joint (child) frame
    springs: np.ndarray  # (n, 3, 3): columns [z, x, y] of each joint's springs, joint frame
    q_lower: np.ndarray
    q_upper: np.ndarray


def spring_axes(a: np.ndarray) -> np.ndarray:
    """Columns [z, x, y] of the virtual springs of a joint with axis ``a`` (docs/conventions.md)."""
    a = a / np.linalg.norm(a)
    ref = np.array([1.0, 0.0, 0.0])
    if np.linalg.norm(ref - ref.dot(a) * a) < 1e-9:  # x ∥ a
        ref = np.array([0.0, 1.0, 0.0])
    u = ref - ref.dot(a) * a
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    return np.column_stack([a, u, v])


def joint_axis(jm) -> np.ndarray:
    name = jm.shortname()
    for suffix, axis in (("RX", (1, 0, 0)), ("RY", (0, 1, 0)), ("RZ", (0, 0, 1))):
        if name == "JointModel" + suffix:
            return np.array(axis, dtype=float)
    if name == "JointModelRevoluteUnaligned":
        return np.array(jm.axis, dtype=float)
    raise ValueError(f"joint type {name} is not a revolute joint")


def load_chain(urdf: Path, tip: str) -> Chain:
    full = pin.buildModelFromUrdf(str(urdf))
    if not full.existFrame(tip):
        raise SystemExit(f"tip link {tip!r} not found in {urdf}")
    tip_joint = full.frames[full.getFrameId(tip)].parentJoint
    chain = set(full.supports[tip_joint].tolist())
    lock = [j for j in range(1, full.njoints) if j not in chain]
    model = (
        pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    )  # e.g. the fingers of a full Panda
    joints = list(range(1, model.njoints))
    axes = np.array([joint_axis(model.joints[j]) for j in joints])
    return Chain(
        model=model,
        data=model.createData(),
        tip_frame=model.getFrameId(tip),
        joints=joints,
        axes=axes,
        springs=np.array([spring_axes(a) for a in axes]),
        q_lower=np.array(model.lowerPositionLimit),
        q_upper=np.array(model.upperPositionLimit),
    )


# ----------------------------------------------------------------------------------------------
# Kinematics: joint frames (R_j, p_j) and tip point, base frame, for N configurations
# ----------------------------------------------------------------------------------------------
def kinematics_loop(ch: Chain, q: np.ndarray):
    """pinocchio forward kinematics, one configuration at a time."""
    n, nj = q.shape
    R = np.empty((n, nj, 3, 3))
    p = np.empty((n, nj, 3))
    tip = np.empty((n, 3))
    model, data, f = ch.model, ch.data, ch.tip_frame
    for i in range(n):
        pin.forwardKinematics(model, data, q[i])
        for k, j in enumerate(ch.joints):
            M = data.oMi[j]
            R[i, k] = M.rotation
            p[i, k] = M.translation
        tip[i] = pin.updateFramePlacement(model, data, f).translation
    return R, p, tip


def _rotations(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues for one axis and many angles: (N, 3, 3)."""
    K = pin.skew(axis)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def kinematics_vectorised(ch: Chain, q: np.ndarray):
    """The same forward kinematics, batched over N in numpy from pinocchio's joint placements."""
    model = ch.model
    n, nj = q.shape
    R = np.empty((n, nj, 3, 3))
    p = np.empty((n, nj, 3))
    Rp = np.broadcast_to(np.eye(3), (n, 3, 3))
    pp = np.zeros((n, 3))
    for k, j in enumerate(ch.joints):
        if model.parents[j] != (ch.joints[k - 1] if k else 0):
            raise ValueError("the vectorised kinematics expects a serial chain")
        P = model.jointPlacements[j]
        pp = pp + Rp @ P.translation
        Rp = (Rp @ P.rotation) @ _rotations(ch.axes[k], q[:, k])
        R[:, k], p[:, k] = Rp, pp
    F = model.frames[ch.tip_frame]
    last = ch.joints.index(F.parentJoint)
    tip = p[:, last] + R[:, last] @ F.placement.translation
    return R, p, tip


# ----------------------------------------------------------------------------------------------
# Regressor (seed eq. 10, translational rows) and rank-revealing solve (eqs. 11-12)
# ----------------------------------------------------------------------------------------------
def regressor(ch: Chain, R, p, tip, wrench, model: str) -> np.ndarray:
    """A (3N × m): row 3i+r, column s = J_lin[r, s] · (Jᵀ F)[s] for measurement i."""
    springs = ch.springs if model == "extended" else ch.springs[:, :, :1]
    W = np.einsum("njab,jbk->njka", R, springs)  # world spring axes (N, n, k, 3)
    lin = np.cross(W, (tip[:, None, :] - p)[:, :, None, :])  # (N, n, k, 3)
    jtf = np.einsum("njka,na->njk", lin, wrench[:, :3]) + np.einsum(
        "njka,na->njk", W, wrench[:, 3:]
    )
    A = lin * jtf[..., None]  # (N, n, k, 3)
    n = A.shape[0]
    return np.ascontiguousarray(A.transpose(0, 3, 1, 2)).reshape(3 * n, -1)


@dataclass
class Fit:
    compliance: np.ndarray  # NaN where not identifiable
    identifiable: np.ndarray  # bool
    rank: int
    seconds: dict = field(default_factory=dict)


def solve_rank_revealing(A: np.ndarray, b: np.ndarray) -> Fit:
    scale = np.linalg.norm(A, axis=0)
    # A column that is zero up to rounding (e.g. torsion of the last joint when the tip lies on
    # its axis) must stay zero, not be blown up to unit norm by the equilibration.
    scale[scale <= 1e-12 * scale.max()] = np.inf
    U, s, Vt = np.linalg.svd(A / scale, full_matrices=False)
    rank = int(np.sum(s > RCOND * s[0]))
    x = Vt[:rank].T @ ((U[:, :rank].T @ b) / s[:rank]) / scale
    null = Vt[rank:]
    identifiable = np.linalg.norm(null, axis=0) < 1e-6
    x[~identifiable] = np.nan
    return Fit(compliance=x, identifiable=identifiable, rank=rank)


def peer_identify(ch: Chain, q, wrench, disp, model: str, kinematics) -> Fit:
    c0, t0 = time.process_time(), time.perf_counter()
    R, p, tip = kinematics(ch, q)
    t1 = time.perf_counter()
    A = regressor(ch, R, p, tip, wrench, model)
    del R, p
    t2 = time.perf_counter()
    fit = solve_rank_revealing(A, disp.reshape(-1))
    t3 = time.perf_counter()
    fit.seconds = {"kinematics": t1 - t0, "regressor": t2 - t1, "solve": t3 - t2, "total": t3 - t0,
                   "cpu": time.process_time() - c0}
    return fit


# ----------------------------------------------------------------------------------------------
# Seeded data
# ----------------------------------------------------------------------------------------------
def true_compliances(n_joints: int, rng: np.random.Generator) -> np.ndarray:
    """Extended-model compliances, rad/(N·m), order joint-major [z, x, y]."""
    torsion = rng.uniform(2e-5, 2e-4, n_joints)  # 5e3 .. 5e4 N·m/rad
    tilt = rng.uniform(2e-6, 2e-5, (n_joints, 2))
    return np.column_stack([torsion, tilt]).reshape(-1)


def generate(ch: Chain, n: int, seed: int = SEED):
    rng = np.random.default_rng(seed)
    c = true_compliances(len(ch.joints), rng)
    q = rng.uniform(ch.q_lower, ch.q_upper, (n, len(ch.joints)))
    wrench = np.column_stack([rng.uniform(-50, 50, (n, 3)), rng.uniform(-5, 5, (n, 3))])
    disp = np.empty((n, 3))
    for s in range(0, n, 100_000):  # bounded memory for the data generation itself
        e = min(n, s + 100_000)
        A = regressor(ch, *kinematics_vectorised(ch, q[s:e]), wrench[s:e], "extended")
        disp[s:e] = (A @ c).reshape(-1, 3)
    disp += rng.normal(0.0, NOISE_STD, disp.shape)
    return c, q, wrench, disp


# ----------------------------------------------------------------------------------------------
# Rust side
# ----------------------------------------------------------------------------------------------
def _bin_path() -> Path | None:
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    exe = target / "release" / "vjm-identify-raw"
    return exe if exe.exists() else None


def rust_identify_bin(q, wrench, disp, model: str, repeats: int) -> Fit:
    exe = _bin_path()
    if exe is None:
        raise SystemExit(
            "vjm-identify-raw not built: cargo build --release -p robot-stiffness-benches "
            "--bin vjm-identify-raw (with the same CARGO_TARGET_DIR)"
        )
    with tempfile.TemporaryDirectory() as d:
        for name, arr in (("q", q), ("wrench", wrench), ("disp", disp)):
            np.ascontiguousarray(arr, dtype="<f8").tofile(Path(d) / f"{name}.f64")
        out = subprocess.run(
            [str(exe), "--dir", d, "--n", str(q.shape[0]), "--model", model,
             "--repeats", str(repeats), "--json"],
            check=True, capture_output=True, text=True,
        ).stdout
    res = json.loads(out)
    c = np.array([np.nan if v is None else v for v in res["compliance"]])
    fit = Fit(compliance=c, identifiable=~np.isnan(c), rank=int(res["rank"]))
    cpu = res.get("cpu_seconds_mean")
    fit.seconds = {"total": float(res["seconds_best"]), "cpu": float("nan") if cpu is None else float(cpu)}
    return fit


def rust_identify_python(rs, q, wrench, disp, model: str, repeats: int) -> Fit:
    robot = rs.Robot.bundled()
    best, best_cpu, result = np.inf, np.inf, None
    for _ in range(repeats):
        c0, t0 = time.process_time(), time.perf_counter()
        result = robot.identify(q, wrench, disp, model=model)
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    c = np.array([np.nan if v is None else v for v in result.compliance], dtype=float)
    fit = Fit(compliance=c, identifiable=~np.isnan(c), rank=int(result.rank))
    fit.seconds = {"total": best, "cpu": best_cpu}
    return fit


# ----------------------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------------------
def best_of(repeats: int, f):
    fits = [f() for _ in range(repeats)]
    best = min(fits, key=lambda x: x.seconds["total"])
    return best


def compare(ref: Fit, other: Fit, c_true: np.ndarray) -> tuple[float, str]:
    """(max relative difference on the identifiable compliances, "" or what disagrees)."""
    problems = []
    if ref.rank != other.rank:
        problems.append(f"rank {other.rank} vs peer {ref.rank}")
    both = ref.identifiable & other.identifiable
    only_other = np.flatnonzero(other.identifiable & ~ref.identifiable)
    only_ref = np.flatnonzero(ref.identifiable & ~other.identifiable)
    if only_other.size:
        problems.append(f"estimates parameters {only_other.tolist()} that the peer finds "
                        f"unidentifiable (values {other.compliance[only_other].tolist()})")
    if only_ref.size:
        problems.append(f"reports parameters {only_ref.tolist()} unidentifiable, peer does not")
    err = float(np.max(np.abs(ref.compliance[both] - other.compliance[both]), initial=0.0)
                / np.max(np.abs(c_true)))
    if err > AGREE_RTOL:
        problems.append(f"identifiable compliances differ by {err:.3e} (> {AGREE_RTOL:g})")
    return err, "; ".join(problems)


def fmt_s(x):
    if x is None:
        return "not run"
    return f"{x * 1e3:.1f} ms" if x < 10 else f"{x:.1f} s"


def machine() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        name = next(l.split(":", 1)[1].strip() for l in out.splitlines() if "Model name" in l)
    except Exception:  # noqa: BLE001 - lscpu missing: fall back to platform
        name = platform.processor() or platform.machine()
    return f"{name}, {os.cpu_count()} cores"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--urdf", type=Path, default=BUNDLED_URDF)
    ap.add_argument("--tip", default=None, help="tip link (default: read from the bundled robot)")
    ap.add_argument("--sizes", default="1000,10000,100000,1000000")
    ap.add_argument("--repeats", type=int, default=3, help="best of R runs (1 at N = 1e6)")
    ap.add_argument("--peer-loop-max", type=int, default=1_000_000,
                    help="largest N for the per-configuration pinocchio loop")
    ap.add_argument("--rust", choices=["auto", "python", "bin"], default="auto")
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args()

    rs = None
    if args.rust in ("auto", "python"):
        try:
            import robot_stiffness.vjm as rs  # noqa: PLC0415
        except ImportError:
            if args.rust == "python":
                raise
    via = "robot_stiffness (Python package)" if rs is not None else "vjm-identify-raw (Rust binary)"

    # The tip of the bundled robot is vjm's BUNDLED_FLANGE; both sides must use the same one.
    tip = args.tip or "panda_link8"
    if rs is not None and rs.Robot.bundled().tip_link != tip:
        raise SystemExit(f"the Rust side's bundled tip is {rs.Robot.bundled().tip_link}, not {tip}")
    ch = load_chain(args.urdf, tip)
    sizes = [int(float(s)) for s in args.sizes.split(",")]

    # The batched numpy kinematics must equal pinocchio's own, or the comparison means nothing.
    _, q0, _, _ = generate(ch, 200, SEED + 1)
    kl, kv = kinematics_loop(ch, q0), kinematics_vectorised(ch, q0)
    kin_err = max(float(np.max(np.abs(a - b))) for a, b in zip(kl, kv))
    assert kin_err < 1e-12, f"vectorised kinematics differ from pinocchio by {kin_err}"

    print(f"machine: {machine()}; numpy {np.__version__}, pinocchio {pin.__version__}")
    print(f"robot: {args.urdf.name} tip {tip}, {len(ch.joints)} joints; rust via {via}")
    rows = []
    for n in sizes:
        reps = args.repeats if n < 1_000_000 else 1
        c_true, q, wrench, disp = generate(ch, n)
        for model in ("extended", "traditional"):
            vec = best_of(reps, lambda: peer_identify(ch, q, wrench, disp, model,
                                                      kinematics_vectorised))
            loop = None
            if model == "extended" and n <= args.peer_loop_max:
                loop = best_of(1 if n >= 100_000 else reps,
                               lambda: peer_identify(ch, q, wrench, disp, model, kinematics_loop))
            if rs is not None:
                rust = rust_identify_python(rs, q, wrench, disp, model, reps)
            else:
                rust = rust_identify_bin(q, wrench, disp, model, reps)
            truth = c_true if model == "extended" else c_true.reshape(-1, 3)[:, 0]
            err, problem = compare(vec, rust, truth)
            if loop is not None:
                loop_err, loop_problem = compare(vec, loop, truth)
                if loop_problem:  # both peers are the same mathematics: this is a script bug
                    raise SystemExit(f"peer variants disagree: {loop_problem}")
            peer_best = min(vec.seconds["total"], loop.seconds["total"] if loop else np.inf)
            peer_best_cpu = min(vec.seconds["cpu"], loop.seconds["cpu"] if loop else np.inf)
            row = dict(
                n=n, model=model, params=len(truth), rank=vec.rank,
                rust=rust.seconds["total"], rust_cpu=rust.seconds["cpu"],
                peer_vec=vec.seconds["total"], peer_vec_parts=vec.seconds,
                peer_loop=loop.seconds["total"] if loop else None,
                peer_loop_cpu=loop.seconds["cpu"] if loop else None,
                ratio=peer_best / rust.seconds["total"],
                ratio_cpu=peer_best_cpu / rust.seconds["cpu"] if rust.seconds["cpu"] > 0 else np.nan,
                load=os.getloadavg()[0], agree=err, problem=problem,
                unidentifiable=[int(i) for i in np.flatnonzero(~vec.identifiable)],
            )
            rows.append(row)
            print(
                f"N={n:>8} {model:11} rank {row['rank']:2}/{row['params']:2}  rust {fmt_s(row['rust']):>10}"
                f"  peer vec {fmt_s(row['peer_vec']):>10}  peer loop {fmt_s(row['peer_loop']):>10}"
                f"  ratio {row['ratio']:7.1f}x (cpu {row['ratio_cpu']:.1f}x, rust cpu {fmt_s(row['rust_cpu'])})"
                f"  load {row['load']:.1f}  agree {err:.1e}"
                + (f"  DISAGREE: rust {problem}" if problem else ""),
                flush=True,
            )
        del q, wrench, disp

    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / "peer_table.md", rows, via, tip, args)
    (args.out / "peer_results.json").write_text(json.dumps(rows, indent=1))
    plot(args.out / "scaling.png", rows)
    print(f"wrote {args.out / 'peer_table.md'}, {args.out / 'scaling.png'}")
    if any(r["problem"] for r in rows):
        print("robot-stiffness and the peer DISAGREE (see the table)", file=sys.stderr)
        return 1
    return 0


def write_table(path: Path, rows, via: str, tip: str, args) -> None:
    lines = [
        f"Measured on {machine()} by `python3 benches/peer_compare.py --sizes {args.sizes}` "
        f"(numpy {np.__version__}, pinocchio {pin.__version__}; Rust via {via}; robot "
        f"`{args.urdf.name}`, tip `{tip}`; best of {args.repeats} runs below N = 1e6, one run at 1e6).",
        "",
        "| N | model | rank | robot-stiffness wall (CPU) | numpy + pinocchio, vectorised FK, wall (CPU) | "
        "numpy + pinocchio, FK loop, wall (CPU) | speed-up vs faster peer, wall (CPU) | 1-min load | agreement |",
        "|---:|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        if r["model"] != "extended":
            loop = "—"
        elif r["peer_loop"] is None:
            loop = "not run (`--peer-loop-max`)"
        else:
            loop = f"{fmt_s(r['peer_loop'])} ({fmt_s(r['peer_loop_cpu'])})"
        agree = f"**disagree**: robot-stiffness {r['problem']}" if r["problem"] else f"{r['agree']:.1e}"
        lines.append(
            f"| {r['n']:.0e} | {r['model']} | {r['rank']}/{r['params']} | "
            f"{fmt_s(r['rust'])} ({fmt_s(r['rust_cpu'])}) | "
            f"{fmt_s(r['peer_vec'])} ({fmt_s(r['peer_vec_parts']['cpu'])}) | {loop} | "
            f"{r['ratio']:.1f}× ({r['ratio_cpu']:.1f}×) | {r['load']:.1f} | {agree} |"
        )
    lines += [
        "",
        "Wall: elapsed time of kinematics + regressor + rank-revealing solve. CPU: process CPU time "
        "(all threads) of the same run, which does not grow when other processes compete for the "
        "2 cores (the 1-min load average at the end of the row is shown).",
        "Agreement: max |c_rust − c_peer| over the compliances both report identifiable, relative to "
        f"the largest true compliance (must be ≤ {AGREE_RTOL:g}); both tools must also report the same "
        "rank and the same identifiable set.",
    ]
    path.write_text("\n".join(lines) + "\n")


def plot(path: Path, rows) -> None:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    ext = [r for r in rows if r["model"] == "extended"]
    trad = [r for r in rows if r["model"] == "traditional"]
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    ax.loglog([r["n"] for r in ext], [r["rust"] for r in ext], "o-", label="robot-stiffness, 21 params")
    ax.loglog([r["n"] for r in trad], [r["rust"] for r in trad], "o--", label="robot-stiffness, 7 params")
    ax.loglog([r["n"] for r in ext], [r["peer_vec"] for r in ext], "s-",
              label="numpy + pinocchio (vectorised FK), 21")
    lp = [r for r in ext if r["peer_loop"] is not None]
    ax.loglog([r["n"] for r in lp], [r["peer_loop"] for r in lp], "^-",
              label="numpy + pinocchio (FK loop), 21")
    n0, t0 = ext[0]["n"], ext[0]["rust"]
    ns = np.array([r["n"] for r in ext], dtype=float)
    ax.loglog(ns, t0 * ns / n0, ":", color="grey", label="linear in N")
    ax.set_xlabel("measurements N")
    ax.set_ylabel("identification time [s]")
    ax.set_title("VJM identification, bundled 7-DoF arm (best of runs)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    sys.exit(main())
