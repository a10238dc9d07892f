#!/usr/bin/env bash
# Runs every test and gate of the project: formatting, lints and docs of the Rust workspace, all
# Rust tests, `cargo package` of each publishable crate (each type-checked from its .crate), the
# Python wheel built and installed from source, ruff and mypy on the package, its pytest suite
# (with the stub check and the README figures check) and a 60-second fuzz budget (Rust readers
# 30 s, CLI 30 s). Installs what it needs itself. Each step prints the seconds it took.
set -euo pipefail
cd "$(dirname "$0")/.."

# Every build below shares one target dir and the workspace's dev profile, so each step reuses
# what the previous ones compiled.
FUZZ_SECONDS_RUST="${FUZZ_SECONDS_RUST:-30}"
FUZZ_SECONDS_CLI="${FUZZ_SECONDS_CLI:-30}"

step() {
    local name="$1"
    shift
    local started=$SECONDS
    echo "== $name =="
    "$@"
    echo "-- $name: $((SECONDS - started)) s"
}

# The library crates: workspace members that do not say `publish = false`.
publishable_crates() {
    cargo metadata --no-deps --format-version 1 | python3 -c '
import json, sys
meta = json.load(sys.stdin)
members = set(meta["workspace_members"])
for p in meta["packages"]:
    if p["id"] in members and p.get("publish") != []:
        print(p["name"])'
}

cargo_package() {
    local args=() crates=()
    for crate in $(publishable_crates); do args+=(-p "$crate"); crates+=("$crate"); done
    echo "crates: ${crates[*]}"
    # --no-verify, then our own verification (scripts/verify_packages.py): each .crate is
    # unpacked and type-checked with its siblings served from their unpacked copies, with the
    # workspace's lock, dev profile and target dir. cargo's own verification unpacks the siblings
    # into $CARGO_HOME/registry/src/<hash of a path under target/>/ and reuses a folder left there
    # by an earlier run as it is: CI once verified against stale sources so. Giving it a
    # CARGO_HOME of its own avoided that but rebuilt every dependency (336 s of a 27-min run).
    # --allow-dirty: the build above may leave ignored or generated files; the package contents
    # are what git tracks.
    cargo package "${args[@]}" --allow-dirty --no-verify
    python3 scripts/verify_packages.py "${crates[@]}"
}

pytest_all() {
    local rc=0
    python3 -m pytest -q crates/py-bindings/tests || rc=$?
    if [ "$rc" -eq 5 ]; then
        echo "pytest collected no tests: that is a failure here" >&2
        return 1
    fi
    return "$rc"
}

fuzz_rust() {
    mkdir -p target
    # The binary `cargo test --workspace` built for the integration tests of its package (it
    # links it to target/debug/fuzz), so nothing is compiled again: `cargo run -p` resolves that
    # package's features alone, and `cargo build --workspace` leaves out the dev-dependencies'
    # features; both rebuilt faer, nalgebra and more (≈ 110 s of a 140–151 s step).
    cargo test -q --workspace --no-run
    "${CARGO_TARGET_DIR:-target}/debug/fuzz" \
        --seconds "$FUZZ_SECONDS_RUST" --seed "${FUZZ_SEED:-0}" --record target/fuzz-record.json
}

fuzz_cli() {
    python3 scripts/fuzz_cli.py --seconds "$FUZZ_SECONDS_CLI" --seed "${FUZZ_SEED:-0}" \
        --record target/fuzz-cli-record.json
}

step "install test requirements" \
    python3 -m pip install --quiet --disable-pip-version-check -r requirements-test.txt

step "cargo fmt --check" cargo fmt --all -- --check
step "cargo clippy -D warnings" cargo clippy --workspace --all-targets -- -D warnings
step "cargo doc -D warnings" env RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps

step "cargo test (all crates)" cargo test --workspace --no-fail-fast

step "cargo package (publishable crates, each type-checked from its .crate)" cargo_package

step "build and install the Python wheel" \
    python3 -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./crates/py-bindings

step "ruff" python3 -m ruff check --config crates/py-bindings/pyproject.toml crates/py-bindings scripts
step "mypy" python3 -m mypy crates/py-bindings/python/robot_stiffness scripts/fuzz_cli.py scripts/figures.py scripts/verify_packages.py

step "pytest" pytest_all

step "fuzz: readers (Rust, ${FUZZ_SECONDS_RUST} s)" fuzz_rust
step "fuzz: command line (${FUZZ_SECONDS_CLI} s)" fuzz_cli
