#!/usr/bin/env bash
# Creates bench/.venv with the Python peers used by the benchmarks (numpy, scipy, pandas, pyrenn…).
# Usage: bash bench/setup_venv.sh [extra pip packages]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
if [ ! -x "$here/.venv/bin/python" ]; then
  python3 -m venv "$here/.venv"
fi
"$here/.venv/bin/pip" install --quiet --disable-pip-version-check numpy scipy "$@"
