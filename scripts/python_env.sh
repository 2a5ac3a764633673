#!/usr/bin/env bash
# Creates (or updates) the test venv at .venv from scripts/requirements-test.txt.
# Called by scripts/setup.sh; safe to rerun. Prints the venv's python path last.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv"
if [ ! -x "$venv/bin/python" ]; then
    echo "spincal setup: creating the test venv at $venv"
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -r "$root/scripts/requirements-test.txt"
echo "spincal setup: test venv ready ($("$venv/bin/python" --version))"
