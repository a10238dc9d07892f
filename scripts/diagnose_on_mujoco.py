"""`diagnose` on campaigns measured in MuJoCo with gravity on: the tables of docs/gravity.md,
"Diagnose on MuJoCo campaigns".

    python3 scripts/diagnose_on_mujoco.py [--seeds 20] [--sigmas 10,5] [--arms panda,xarm7,ur10,kinova] [--weightless]

Each campaign is diagnosed under the gravity it was measured with (``vjm.diagnose(gravity=)``);
``--weightless`` diagnoses with a weightless model instead (the baseline issue 22 started from).

Per arm, tracker noise and scenario, ``--seeds`` campaigns of 40 poses × 4 wrenches recorded in
MuJoCo (crates/py-bindings/tests/mujoco_campaign.py: loaded − unloaded at static equilibrium
under gravity, Panda-class torsions 2–10 kN·m/rad, F/T noise 0.5 N / 0.05 N·m), each diagnosed
twice: without and with the noise levels given. Scenario seeds are shared, so the scenarios of
one seed have the same torsions and poses. Seeded: the same command prints the same table.
Needs mujoco and example-robot-data (scripts/test.sh installs both).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "crates" / "py-bindings" / "tests"))

import mujoco_campaign as mc  # noqa: E402

#: 0-based shoulder and elbow joints per arm (the joints that carry the most weight).
SHOULDER = {"panda": 1, "xarm7": 1, "ur10": 1, "kinova": 1}
ELBOW = {"panda": 3, "xarm7": 3, "ur10": 2, "kinova": 2}

SEED0 = 22000


def scenarios(arm: str) -> List[Tuple[str, mc.Hidden, bool]]:
    """(label, hidden effect, gravity on) per scenario."""
    s, e = SHOULDER[arm], ELBOW[arm]
    return [
        ("clean, g = 0", mc.CLEAN, False),
        ("clean", mc.CLEAN, True),
        (f"tilt J{s + 1}x", mc.tilt(s, kx=mc.TILT_K, ky=mc.STIFF), True),
        (f"tilt J{e + 1}x+y", mc.tilt(e, kx=mc.TILT_K, ky=mc.TILT_K), True),
        (f"gear J{s + 1}", mc.gear(s), True),
        (f"gear J{e + 1}", mc.gear(e), True),
    ]


def pct(flags: List[bool]) -> str:
    return f"{100.0 * sum(flags) / len(flags):.0f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--sigmas", default="10,5", help="tracker noise per axis, µm, comma-separated")
    ap.add_argument("--arms", default="panda,xarm7,ur10,kinova")
    ap.add_argument("--weightless", action="store_true", help="diagnose with a weightless model")
    args = ap.parse_args()
    if not 1 <= args.seeds <= 1000:
        raise SystemExit(f"--seeds must be in 1..1000, got {args.seeds}")
    arms = [a.strip() for a in args.arms.split(",") if a.strip()]
    unknown = [a for a in arms if a not in mc.ARMS]
    if unknown:
        raise SystemExit(f"--arms: unknown arm(s) {', '.join(unknown)}; known: {', '.join(mc.ARMS)}")
    sigmas = [float(x) * 1e-6 for x in args.sigmas.split(",")]
    started = time.time()
    print(
        "| arm | σ (µm) | scenario | noise given | alarm % | alarm beyond geometric non-linearity % "
        "| named at its joint % | named or alias % | other finding % | unexplained % | held-out error, baseline → extended (median) "
        "| extended better % | knee-crossing rows | most frequent findings |"
    )
    print("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---|")
    for arm in arms:
        spec = mc.ArmSpec.example(arm)
        if spec is None:
            raise SystemExit(f"example-robot-data's {mc.ARMS[arm][0]} not found: pip install example-robot-data")
        for sigma in sigmas:
            for label, hidden, grav in scenarios(arm):
                outcomes: Dict[bool, List[mc.Outcome]] = {False: [], True: []}
                crossings: List[float] = []
                for i in range(args.seeds):
                    camp = mc.measure(spec, 40, 4, seed=SEED0 + i, tracker_sigma=sigma, hidden=hidden,
                                      gravity=(0.0, 0.0, -mc.STANDARD_GRAVITY if grav else 0.0))
                    crossings.append(camp.knee_crossings())
                    for given in (False, True):
                        outcomes[given].append(mc.judge(camp, given, weightless=args.weightless))
                for given in (False, True):
                    os_ = outcomes[given]
                    target = hidden.kind != "clean"
                    b = float(np.median([o.baseline_test for o in os_]))
                    x = float(np.median([o.extended_test for o in os_]))
                    common = Counter(f for o in os_ for f in o.findings).most_common(3)
                    cross = "" if math.isnan(crossings[0]) else f"{100 * float(np.median(crossings)):.0f} %"
                    print(
                        f"| {arm} | {sigma * 1e6:g} | {label} | {'yes' if given else 'no'} "
                        f"| {pct([o.alarm for o in os_])} | {pct([o.alarm_beyond_geometry for o in os_])} "
                        f"| {pct([o.named for o in os_]) if target else ''} "
                        f"| {pct([o.named_or_alias for o in os_]) if target else ''} "
                        f"| {pct([o.wrong for o in os_])} | {pct([o.unexplained for o in os_])} "
                        f"| {100 * b:.2f} % → {100 * x:.2f} % "
                        f"| {pct([o.extended_test < o.baseline_test for o in os_])} | {cross} "
                        f"| {', '.join(f'{name} ({k})' for name, k in common)} |",
                        flush=True,
                    )
                print(f"# {arm} σ={sigma * 1e6:g} µm {label}: {time.time() - started:.0f} s", file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()
