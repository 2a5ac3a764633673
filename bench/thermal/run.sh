#!/usr/bin/env bash
# Thermal fit (warm-up of 40 min + 60 poses of 30 s at 50 Hz, one simulated unit; lag fixed at
# 20 s, orders [2, 2]): spincal's fit_thermal against scipy.optimize.least_squares on the same
# windows, model and zero start; then the flight stacks' method (cubic per axis against the
# reported temperature + static calibration) against spincal's corrector and the oracle on the
# held-out poses.
#
# Usage: bash bench/thermal/run.sh [OUT_DIR] [SEED] [REPS] [CPU]
#   OUT_DIR  where the data, the windows, the fits and the log go (default
#            /tmp/spincal-bench-thermal); nothing under the checkout is written (cargo builds into
#            $CARGO_TARGET_DIR, default /tmp/spincal-target-bench).
#   SEED 1, REPS 5 (best and median of REPS on both sides, after a warm-up), CPU 1 (taskset -c CPU).
# Env: DATA_DIR (a folder written by `spincal simulate --thermal DIR --seed N`; default: simulated
#      by the example into OUT_DIR/data-SEED), PEER_METHODS (default "lm,trf"), PEER_JACS (default
#      "analytic 2-point"), VENV (a venv with numpy and scipy; default bench/.venv when it has
#      both, else one created under /tmp).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-/tmp/spincal-bench-thermal}
seed=${2:-1}
reps=${3:-5}
cpu=${4:-1}
mkdir -p "$out"
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-/tmp/spincal-target-bench}
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

nice -n 19 cargo build --release --quiet --manifest-path "$root/Cargo.toml" -p spincal --example thermal_bench
bin="$CARGO_TARGET_DIR/release/examples/thermal_bench"

py=""
if [ -n "${VENV:-}" ]; then
    py="$VENV/bin/python"
elif "$root/bench/.venv/bin/python" -c "import numpy, scipy" 2>/dev/null; then
    py="$root/bench/.venv/bin/python"          # read only: gitignored, made by bench/setup_venv.sh
else
    venv=/tmp/spincal-bench-venv
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
    "$venv/bin/python" -c "import numpy, scipy" 2>/dev/null ||
        "$venv/bin/pip" install --quiet --disable-pip-version-check numpy scipy
    py="$venv/bin/python"
fi

{
echo "== machine: $(lscpu | sed -n 's/^Model name: *//p' | head -1), $(getconf _NPROCESSORS_ONLN) CPUs; pinned to CPU $cpu"
echo "== commit: $(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet HEAD -- crates/spincal && echo '' || echo ' + uncommitted changes in crates/spincal')"
echo "== numpy $("$py" -c 'import numpy; print(numpy.__version__)'), scipy $("$py" -c 'import scipy; print(scipy.__version__)')"
echo "== load before: $(uptime)"
echo "== spincal: taskset -c $cpu $bin $seed $out $reps ${DATA_DIR:-}"
taskset -c "$cpu" "$bin" "$seed" "$out" "$reps" ${DATA_DIR:+"$DATA_DIR"}
for jac in ${PEER_JACS:-analytic 2-point}; do
    echo "== scipy: taskset -c $cpu $py scipy_thermal.py $out --reps $reps --methods ${PEER_METHODS:-lm,trf} --jac $jac"
    taskset -c "$cpu" "$py" "$root/bench/thermal/scipy_thermal.py" "$out" --reps "$reps" \
        --methods "${PEER_METHODS:-lm,trf}" --jac "$jac"
done
echo "== flight stacks: $py flight_stack.py $out"
taskset -c "$cpu" "$py" "$root/bench/thermal/flight_stack.py" "$out"
echo "== load after: $(uptime)"
"$py" - "$out" <<'EOF'
import glob, json, sys
d = sys.argv[1]
sp = json.load(open(f"{d}/spincal_fit.json"))
t = sp["timing"]
print("\n== ratios (scipy / spincal), same run")
print("spincal's time is the whole fit_thermal (die temperatures + windows + LM + covariance); "
      f"its windowing alone: best {t['windows_best_s']:.4f} s. scipy's is the solve alone, on spincal's windows.")
print("%-18s %9s %9s %10s %12s %18s %12s %10s" % (
    "peer", "best s", "median s", "ratio best", "ratio median", "solve-only b / m", "max|Δ| β,ρ", "max|Δ|/SE"))
for f in sorted(glob.glob(f"{d}/scipy_*.json")):
    s = json.load(open(f))
    fo = "%.1f / %.1f" % (s["best_s"] / (t["best_s"] - t["windows_best_s"]),
                          s["median_s"] / (t["median_s"] - t["windows_median_s"]))
    print("%-18s %9.4f %9.4f %10.1f %12.1f %18s %12.1e %10.1e" % (
        s["method"] + "/" + s["jac"], s["best_s"], s["median_s"], s["best_s"] / t["best_s"],
        s["median_s"] / t["median_s"], fo, max(s["max_abs_diff"]["beta"], s["max_abs_diff"]["rho"]),
        s["max_diff_over_se"]))
print("%-18s %9.4f %9.4f" % ("spincal", t["best_s"], t["median_s"]))
EOF
} 2>&1 | tee "$out/log.txt"
