#!/usr/bin/env bash
# spincal vs pysib and SIPPY in one run: ARX [6 8 1] on 10⁶ samples, BJ [4 4 4 4 1] on 5,000
# samples (first half training, second half validation). Prints times and ratios.
set -euo pipefail
cd "$(dirname "$0")/../.."
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
cargo build --release -q -p spincal --example sysid_bench
target/release/examples/sysid_bench "$OUT/arx_1e6.csv" "$OUT/bj_5000.csv" | tee "$OUT/spincal.jsonl"
$PY bench/sysid/bench_peers.py "$OUT/arx_1e6.csv" "$OUT/bj_5000.csv" 2>/dev/null | grep '^{' | tee "$OUT/peers.jsonl"
$PY - "$OUT" <<'PYEOF'
import json, sys
out = sys.argv[1]
ours = {r["case"]: r for r in map(json.loads, open(f"{out}/spincal.jsonl"))}
peers = [json.loads(l) for l in open(f"{out}/peers.jsonl")]
for case in ["arx", "bj"]:
    print(f"\n{case}: spincal {ours[case]['seconds']:.4f} s", {k: v for k, v in ours[case].items() if "fit" in k})
    for p in [p for p in peers if p["case"] == case]:
        fits = {k: v for k, v in p.items() if "fit" in k}
        print(f"  {p['peer']:<12} {p['seconds']:.4f} s  ratio {p['seconds'] / ours[case]['seconds']:.1f}x  {fits}")
PYEOF
