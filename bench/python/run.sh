#!/usr/bin/env bash
# The Python package's speed: `correct` on 10^6 rows against the CLI, and a fleet of simulated
# units on a local Ray cluster (2 CPUs) against one process calling the library in a loop, with
# Ray's start-up and per-task overhead. Follows bench/README.md: pinned where the work is one
# thread, best and median of REPS timed runs after a warm-up, load recorded, answers checked.
#
#   bash bench/python/run.sh [OUT_DIR] [REPS] [CPU]      (defaults: bench/out/python 3 1)
#
# Builds the CLI and the wheel (release), installs the wheel into the test venv (.venv), then
# runs bench.py. Nothing tracked is written.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-$root/bench/out/python}
reps=${2:-3}
cpu=${3:-1}
mkdir -p "$out"
cd "$root"
bash scripts/python_env.sh >/dev/null
cargo build --release -p spincal-cli --quiet
target=${CARGO_TARGET_DIR:-$root/target}
echo "machine: $(nproc) cores, $(uname -m), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "load before: $(uptime)"
RAYON_NUM_THREADS=1 "$root/.venv/bin/python" "$root/bench/python/bench.py" \
    --cli "$target/release/spincal" --out "$out" --reps "$reps" --cpu "$cpu" "${@:4}"
echo "load after: $(uptime)"
