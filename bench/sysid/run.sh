#!/usr/bin/env bash
# spincal vs numpy lstsq, pysib and SIPPY in one run: ARX [6 8 1] on 10⁶ samples, BJ [4 4 4 4 1]
# on 5,000 samples (first half training, second half validation). Every side pinned to one CPU,
# single-threaded (RAYON_NUM_THREADS=1, one BLAS thread); each fit timed RUNS times after a warm-up
# fit, best and median printed for both sides, with the ratios of each; load printed before and
# after. Writes bench/out/sysid/ only.
#
#   bash bench/sysid/run.sh [RUNS] [CPU]      (defaults: 3 1)
set -euo pipefail
runs=${1:-3}
cpu=${2:-1}
cd "$(dirname "$0")/../.."
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
target=${CARGO_TARGET_DIR:-$(pwd)/target}
pin=(taskset -c "$cpu")
bash bench/sysid/setup.sh
PY=bench/.venv-sysid/bin/python
OUT=bench/out/sysid
mkdir -p "$OUT"
$PY - "$OUT" <<'PYEOF'
import sys, os
import numpy as np
sys.path.insert(0, "bench/sysid")
import peers
from scipy.signal import lfilter
out = sys.argv[1]
rng = np.random.default_rng(11)
n = 1_000_000
u = rng.standard_normal(n)
y = lfilter([0, 0.5, 0.3, 0.1], [1, -1.5, 0.7], u) + lfilter([1], [1, -1.5, 0.7], 0.1 * rng.standard_normal(n))
np.savetxt(f"{out}/arx_1e6.csv", np.column_stack([u, y]), delimiter=",", header="u,y", comments="", fmt="%.17g")
u, y = peers.bj_data(5000, seed=13)
np.savetxt(f"{out}/bj_5000.csv", np.column_stack([u, y]), delimiter=",", header="u,y", comments="", fmt="%.17g")
PYEOF
"${pin[@]}" cargo build --release -q -p spincal --example sysid_bench
echo "machine: $(nproc --all) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); every side on CPU $cpu, one thread"
echo "$(date -u '+%Y-%m-%d %H:%M:%S UTC'); load before: $(uptime)"
"${pin[@]}" "$target/release/examples/sysid_bench" "$OUT/arx_1e6.csv" "$OUT/bj_5000.csv" "$runs" | tee "$OUT/spincal.jsonl"
echo "spincal done; load: $(cut -d' ' -f1-3 /proc/loadavg)"
"${pin[@]}" $PY bench/sysid/bench_peers.py "$OUT/arx_1e6.csv" "$OUT/bj_5000.csv" "$runs" 2>/dev/null | grep '^{' \
    | tee "$OUT/peers.jsonl"
echo "$(date -u '+%Y-%m-%d %H:%M:%S UTC'); load after: $(uptime)"
$PY - "$OUT" <<'PYEOF'
import json, sys
import numpy as np
out = sys.argv[1]
ours = {r["case"]: r for r in map(json.loads, open(f"{out}/spincal.jsonl"))}
peers = [json.loads(l) for l in open(f"{out}/peers.jsonl")]
for case in ["arx", "bj"]:
    o = ours[case]
    fits = {k: v for k, v in o.items() if "fit" in k}
    print(f"\n{case}: spincal best {o['seconds']:.4f} s, median {o['median_seconds']:.4f} s ({o['runs']} runs) {fits}")
    for p in [p for p in peers if p["case"] == case]:
        fits = {k: (round(v, 2) if v is not None else None) for k, v in p.items() if "fit" in k}
        agree = ""
        if "theta" in p and "theta" in o:
            agree = f" max |theta - spincal's| {np.max(np.abs(np.array(p['theta']) - np.array(o['theta']))):.1e}"
        print(f"  {p['peer']:<12} best {p['seconds']:.4f} s, median {p['median_seconds']:.4f} s; ratio best "
              f"{p['seconds'] / o['seconds']:.1f}x, median {p['median_seconds'] / o['median_seconds']:.1f}x{agree} {fits}")
PYEOF
