#!/usr/bin/env bash
# Joint campaign fit (4 turntable runs of 2 min at 100 Hz + 6 still poses): spincal's fit_joint
# against scipy.optimize.least_squares on the same model, data, start and weights, in one run.
#
# Usage: bash bench/campaign/run.sh [OUT_DIR] [SEED] [REPS] [CPU]
#   OUT_DIR  where the problem, both fits and the log go (default /tmp/spincal-bench-campaign);
#            nothing under the checkout is written (cargo builds into $CARGO_TARGET_DIR,
#            default /tmp/spincal-target-bench).
#   SEED 1, REPS 3 (best and median of REPS on both sides), CPU 1 (taskset -c CPU).
# Env: PEER_METHODS (default "trf,lm"), PEER_JACS (default "2-point analytic"), VENV (a venv with
#      numpy and scipy; default bench/.venv when it has both, else one created under /tmp).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-/tmp/spincal-bench-campaign}
seed=${2:-1}
reps=${3:-3}
cpu=${4:-1}
mkdir -p "$out"
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-/tmp/spincal-target-bench}
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

nice -n 19 cargo build --release --quiet --manifest-path "$root/Cargo.toml" -p spincal --example joint_fit_bench
bin="$CARGO_TARGET_DIR/release/examples/joint_fit_bench"

py=""
if [ -n "${VENV:-}" ]; then
    py="$VENV/bin/python"
elif "$root/bench/.venv/bin/python" -c "import numpy, scipy" 2>/dev/null; then
    py="$root/bench/.venv/bin/python"          # read only: gitignored, made by bench/setup_venv.sh
else
    venv=/tmp/spincal-bench-venv
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check numpy scipy
    py="$venv/bin/python"
fi

{
echo "== machine: $(lscpu | sed -n 's/^Model name: *//p' | head -1), $(getconf _NPROCESSORS_ONLN) CPUs; pinned to CPU $cpu"
echo "== commit: $(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet HEAD -- crates/spincal/src && echo '' || echo ' + uncommitted changes in crates/spincal/src')"
echo "== load before: $(uptime)"
echo "== spincal: taskset -c $cpu $bin $seed $out $reps"
taskset -c "$cpu" "$bin" "$seed" "$out" "$reps" >/dev/null
"$py" - "$out/spincal_fit.json" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1])); t = d["timing"]
print(f"spincal fit_joint: best {t['best_s']:.4f} s, median {t['median_s']:.4f} s of {t['repetitions']} "
      f"(warm-up {t['warmup_s']:.4f} s); iterations (both passes) {d['iterations_both_passes']}, stop {d['stop']}, "
      f"chi2 {d['chi2']:.10e}; the runs' demodulation (run_start on fresh copies of the runs, timed alone in the example; "
      f"the timed fit_joint calls reuse the demodulation the first call found) best {t['start_values_best_s']:.4f} s, "
      f"median {t['start_values_s_example_reimplementation']:.4f} s; "
      f"start vector identical to fit_joint's: {t['start_vector_matches_fit_joint']}")
EOF
for jac in ${PEER_JACS:-2-point analytic}; do
    echo "== scipy: taskset -c $cpu $py scipy_joint.py $out --reps $reps --methods ${PEER_METHODS:-trf,lm} --jac $jac"
    taskset -c "$cpu" "$py" "$root/bench/campaign/scipy_joint.py" "$out" --reps "$reps" \
        --methods "${PEER_METHODS:-trf,lm}" --jac "$jac"
done
echo "== load after: $(uptime)"
"$py" - "$out" <<'EOF'
import glob, json, sys
d = sys.argv[1]
sp = json.load(open(f"{d}/spincal_fit.json"))["timing"]
print("\n== ratios (scipy / spincal), same run")
st, st_b = sp["start_values_s_example_reimplementation"], sp["start_values_best_s"]
print("same work = starting values + both passes. spincal: the timed fit_joint calls reuse the runs' demodulation")
print("(RunInput keeps it once found), so its side is fit_joint + the demodulation timed alone;")
print(f"fit only = both passes: fit_joint as timed (best {sp['best_s']:.3f} s / median {sp['median_s']:.3f} s); "
      f"the demodulation best {st_b:.4f} s / median {st:.4f} s")
hdr = ("peer", "best s", "median s", "ratio best", "ratio median", "fit-only ratio b/m", "max|Δ|/scale", "max|Δ|/SE")
print("%-16s %9s %9s %10s %12s %18s %13s %10s" % hdr)
same_b, same_m = sp["best_s"] + st_b, sp["median_s"] + st
for f in sorted(glob.glob(f"{d}/scipy_*.json")):
    s = json.load(open(f))
    tw = s["total_with_start_s"]
    fo = "%.1f / %.1f" % (s["best_s"] / sp["best_s"], s["median_s"] / sp["median_s"])
    print("%-16s %9.3f %9.3f %10.1f %12.1f %18s %13.1e %10.1e" % (
        s["method"] + "/" + s["jac"], tw["best"], tw["median"], tw["best"] / same_b,
        tw["median"] / same_m, fo, s["max_abs_diff_over_scale"], s["max_abs_diff_over_se"]))
print("%-16s %9.4f %9.4f" % ("spincal", same_b, same_m))
print("(scipy times in this table include its numpy starting values; the per-method lines above are the fits alone)")
EOF
} 2>&1 | tee "$out/log.txt"
