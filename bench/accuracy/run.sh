#!/usr/bin/env bash
# The saved corrector against the oracle on an independent simulation (bench/accuracy/independent.py):
# per unit, a campaign generated outside spincal, calibrated with `spincal calibrate --campaign`,
# its held-out files corrected with `spincal correct`, and each held-out file and axis scored as
# RMS(corrected − truth) / RMS(oracle − truth).
#
#   bash bench/accuracy/run.sh OUT_DIR UNITS POSES [independent.py generate's flags]
#   bash bench/accuracy/run.sh OUT_DIR UNITS POSES --phone   (phone.py: phyphox zips, no radius stated)
set -euo pipefail
out=${1:?OUT_DIR}
units=${2:-10}
poses=${3:-24}
shift 3 || true
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../lib.sh"
mkdir -p "$out"
for seed in $(seq 1 "$units"); do
    unit=$out/unit-$seed
    rm -rf "$unit"
    "$python" "$here/independent.py" generate "$unit" "$seed" "$poses" "$@"
    "$spincal" calibrate --campaign "$unit/campaign.toml" --out "$unit/cal" --quiet > "$unit/calibrate.log" 2>&1 || true
    mkdir -p "$unit/corrected"
    if [ -f "$unit/cal/model.json" ]; then
        # Held-out CSVs, or with --phone phyphox zips (corrected into CSVs of the same base name).
        for f in "$unit"/held_out/*.csv "$unit"/held_out/*.zip; do
            [ -e "$f" ] || continue
            base=$(basename "$f")
            "$spincal" correct --model "$unit/cal/model.json" "$f" -o "$unit/corrected/${base%.*}.csv" > /dev/null 2>&1
        done
        saved=$(grep -o '"saved": *"[^"]*"' "$unit/cal/results.json" | head -1)
    else
        saved="nothing saved"
    fi
    score=$("$python" "$here/independent.py" evaluate "$unit")
    echo "$score" > "$unit/score.json"
    echo "unit $seed: $saved $(echo "$score" | "$python" -c '
import json, sys
s = json.load(sys.stdin)
line = "worst %.2f mean %.2f pooled x/y/z %s (predicted %s) worse-than-raw %d" % (s["worst_ratio"], s["mean_ratio"], "/".join("%.2f" % v for v in s["pooled_ratio"]), "-" if s["predicted_pooled_ratio"] is None else "/".join("%.2f" % v for v in s["predicted_pooled_ratio"]), s["worse_than_raw"])
if "share_determined" in s:
    inside = s["worst_ratio_inside"]
    line += "; determined %.0f %% of the sphere, %d recorded poses outside, %d held-out files inside (worst there %s), session spread %.3f, systematic/sd RMS %.2f (the correction sd alone %.2f) over %d" % (
        100 * s["share_determined"], s["poses_outside"], s["held_out_inside"], "-" if inside is None else "%.2f" % inside,
        s["session_spread_mps2"], (s["z_sum_squares"] / max(s["z_count"], 1)) ** 0.5,
        (s["z_correction_sum_squares"] / max(s["z_count"], 1)) ** 0.5, s["z_count"])
if "placements" in s:
    line += "; chip radius found/true " + ", ".join("%s %s/%.2f mm" % (k, "-" if p["found_m"] is None else "%.2f" % (1e3 * p["found_m"]), 1e3 * p["true_m"]) for k, p in s["placements"].items())
print(line)')"
done
# Over every unit: the RMS of systematic error / predicted sd (issue 46: within 0.7–1.4).
cat "$out"/unit-*/score.json | "$python" -c '
import json, sys
scores = [json.loads(line) for line in sys.stdin if line.strip()]
z2 = sum(s.get("z_sum_squares", 0.0) for s in scores)
n = sum(s.get("z_count", 0) for s in scores)
if n:
    print("all units: systematic error / predicted sd, RMS %.2f over %d file-axes" % ((z2 / n) ** 0.5, n))'
echo "== load after: $(uptime)"
