#!/usr/bin/env bash
# Runs every test of the project: all Rust crates, then the Python package (built and installed
# from source as a wheel), its pytest suite and the stub check. Installs what it needs itself.
set -euo pipefail
cd "$(dirname "$0")/.."

python3 -m pip install --quiet --disable-pip-version-check -r requirements-test.txt

echo "== cargo test (all crates) =="
cargo test --workspace --no-fail-fast

echo "== build and install the Python wheel =="
python3 -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./crates/py-bindings

echo "== pytest =="
python3 -m pytest -q crates/py-bindings/tests
