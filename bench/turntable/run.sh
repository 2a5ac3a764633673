#!/usr/bin/env bash
# Turntable fit on a 10-minute, 100 Hz recording: spincal against scipy (Nelder–Mead with bounds,
# then least_squares) on the same file, from the same start and bounds. Both sides pinned to one
# CPU (taskset), three timed runs each per round, ROUNDS rounds, load printed before each.
#
#   bash bench/turntable/run.sh [ROUNDS] [CPU]      (defaults: 3 1)
set -euo pipefail
rounds=${1:-3}
cpu=${2:-1}
root=$(cd "$(dirname "$0")/../.." && pwd)
out="$root/bench/out/turntable"
mkdir -p "$out"
bash "$root/bench/setup_venv.sh"
cargo build --release --quiet --manifest-path "$root/Cargo.toml" -p spincal-cli
spincal="$root/target/release/spincal"
"$spincal" simulate -o "$out/rec600.csv" --duration 600 --seed 42 --quiet
# The paper's model (offsets held at zero) is identifiable from one recording, so both fits must
# land on the same point.
args=(fit "$out/rec600.csv" --no-offsets --quiet)
"$spincal" "${args[@]}" -o "$out/spincal_fit.json" >/dev/null   # warm the page cache
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); both sides on CPU $cpu"
for round in $(seq 1 "$rounds"); do
    echo "== round $round, load average: $(cut -d' ' -f1-3 /proc/loadavg)"
    times=()
    for _ in 1 2 3; do
        start=$(date +%s.%N)
        taskset -c "$cpu" "$spincal" "${args[@]}" -o "$out/spincal_fit.json" >/dev/null
        end=$(date +%s.%N)
        times+=("$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')")
    done
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 taskset -c "$cpu" "$root/bench/.venv/bin/python" \
        "$root/bench/turntable/scipy_fit.py" "$out/rec600.csv" "$out/spincal_fit.json" "$(IFS=,; echo "${times[*]}")"
done
