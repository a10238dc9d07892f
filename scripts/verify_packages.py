#!/usr/bin/env python3
"""Builds the publishable crates from their ``.crate`` files, as a user's ``cargo add`` gets them.

``cargo package --no-verify`` (run before this script) writes ``target/package/<crate>-<version>.crate``.
This script unpacks each one into ``target/package-check/``, makes that folder a workspace of the
unpacked crates whose ``[patch.crates-io]`` serves every sibling from its unpacked copy (the
crates are not on crates.io yet), and runs ``cargo build`` there. A file missing from a package
(``include``/``exclude``, a ``README`` or a module left out) fails the build, as it would for a
user.

Why not ``cargo package``'s own verification: it unpacks the siblings into
``$CARGO_HOME/registry/src/<hash of a path under target/>/`` and reuses such a folder from an
earlier run as it is (CI once verified against stale sources so), and with a ``CARGO_HOME`` of
its own it rebuilds every dependency from scratch. Here the dependencies keep their paths in the
user's ``CARGO_HOME`` and the build shares the workspace's target dir and dev profile, so only
the unpacked crates are compiled (they are path crates under another root, so their artifacts
never replace the workspace's).

Usage (from the workspace root): ``python3 scripts/verify_packages.py stiffness-core vjm ...``
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tarfile
import tomllib
from pathlib import Path
from typing import Any, Dict, List

# Written into the folder this script makes; it removes a folder only when this file is in it.
MARKER = ".made-by-verify-packages"


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def profile_tables(manifest: Dict[str, Any]) -> str:
    """The workspace's ``[profile.*]`` tables, as TOML text (nested tables written inline)."""
    out: List[str] = []
    for name, table in manifest.get("profile", {}).items():
        out.append(f"[profile.{json.dumps(name)}]")
        out.extend(f"{json.dumps(k)} = {toml_value(v)}" for k, v in table.items())
        out.append("")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("crates", nargs="+", help="names of the crates packaged by cargo package")
    args = ap.parse_args()

    meta = json.loads(subprocess.run(
        ["cargo", "metadata", "--no-deps", "--format-version", "1"],
        check=True, capture_output=True, text=True).stdout)
    root = Path(meta["workspace_root"])
    target = Path(meta["target_directory"])
    versions = {p["name"]: p["version"] for p in meta["packages"]}
    unknown = [c for c in args.crates if c not in versions]
    if unknown:
        print(f"verify_packages: not a workspace member: {', '.join(unknown)}", file=sys.stderr)
        return 2

    out = target / "package-check"
    if out.exists():
        if not (out / MARKER).exists():
            print(f"verify_packages: {out} exists and was not made by this script; "
                  "move it away first", file=sys.stderr)
            return 2
        shutil.rmtree(out)
    out.mkdir(parents=True)
    (out / MARKER).write_text("made by scripts/verify_packages.py; removed by its next run\n")

    folders = {}
    for crate in args.crates:
        stem = f"{crate}-{versions[crate]}"
        archive = target / "package" / f"{stem}.crate"
        if not archive.is_file():
            print(f"verify_packages: {archive} is missing: run cargo package first", file=sys.stderr)
            return 2
        with tarfile.open(archive) as tar:
            tar.extractall(out, filter="data")
        folders[crate] = stem

    manifest = tomllib.loads((root / "Cargo.toml").read_text())
    lines = ["# Made by scripts/verify_packages.py: the packaged crates, built as users get them.",
             "[workspace]", 'resolver = "2"',
             "members = [" + ", ".join(json.dumps(f) for f in folders.values()) + "]", "",
             "[patch.crates-io]"]
    lines += [f"{json.dumps(c)} = {{ path = {json.dumps(f)} }}" for c, f in folders.items()]
    lines += ["", profile_tables(manifest)]
    (out / "Cargo.toml").write_text("\n".join(lines))
    # The workspace's lock: the same dependency versions as every other step.
    shutil.copyfile(root / "Cargo.lock", out / "Cargo.lock")

    cmd = ["cargo", "check", "--workspace", "--manifest-path", str(out / "Cargo.toml"),
           "--target-dir", str(target)]
    print("verify_packages:", " ".join(cmd), flush=True)
    return subprocess.run(cmd).returncode


if __name__ == "__main__":
    sys.exit(main())
