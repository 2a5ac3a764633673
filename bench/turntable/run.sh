#!/usr/bin/env bash
# Turntable fit on a 10-minute, 100 Hz recording: spincal against scipy on the same file, from the
# same start and bounds, in two rows:
#   - scipy as users write it (scipy_fit.py): Nelder–Mead with bounds on the per-sample cost, then
#     least_squares with its numerical Jacobian; timed for the fit alone;
#   - the same algorithm as spincal's in numpy/scipy (scipy_moments.py): spectrum rate, linear
#     start, Nelder–Mead on the precomputed-moment cost, LM with the analytic Jacobian, standard
#     errors; timed for the same work as spincal's process (reading the CSV included).
# Both sides pinned to one CPU (taskset), one thread each; per round three timed runs on every side
# after a warm-up, best and median of each; ROUNDS rounds; load printed before each round and after.
# Writes bench/out/turntable/ only.
#
#   bash bench/turntable/run.sh [ROUNDS] [CPU]      (defaults: 3 1)
set -euo pipefail
rounds=${1:-3}
cpu=${2:-1}
root=$(cd "$(dirname "$0")/../.." && pwd)
out="$root/bench/out/turntable"
mkdir -p "$out"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
pin=(taskset -c "$cpu")
bash "$root/bench/setup_venv.sh"
"${pin[@]}" cargo build --release --quiet --manifest-path "$root/Cargo.toml" -p spincal-cli
spincal="${CARGO_TARGET_DIR:-$root/target}/release/spincal"
"$spincal" simulate -o "$out/rec600.csv" --duration 600 --seed 42 --quiet
# The paper's model (offsets held at zero) is identifiable from one recording, so both fits must
# land on the same point.
args=(fit "$out/rec600.csv" --no-offsets --quiet)
"${pin[@]}" "$spincal" "${args[@]}" -o "$out/spincal_fit.json" >/dev/null   # warm-up (and page cache)
py="$root/bench/.venv/bin/python"
echo "machine: $(nproc --all) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); both sides on CPU $cpu"
echo "$(date -u '+%Y-%m-%d %H:%M:%S UTC'); load before: $(uptime)"
for round in $(seq 1 "$rounds"); do
    echo "== round $round, load average: $(cut -d' ' -f1-3 /proc/loadavg)"
    times=()
    for _ in 1 2 3; do
        start=$(date +%s.%N)
        "${pin[@]}" "$spincal" "${args[@]}" -o "$out/spincal_fit.json" >/dev/null
        end=$(date +%s.%N)
        times+=("$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')")
    done
    list=$(IFS=,; echo "${times[*]}")
    echo "-- scipy as users write it"
    "${pin[@]}" "$py" "$root/bench/turntable/scipy_fit.py" "$out/rec600.csv" "$out/spincal_fit.json" "$list"
    echo "-- the same algorithm in numpy/scipy"
    "${pin[@]}" "$py" "$root/bench/turntable/scipy_moments.py" "$out/rec600.csv" "$out/spincal_fit.json" "$list"
done
echo "$(date -u '+%Y-%m-%d %H:%M:%S UTC'); load after: $(uptime)"
