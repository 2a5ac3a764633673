#!/usr/bin/env bash
# LM epoch benchmark and pyrenn peer check for spincal's network trainer.
# Usage: bash bench/ann/run.sh [CPU] [ROUNDS] [PYRENN_ROUNDS] [K]     (defaults: 1 5 3 3)
#   CPU            the one core every timed side runs on (taskset)
#   ROUNDS         timed rounds per side after a warm-up (spincal: rounds of >= 1 s of epochs;
#                  numpy: single epochs); best and median are printed
#   PYRENN_ROUNDS  timed train_LM runs of pyrenn per k_max (each is seconds long)
#   K              epochs of the long run from which the marginal epoch is taken:
#                  ((K epochs) - (1 epoch)) / (K - 1), on pyrenn's side and spincal's alike
# Writes bench/out/ann/ only. The peer check writes bench/out/ann/pyrenn_peer.json and runs the
# ann_peer test on it; nothing tracked is written unless ANN_BENCH_UPDATE_FIXTURE=1, which copies
# it over crates/spincal/tests/fixtures/ann/pyrenn_peer.json (the test's default input).
set -euo pipefail
cpu=${1:-1}
rounds=${2:-5}
pyrenn_rounds=${3:-3}
k=${4:-3}
cd "$(dirname "$0")/../.."
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
target=${CARGO_TARGET_DIR:-$(pwd)/target}
out=bench/out/ann
mkdir -p "$out"
# The venv is shared with the turntable bench: install what this bench needs when it is missing.
# Pinned to the versions pyrenn_peer.json records.
if ! bench/.venv/bin/python -c "import numpy, pyrenn; assert numpy.__version__ == '2.4.6'" 2>/dev/null; then
    [ -x bench/.venv/bin/python ] || python3 -m venv bench/.venv
    bench/.venv/bin/pip install -q numpy==2.4.6 pyrenn==0.1
fi
py=bench/.venv/bin/python
pin=(taskset -c "$cpu")
"${pin[@]}" cargo build --release --quiet -p spincal --example ann_epoch
ex=$target/release/examples/ann_epoch

echo "== machine: $(nproc --all) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); every timed side on CPU $cpu"
echo "== $(date -u '+%Y-%m-%d %H:%M:%S UTC'); load before: $(uptime)"

echo "== peer check: pyrenn vs spincal, same data and initial weights"
"${pin[@]}" "$ex" export 1000 10,6 3 "$out/peer_export.json"
"${pin[@]}" $py bench/ann/bench.py peer "$out/peer_export.json" 40 "$out/pyrenn_peer.json"
SPINCAL_PYRENN_PEER="$(pwd)/$out/pyrenn_peer.json" "${pin[@]}" cargo test --release --quiet -p spincal \
    --test ann_peer -- --nocapture
if [ "${ANN_BENCH_UPDATE_FIXTURE:-0}" = 1 ]; then
    cp "$out/pyrenn_peer.json" crates/spincal/tests/fixtures/ann/pyrenn_peer.json
fi

echo "== seconds per LM epoch, 2-input [10,6] 2-output network; load: $(cut -d' ' -f1-3 /proc/loadavg)"
"${pin[@]}" "$ex" dgemm > "$out/faer_dgemm.json"
"${pin[@]}" "$ex" parts | tee "$out/parts.json"
"${pin[@]}" "$ex" time --rounds "$rounds" --epochs "$k" 3000 30000 > "$out/spincal_epoch.json"
"${pin[@]}" "$ex" export 3000 10,6 1 "$out/export_3000.json"
"${pin[@]}" "$ex" export 30000 10,6 1 "$out/export_30000.json"
echo "== spincal done; load: $(cut -d' ' -f1-3 /proc/loadavg)"
"${pin[@]}" $py bench/ann/bench.py epoch "$out/spincal_epoch.json" "$out/faer_dgemm.json" \
    "$rounds" "$pyrenn_rounds" "$k" "$out/export_3000.json" "$out/export_30000.json" | tee "$out/epoch.txt"
echo "== $(date -u '+%Y-%m-%d %H:%M:%S UTC'); load after: $(uptime)"

if [ "${ANN_BENCH_SWEEP:-0}" = 1 ]; then
    echo "== sweep on a 10-minute 100 Hz recording (60,000 samples), subset of the default grid"
    mkdir -p "$out/sweep"
    "$ex" csv 60000 "$out/sweep/tt60k"
    cargo build --release -p spincal-cli
    (cd "$out/sweep" && /usr/bin/time -v "$target/release/spincal" --quiet sweep \
        --data tt60k-measured.csv --reference tt60k-reference.csv \
        --grid "2;8;15;4,3;10,6;15,10" --restarts 2 --threads 2 -o subset)
fi
