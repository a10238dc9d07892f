#!/usr/bin/env python3
"""Summarise the last `cargo bench -p robot-stiffness-benches` run as a Markdown table.

Reads criterion's `estimates.json`/`benchmark.json` under ``$CARGO_TARGET_DIR/criterion``
(default ``target/criterion``) and writes ``benches/results/criterion_table.md``: for every
benchmark the median time per iteration with criterion's 95 % interval and, when the bench
declares a throughput of E elements per iteration, the time per element (iteration / E).
Nothing is computed that criterion did not measure.

Usage (from the workspace root):  python3 benches/criterion_table.py
"""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = Path(__file__).resolve().parent / "results" / "criterion_table.md"
GROUPS = ("so3", "vjm_jacobian", "vjm_identify", "csjm")


def fmt_ns(ns: float) -> str:
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("µs", 1e3)):
        if ns >= scale:
            return f"{ns / scale:.3g} {unit}"
    return f"{ns:.3g} ns"


def main() -> int:
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    base = target / "criterion"
    rows = []
    for bench_json in sorted(base.glob("**/new/benchmark.json")):
        meta = json.loads(bench_json.read_text())
        if meta["group_id"] not in GROUPS:
            continue
        est = json.loads((bench_json.parent / "estimates.json").read_text())["median"]
        lo, hi = est["confidence_interval"]["lower_bound"], est["confidence_interval"]["upper_bound"]
        elements = (meta.get("throughput") or {}).get("Elements")
        per = f"{fmt_ns(est['point_estimate'] / elements)}" if elements else "—"
        rows.append((meta["full_id"], fmt_ns(est["point_estimate"]), f"{fmt_ns(lo)} – {fmt_ns(hi)}",
                     elements or "—", per))
    if not rows:
        print(f"no criterion results under {base}; run cargo bench first", file=sys.stderr)
        return 1
    lines = [
        "| benchmark | median per iteration | 95 % interval | elements per iteration | per element |",
        "|---|---:|---:|---:|---:|",
    ] + [f"| `{a}` | {b} | {c} | {d} | {e} |" for a, b, c, d, e in rows]
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
