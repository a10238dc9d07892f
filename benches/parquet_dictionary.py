#!/usr/bin/env python3
"""Why ``write_columns`` turns Parquet's dictionary encoding off for numbers: 33 seeded columns of
10^6 normal floats (a PRED file's width) written with pyarrow's ``ParquetWriter`` in row groups
of 2^17 and 2^20 rows, with its defaults and with ``use_dictionary=False``; wall time and file
size. Usage: ``python benches/parquet_dictionary.py [--rows N]`` (needs pyarrow)."""
from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np
import pyarrow as pa  # type: ignore[import-untyped,import-not-found,unused-ignore]
import pyarrow.parquet as pq  # type: ignore[import-untyped,import-not-found,unused-ignore]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rows", type=int, default=1_000_000)
    rows = parser.parse_args().rows
    rng = np.random.default_rng(0)
    cols = [rng.normal(size=rows) for _ in range(33)]
    names = [f"c{i}" for i in range(33)]
    schema = pa.Table.from_arrays([pa.array(c[:0]) for c in cols], names=names).schema
    print("| rows per group | writer options | time | file |\n| ---: | --- | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "t.parquet")
        for group in (1 << 17, 1 << 20):
            for options in ({}, {"use_dictionary": False}):
                t0 = time.perf_counter()
                with pq.ParquetWriter(path, schema, **options) as writer:
                    for start in range(0, rows, group):
                        writer.write_table(pa.Table.from_arrays([pa.array(c[start:start + group]) for c in cols],
                                                                names=names))
                wall = time.perf_counter() - t0
                print(f"| {group:,} | {options or 'defaults'} | {wall:.2f} s | {os.path.getsize(path) / 1e6:.0f} MB |")


if __name__ == "__main__":
    main()
