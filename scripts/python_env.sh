#!/usr/bin/env bash
# The test venv at .venv and the Python package's wheel. Called by scripts/setup.sh; safe to rerun.
#   python_env.sh venv    creates (or updates) .venv from scripts/requirements-test.txt
#   python_env.sh wheel   builds crates/spincal-py into a wheel with maturin and installs it in .venv
#   python_env.sh         both
# The wheel's build shares cargo's target folder and release profile with
# `cargo test --release --workspace`, so the library is compiled once. The pytest suite itself runs
# from `cargo test` (crates/spincal-py/tests/python.rs), against the extension module of that build.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv"
step=${1:-all}

if [ "$step" = venv ] || [ "$step" = all ]; then
    if [ ! -x "$venv/bin/python" ]; then
        echo "spincal setup: creating the test venv at $venv"
        python3 -m venv "$venv"
    fi
    "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$root/scripts/requirements-test.txt"
    # Every package in the venv is pinned in the file (transitively): a dependency that pulls in
    # a new package fails here, naming it, instead of floating to whatever is newest.
    unpinned=$("$venv/bin/pip" freeze --disable-pip-version-check --exclude spincal \
        | grep -vixF -f <(grep -v '^#' "$root/scripts/requirements-test.txt" | grep .) || true)
    if [ -n "$unpinned" ]; then
        echo "spincal setup: the venv holds packages that scripts/requirements-test.txt does not pin:" >&2
        echo "$unpinned" >&2
        exit 1
    fi
    echo "spincal setup: test venv ready ($("$venv/bin/python" --version))"
fi

if [ "$step" = wheel ] || [ "$step" = all ]; then
    target=${CARGO_TARGET_DIR:-$root/target}
    wheels="$target/wheels"
    echo "spincal setup: building the Python package's wheel (maturin, release) into $wheels"
    rm -f "$wheels"/spincal-*.whl
    "$venv/bin/maturin" build --release --quiet --manifest-path "$root/crates/spincal-py/Cargo.toml" --out "$wheels"
    wheel=$(ls "$wheels"/spincal-*.whl)
    "$venv/bin/pip" install --quiet --disable-pip-version-check --no-deps --force-reinstall "$wheel"
    (cd / && "$venv/bin/python" -c 'import spincal; print("spincal setup: installed the spincal package", spincal.__version__, "from", spincal.__file__)')
fi
