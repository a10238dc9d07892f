#!/usr/bin/env bash
# Runs every test and gate of the project: formatting, lints and docs of the Rust workspace, all
# Rust tests, `cargo package` (verified) of each publishable crate, the Python wheel built and
# installed from source, ruff and mypy on the package, its pytest suite (with the stub check
# and the README figures check) and a 60-second fuzz budget (Rust readers 30 s, CLI 30 s).
# Installs what it needs itself. Each step prints the seconds it took.
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
    local args=()
    for crate in $(publishable_crates); do args+=(-p "$crate"); done
    echo "crates: ${args[*]}"
    # Verified: each crate is built from its .crate file, with its sibling crates served from a
    # local registry overlay. The dev profile of the workspace is passed as config, so the
    # verification builds dependencies as the workspace does. --allow-dirty: the build above
    # may leave ignored or generated files; the package contents are what git tracks.
    #
    # Why a CARGO_HOME of its own: cargo unpacks the sibling crates it verifies against into
    # $CARGO_HOME/registry/src/<hash of the path of its temporary registry>/<crate>-<version>/
    # and reuses such a folder as it is. A CARGO_HOME kept from an earlier run at the same path
    # therefore verifies against that run's sources: CI failed so, compiling a stiffness-core
    # without `engine`. The private home is made here and shares only the user's downloaded
    # index, .crate files and config, not the unpacked sources; it is removed when the step ends.
    # The verification builds go to a target dir of their own (target/package-verify): with
    # another CARGO_HOME the dependencies' sources have other paths, and building them into the
    # workspace's target dir replaced its artifacts, which the fuzz step then rebuilt (seen in
    # a clean-clone run: faer compiled a third time).
    local user_home="${CARGO_HOME:-$HOME/.cargo}" home rc=0
    home="$(mktemp -d "${TMPDIR:-/tmp}/robot-stiffness-package-home.XXXXXX")"
    mkdir -p "$home/registry" "$user_home/registry/index" "$user_home/registry/cache"
    ln -s "$user_home/registry/index" "$home/registry/index"
    ln -s "$user_home/registry/cache" "$home/registry/cache"
    for f in config.toml config credentials.toml credentials; do
        if [ -e "$user_home/$f" ]; then ln -s "$user_home/$f" "$home/$f"; fi
    done
    CARGO_HOME="$home" cargo package "${args[@]}" --allow-dirty --target-dir target/package-verify \
        --config 'profile.dev.opt-level=1' --config 'profile.dev.package."*".opt-level=2' || rc=$?
    # Only the folder made above; rm removes the links in it, never what they point at.
    rm -rf -- "$home"
    return "$rc"
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
    cargo run -q -p robot-stiffness-tests --bin fuzz -- \
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

step "cargo package (publishable crates, verified)" cargo_package

step "build and install the Python wheel" \
    python3 -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./crates/py-bindings

step "ruff" python3 -m ruff check --config crates/py-bindings/pyproject.toml crates/py-bindings scripts
step "mypy" python3 -m mypy crates/py-bindings/python/robot_stiffness scripts/fuzz_cli.py scripts/figures.py

step "pytest" pytest_all

step "fuzz: readers (Rust, ${FUZZ_SECONDS_RUST} s)" fuzz_rust
step "fuzz: command line (${FUZZ_SECONDS_CLI} s)" fuzz_cli
