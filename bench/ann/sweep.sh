#!/usr/bin/env bash
# The default network sweep (the paper's grid, 165 architectures × 10 restarts) on a 10-minute,
# 100 Hz simulated 3DM-GX1 turntable recording, inside the whole calibration (fit → reference →
# sweep → chosen network trained exactly → linear, ARX, BJ, NARX, HW → report).
# Usage: bench/ann/sweep.sh [HESSIAN_SAMPLES]   (from the repository root; writes bench/out/sweep/)
#   HESSIAN_SAMPLES: samples of each epoch's JᵀJ while screening (default: spincal's, 8192; 0 = all).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=bench/out/sweep
mkdir -p "$out"
cargo build --release --quiet -p spincal-cli
spincal=target/release/spincal

echo "== machine"
lscpu | grep -E "Model name|^CPU\(s\)" || true
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"

"$spincal" simulate -o "$out/rec600.csv" --duration 600 --seed 42 --quiet
extra=()
if [ $# -ge 1 ]; then
    extra=(--sweep-hessian-samples "$1")
fi
/usr/bin/time -f "wall %e s, user %U s, system %S s, CPU %P" \
    "$spincal" --quiet calibrate "$out/rec600.csv" --sweep full --restarts 10 "${extra[@]}" \
    --out "$out/calibration" > "$out/calibrate.txt" 2> "$out/time.txt"
cat "$out/calibrate.txt"
echo "== time (whole calibration, all threads)"
cat "$out/time.txt"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$out/calibration/results.json" <<'EOF'
import json, sys
result = json.load(open(sys.argv[1]))
rows = result["sweep"]
runs = sum(1 for _ in rows) * 10
cpu = sum(r["seconds"] for r in rows)
print(f"sweep: {len(rows)} architectures, {runs} runs, {cpu:.0f} CPU-s of training "
      f"({cpu / runs:.2f} s per run)")
epochs = sorted(r["epochs"] for r in rows)
print(f"epochs of the kept restarts: median {epochs[len(epochs) // 2]}, max {epochs[-1]}")
best = sorted(rows, key=lambda r: r["best_validation_mse"])[:5]
print("best five on validation (architecture, validation / test fit %):")
for r in best:
    print(f"  {r['architecture']:>6}  {r['validation_fit_percent']:6.2f}  {r['test_fit_percent']:6.2f}")
EOF
