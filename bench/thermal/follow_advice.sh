#!/usr/bin/env bash
# The verdict's next still pose on the thermal campaign, followed: for each unit of a
# bench/thermal/campaign.sh output whose saved model advises one (results.json
# error_map.next_pose), the same unit generated again with that pose recorded hot after the rest
# (THERMAL_NEXT_POSE; every other file unchanged), calibrated and scored in OUT-next. Per unit:
# the trusted share now / predicted / after, and the worst held-out axis over the oracle before
# and after.
#
#   bash bench/thermal/campaign.sh OUT N FIRST; bash bench/thermal/follow_advice.sh OUT
# Env: PYTHON, SPINCAL (bench/lib.sh).
set -euo pipefail
out=${1:?OUT_DIR (a bench/thermal/campaign.sh output)}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../lib.sh"
for unit in $(ls -d "$out"/unit-* | sort -V); do
    seed=${unit##*-}
    direction=$("$python" -c '
import json, sys
m = (json.load(open(sys.argv[1])).get("error_map") or {}).get("next_pose")
print(",".join("%.6f" % v for v in m["pose_direction"]) if m else "")' "$unit/cal/results.json")
    if [ -z "$direction" ]; then
        echo "unit $seed: no pose advised"
        continue
    fi
    THERMAL_NEXT_POSE=$direction bash "$here/campaign.sh" "$out-next" 1 "$seed" > /dev/null
    "$python" - "$unit" "$out-next/unit-$seed" "$seed" <<'PY'
import json, sys
unit, nxt, seed = sys.argv[1:]
b, a = json.load(open(unit + "/cal/results.json")), json.load(open(nxt + "/cal/results.json"))
m0, m1 = b["error_map"], a.get("error_map") or {}
def worst(d):
    r = json.load(open(d + "/score.json"))["rms_mps2"]
    return max(r["spincal"]["sample"][k] / r["oracle"]["sample"][k] for k in range(3))
print("unit %s: saved %s → %s; trusted share %.2f → predicted %.2f, after %s; worst axis ÷ oracle %.2f → %.2f" % (
    seed, b["saved"], a["saved"], m0["share_determined"], m0["next_pose"]["share_determined_after"],
    "%.2f" % m1["share_determined"] if m1 else "-", worst(unit), worst(nxt)))
PY
done
