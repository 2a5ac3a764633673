#!/usr/bin/env bash
# Turntable fit on a 10-minute, 100 Hz recording: spincal against scipy (Nelder–Mead with bounds,
# then least_squares) on the same file, from the same start and bounds, in one run.
set -euo pipefail
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
# Best of three whole-process runs (the load of a shared machine moves single timings).
spincal_s=1e9
for _ in 1 2 3; do
    start=$(date +%s.%N)
    "$spincal" "${args[@]}" -o "$out/spincal_fit.json" >/dev/null
    end=$(date +%s.%N)
    spincal_s=$(awk -v a="$start" -v b="$end" -v best="$spincal_s" 'BEGIN { s = b - a; print (s < best) ? s : best }')
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
"$root/bench/.venv/bin/python" "$root/bench/turntable/scipy_fit.py" "$out/rec600.csv" "$out/spincal_fit.json" "$spincal_s"
