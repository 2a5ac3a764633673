#!/usr/bin/env bash
# Issue 46's experiment for the terms rule: campaigns from the independent generator
# (bench/accuracy/independent.py, 24 poses one file each, four runs, a ruler's radius) with q set
# to Q on x and zero on y and z. Per draw: q̂/se per axis and the axes whose q the saved model
# carries. The rule should keep x in at least 90 % of draws when Q is 5 standard errors, and y or
# z in at most 5 % (its false-alarm probability is 1e-3 per axis).
#
#   bash bench/accuracy/terms_rule.sh OUT_DIR DRAWS Q
set -euo pipefail
out=${1:?OUT_DIR}
draws=${2:-20}
q=${3:-1e-4}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../lib.sh"
mkdir -p "$out"
for seed in $(seq 1 "$draws"); do
    unit=$out/draw-$seed
    rm -rf "$unit"
    "$python" "$here/independent.py" generate "$unit" "$seed" 24 --ruler-sd 0.002 --q "$q,0,0"
    "$spincal" calibrate --campaign "$unit/campaign.toml" --out "$unit/cal" --quiet > "$unit/calibrate.log" 2>&1 || true
done
"$python" - "$out" "$q" <<'PY'
import glob, json, os, sys
out, q = sys.argv[1], float(sys.argv[2])
rows = []
for path in sorted(glob.glob(os.path.join(out, "draw-*", "cal", "results.json"))):
    r = json.load(open(path))
    rule = r.get("terms_rule")
    if rule is None:
        continue
    se_x = r["joint"]["sensor_params"][9]["std_error"]
    kept = rule.get("nonlinearity_axes") or [rule["keeps_nonlinearity"]] * 3
    rows.append((q / se_x, rule["nonlinearity_z"], kept, r.get("saved")))
    print("%s: true q_x/se %.1f, q̂/se %s, kept %s, saved %s" % (path.split("/")[-3], q / se_x, ["%.1f" % z for z in rule["nonlinearity_z"]], kept, r.get("saved")))
n = len(rows)
print("draws %d; true q_x/se median %.1f" % (n, sorted(r[0] for r in rows)[n // 2]))
print("q_x kept in %d of %d draws (%.0f %%)" % (sum(r[2][0] for r in rows), n, 100 * sum(r[2][0] for r in rows) / n))
false = sum(r[2][1] + r[2][2] for r in rows)
print("q_y or q_z (zero) kept in %d of %d axis-draws (%.1f %%)" % (false, 2 * n, 100 * false / (2 * n)))
PY
